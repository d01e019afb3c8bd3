"""NumPy reference of every runtime lighting model: one function per GLSL function of the
same name in `patchlight/shaders/`, so the CPU renderer and the viewer give the same pixels."""
from .lights import FALLOFFS, LIGHT_KINDS, MAX_LIGHTS, PunctualLight
from .models import LIT_MODELS, MODELS, Fragments, Lighting, MaterialTable, ShadingSettings, shade_fragments
from .surface import SurfaceArrays, vertex_tangents

__all__ = ["FALLOFFS", "LIGHT_KINDS", "LIT_MODELS", "MAX_LIGHTS", "MODELS", "Fragments", "Lighting",
           "MaterialTable", "PunctualLight", "ShadingSettings", "SurfaceArrays", "shade_fragments",
           "vertex_tangents"]
