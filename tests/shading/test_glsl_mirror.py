"""The GLSL chunks are the single source; the NumPy reference mirrors them name for name."""
from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import patchlight.shaders as _shaders_pkg
import patchlight.shading as _shading_pkg
from patchlight.shading.lights import FALLOFFS, LIGHT_KINDS, MAX_LIGHTS
from patchlight.shading.models import MODELS

SHADERS = Path(_shaders_pkg.__path__[0])
FUNCTION = re.compile(r"^(?:float|vec[234]|void|Incident|Lighting)\s+(\w+)\s*\(", re.M)
DEFINE = re.compile(r"^#define\s+(\w+)\s+(\S+)", re.M)
INCLUDE = re.compile(r'^#include\s+"([\w.]+)"', re.M)
# A formula chunk names where its formula comes from: its author, a specification, or a page
# of this repository (never a file outside it).
SOURCES = ("Lambert", "Phong", "Blinn", "Frazier", "Ginsburg", "Half-Life 2", "KHR_lights_punctual", "IEC 61966",
           "docs/architecture.md", "patchlight.bake", "patchlight.ground", "patchlight.imaging",
           "patchlight.shading.directional", "patchlight.shading.surface")


def chunks() -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(SHADERS.glob("*.glsl"))}


def reference_names() -> set[str]:
    """Every name defined by a module of patchlight.shading."""
    names = set()
    for info in pkgutil.iter_modules(_shading_pkg.__path__):
        names |= set(dir(importlib.import_module(f"patchlight.shading.{info.name}")))
    return names


def test_every_glsl_function_has_a_numpy_twin():
    python = reference_names()
    glsl = {name for text in chunks().values() for name in FUNCTION.findall(text)} - {"main"}
    assert len(glsl) >= 20
    assert sorted(glsl - python) == []


def test_model_light_and_falloff_numbers_match():
    defines = {k: v for text in chunks().values() for k, v in DEFINE.findall(text)}
    assert [defines[f"MODEL_{m.upper().replace('-', '_')}"] for m in MODELS] == [str(i) for i in range(len(MODELS))]
    assert [defines[f"LIGHT_{k.upper()}"] for k in LIGHT_KINDS] == ["0", "1", "2"]
    assert [defines[f"FALLOFF_{f.upper().replace('-', '_')}"] for f in FALLOFFS] == ["0", "1"]
    assert defines["MAX_LIGHTS"] == str(MAX_LIGHTS)
    assert len([k for k in defines if k.startswith("MODEL_")]) == len(MODELS)


def test_includes_resolve_and_the_surface_programs_use_every_model_chunk():
    texts = chunks()
    used = set()

    def visit(name):
        assert name in texts, f"missing chunk {name}"
        if name not in used:
            used.add(name)
            for child in INCLUDE.findall(texts[name]):
                visit(child)

    visit("surface_vertex.glsl")
    visit("surface_fragment.glsl")
    model_chunks = {"lambert.glsl", "phong.glsl", "blinn_phong.glsl", "self_shadow.glsl", "hemisphere.glsl",
                    "envmap.glsl", "lightmap.glsl", "normal_map.glsl", "falloff.glsl", "light_directional.glsl",
                    "light_point.glsl", "light_spot.glsl", "lighting.glsl", "compose.glsl", "display.glsl"}
    assert model_chunks <= used


def test_every_formula_chunk_cites_its_source():
    for name, text in chunks().items():
        if FUNCTION.search(text) and name not in ("lights.glsl", "common.glsl", "material.glsl",
                                                  "surface_vertex.glsl", "surface_fragment.glsl"):
            assert any(s in text for s in SOURCES), f"{name} cites none of {SOURCES}"
