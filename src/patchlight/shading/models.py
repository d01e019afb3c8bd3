"""The lighting models, composed from the terms exactly as lighting.glsl, compose.glsl and
surface_fragment.glsl compose them (see those files for the formulas and sources).

`light_surface` is one model's light sum at surface points; `compose_surface` turns colour,
emission and that sum into radiance; `shade_fragments` runs the fragment shader on N covered
pixels. The CPU renderer and the tests call these; the viewer runs the GLSL.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import setting, validate_fields
from ..errors import PatchlightError
from .ambient_cube import ambient_cube_light, sky_cube, sky_cube_light
from .directional import DirectionalLightmap, directional_light, directional_specular
from .hemisphere_radiosity import (GroundMapInputs, apply_fog, check_ambient, fog_factor, hemisphere_radiosity,
                                   hemisphere_radiosity_color, neutral_ground_map)
from .lights import PunctualLight, incident_light
from .terms import (blinn_phong_specular, decode_normal, envmap_color, fresnel_term, hemisphere_light,
                    lambert_diffuse, normalize, perturb_normal, phong_specular, reflect_view, self_shadow)
from .textures import sample_bilinear, sample_cube

DEFAULT_AMBIENT = 0.05  # incident light of the ambient term without a sky: dim, so unlit sides stay visible

# Index = the GLSL MODEL_* number (common.glsl).
MODELS = ("unlit", "ambient", "lambert", "phong", "blinn-phong", "self-shadow", "hemisphere", "lightmap", "envmap",
          "hemisphere-radiosity", "ambient-cube", "lightmap-directional")
LIT_MODELS = MODELS[1:]
LIGHTMAP_MODELS = ("lightmap", "lightmap-directional")  # the models that read the lightmap (TEXCOORD_1)
# Models the punctual lights do not reach (lightmap-directional: they are in its maps, their
# highlight is the dominant direction's).
UNLIT_BY_LIGHTS = ("unlit", "ambient", "hemisphere", "ambient-cube", "lightmap-directional")


def _grey():
    return np.full(3, DEFAULT_AMBIENT, np.float32)


@dataclass
class ShadingSettings:
    """Everything but geometry and textures that decides a shaded pixel (table:
    docs/settings.md). exposure is never applied to EXR radiance."""

    model: str = setting("lambert", "", "the lighting model", choices=MODELS)
    lights: list[PunctualLight] = setting(unit="", meaning="the punctual lights", factory=list)
    ambient: np.ndarray = setting(unit="radiance", meaning="incident light (3,) of the ambient term", length=3,
                                  factory=_grey)
    sky: np.ndarray = setting(unit="radiance", meaning="incident light (3,) at the hemisphere's up pole", length=3,
                              factory=_grey)
    ground: np.ndarray = setting(unit="radiance", meaning="incident light (3,) at the hemisphere's down pole",
                                 length=3, factory=_grey)
    per_vertex: bool = setting(False, "bool", "evaluate the light sum at vertices and interpolate")
    normal_map: bool = setting(False, "bool", "perturb normals by the materials' normal maps, colour alpha as gloss")
    lightmap_specular: bool = setting(False, "bool", "add a highlight to the lightmap models: the lights' Blinn-Phong (lightmap), the dominant direction's (lightmap-directional)")
    exposure: float = setting(1.0, "1 / radiance", "k of the display curve 1 - exp(-k x) for PNGs and the viewer",
                              lo=0, lo_open=True)
    reflectivity: float | None = setting(None, "ratio", "envmap strength of every material", lo=0.0, hi=1.0,
                                         none="each material's own")
    ground_map: GroundMapInputs | None = setting(None, "", "the hemisphere-radiosity model's baked ground map",
                                                 none="a plain hemisphere of the ground colour")
    volume: object | None = setting(None, "", "the ambient-cube model's light volume (volumes.LightVolume)",
                                    none="the sky as one probe")
    ambient_cube_naive: bool = setting(False, "bool", "weight the ambient cube's axes by saturate(N), not N^2")
    directional: DirectionalLightmap | None = setting(None, "", "the lightmap-directional model's maps (a bake's)",
                                                      none="none")

    def cube_light(self, P: np.ndarray, N: np.ndarray) -> np.ndarray:
        """The ambient-cube model's incident light (N, 3) at points P with normals N: from the
        baked volume, else from the sky as one probe (sky_cube)."""
        if self.volume is None:
            return sky_cube_light(sky_cube(self.sky, self.ground, self.ambient), N, self.ambient_cube_naive)
        return ambient_cube_light(self.volume, P, N, self.ambient_cube_naive)

    def radiosity_inputs(self) -> GroundMapInputs:
        """The hemisphere-radiosity model's map: the baked one, else one texel of `ground`."""
        return self.ground_map or neutral_ground_map(self.sky, self.ground)

    def validate(self) -> None:
        validate_fields(self)
        if self.per_vertex and self.normal_map:
            raise PatchlightError("`normal_map` needs per-pixel lighting; drop `per_vertex`")
        if self.per_vertex and self.model == "lightmap-directional":
            raise PatchlightError("`model` lightmap-directional lights per pixel; drop `per_vertex`")
        if self.model == "hemisphere-radiosity":
            check_ambient(self.ambient)
            self.radiosity_inputs().validate()


@dataclass
class MaterialTable:
    """The scene's materials as arrays: base_color (M, 4), emissive (M, 3), shininess (M,),
    reflectivity (M,); per-material textures (H, W, C) f32 or None."""

    base_color: np.ndarray
    emissive: np.ndarray
    shininess: np.ndarray
    reflectivity: np.ndarray
    color_maps: list
    emissive_maps: list
    normal_maps: list

    @classmethod
    def from_materials(cls, materials, reflectivity: float | None = None) -> "MaterialTable":
        refl = [m.reflectivity if reflectivity is None else reflectivity for m in materials]
        return cls(np.array([m.base_color for m in materials], np.float32).reshape(-1, 4),
                   np.array([m.emissive for m in materials], np.float32).reshape(-1, 3),
                   np.array([m.shininess for m in materials], np.float32),
                   np.array(refl, np.float32),
                   [m.base_color_texture for m in materials],
                   [m.emissive_texture for m in materials],
                   [m.normal_texture for m in materials])

    def sample(self, maps: list, material: np.ndarray, uv: np.ndarray, default) -> np.ndarray:
        """(N, C) texels of each point's material map (`default` (C,) where it has none)."""
        out = np.broadcast_to(np.asarray(default, np.float32), (len(material), len(default))).copy()
        for m in np.unique(material):
            if maps[m] is not None:
                sel = material == m
                out[sel] = sample_bilinear(maps[m], uv[sel])[:, :len(default)]
        return out


@dataclass
class Lighting:
    """A light sum (lighting.glsl): diffuse, specular (N, 3); reflected (N, 3); fresnel (N,)."""

    diffuse: np.ndarray
    specular: np.ndarray
    reflected: np.ndarray
    fresnel: np.ndarray

    def interpolate(self, corners: np.ndarray, bary: np.ndarray) -> "Lighting":
        """Per-vertex sums (rows indexed by corners (N, 3)) interpolated with bary (N, 3)."""
        from .surface import interpolate

        return Lighting(interpolate(self.diffuse, corners, bary), interpolate(self.specular, corners, bary),
                        interpolate(self.reflected, corners, bary),
                        interpolate(self.fresnel[:, None], corners, bary)[:, 0])


@dataclass
class Fragments:
    """The interpolated varyings of N covered pixels (surface_fragment.glsl's inputs).

    position (N, 3) world metres; normal (N, 3) interpolated, not yet normalised; tangent (N, 4)
    (None unless normal mapping); uv0 (N, 2); uv1 (N, 2) (None unless the lightmap model needs
    it); color (N, 4) vertex colour; material (N,) i32; front (N,) bool, False on the back of a
    double-sided surface; vertex_lighting: the interpolated per-vertex sum, or None."""

    position: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray | None
    uv0: np.ndarray
    uv1: np.ndarray | None
    color: np.ndarray
    material: np.ndarray
    front: np.ndarray
    vertex_lighting: Lighting | None = None


def add_light(model: str, lit: Lighting, L: np.ndarray, I: np.ndarray, N: np.ndarray, V: np.ndarray,
              gloss, shininess, lightmap_specular: bool) -> None:
    """lighting.glsl: add one light's share (L, I (N, 3)) to `lit` in place."""
    n_dot_l = lambert_diffuse(N, L)[:, None]
    if model == "self-shadow":
        s = self_shadow(N, L)[:, None]
        lit.diffuse += s * n_dot_l * I
        lit.specular += s * np.minimum(phong_specular(N, L, V, shininess), gloss)[:, None] * I
    elif model in ("phong", "blinn-phong"):
        specular = phong_specular if model == "phong" else blinn_phong_specular
        lit.diffuse += n_dot_l * I
        lit.specular += np.minimum(specular(N, L, V, shininess), gloss)[:, None] * I
    elif model == "lightmap":
        if lightmap_specular:
            lit.specular += np.minimum(blinn_phong_specular(N, L, V, shininess), gloss)[:, None] * I
    else:
        lit.diffuse += n_dot_l * I


def light_surface(settings: ShadingSettings, P: np.ndarray, N: np.ndarray, V: np.ndarray, gloss,
                  shininess, reflectivity) -> Lighting:
    """lighting.glsl: the model's light sum at points P with unit normals N and unit view
    vectors V (N, 3); gloss, shininess, reflectivity scalars or (N,)."""
    n = len(P)
    lit = Lighting(np.zeros((n, 3), np.float32), np.zeros((n, 3), np.float32), reflect_view(N, V),
                   np.broadcast_to(fresnel_term(N, V, reflectivity), (n,)).astype(np.float32))
    model = settings.model
    if model == "hemisphere":
        lit.diffuse[:] = hemisphere_light(N, settings.sky, settings.ground)
    elif model == "ambient-cube":
        lit.diffuse[:] = settings.cube_light(P, N)
        lit.specular[:] = np.reshape(reflectivity, (-1, 1)) * settings.cube_light(P, lit.reflected)
    elif model not in ("unlit", *LIGHTMAP_MODELS):
        lit.diffuse[:] = settings.ambient
    if model not in UNLIT_BY_LIGHTS:
        for light in settings.lights:
            L, I = incident_light(light, P)
            add_light(model, lit, L, I, N, V, gloss, shininess, settings.lightmap_specular)
    return lit


def compose_surface(model: str, color: np.ndarray, emission: np.ndarray, lit: Lighting, baked, env,
                    reflectivity) -> np.ndarray:
    """compose.glsl: radiance (N, 3) from colour (N, 4), emission (N, 3), the light sum, the
    baked lightmap light (N, 3) (lightmap model) and the environment texels (N, 4) (envmap)."""
    rgb = color[:, :3]
    if model == "unlit":
        return rgb.copy()
    if model in LIGHTMAP_MODELS:
        return rgb * baked + lit.specular + emission
    if model == "envmap":
        return envmap_color(rgb * lit.diffuse, env, lit.fresnel, reflectivity) + emission
    return rgb * lit.diffuse + lit.specular + emission


def shade_fragments(settings: ShadingSettings, frags: Fragments, materials: MaterialTable, eye: np.ndarray,
                    lightmap: np.ndarray | None = None, env: np.ndarray | None = None) -> np.ndarray:
    """surface_fragment.glsl on N pixels: linear radiance (N, 3) f32.

    eye (3,) camera position; lightmap (H, W, 3) incident light at uv1, needed by the
    lightmap models (lightmap-directional also by settings.directional); env (6, S, S, 4) cube map (RGB radiance, A highlight), needed by envmap and
    hemisphere-radiosity."""
    model = settings.model
    mat = frags.material
    color = surface_color(materials, mat, frags.uv0, frags.color)
    if model == "unlit":
        return color[:, :3].copy()
    shininess = materials.shininess[mat]
    reflectivity = materials.reflectivity[mat]
    if frags.vertex_lighting is not None:
        lit = frags.vertex_lighting
    else:
        facing = np.where(frags.front, 1.0, -1.0).astype(np.float32)[:, None]
        N0 = N = normalize(frags.normal) * facing
        gloss = np.float32(1.0)
        if settings.normal_map:  # glTF: a back face turns the whole frame (T, B, N), so the mapped normal flips
            texel = materials.sample(materials.normal_maps, mat, frags.uv0, (0.5, 0.5, 1.0))
            N = perturb_normal(normalize(frags.normal), frags.tangent, decode_normal(texel)) * facing
            gloss = color[:, 3]
        V = normalize(eye.astype(np.float32) - frags.position)
        lit = light_surface(settings, frags.position, N, V, gloss, shininess, reflectivity)
    emission = surface_emission(materials, mat, frags.uv0)
    if model == "hemisphere-radiosity":  # compose.glsl's branch, then surface_fragment.glsl's fog
        m = settings.radiosity_inputs()
        radiance = hemisphere_radiosity_color(m, color[:, :3], sample_cube(env, lit.reflected), lit.diffuse,
                                              lit.fresnel, hemisphere_radiosity(m, frags.position, frags.normal),
                                              reflectivity, settings.ambient) + emission
        return apply_fog(m, radiance, fog_factor(m, frags.position, eye))
    baked = lightmap_light(lightmap, frags.uv1) if model in LIGHTMAP_MODELS else None
    if model == "lightmap-directional":  # surface_fragment.glsl's branch
        d = settings.directional
        texels = d.texels(frags.uv1)
        if settings.lightmap_specular:
            lit.specular = lit.specular + directional_specular(d.mode, texels, baked, N, V, gloss, shininess)
        baked = directional_light(d.mode, texels, baked, N, N0)
    env_texels = sample_cube(env, lit.reflected) if model == "envmap" else None
    return compose_surface(model, color, emission, lit, baked, env_texels, reflectivity).astype(np.float32)


def surface_color(materials: MaterialTable, material: np.ndarray, uv0: np.ndarray, vertex_color: np.ndarray) -> np.ndarray:
    """material.glsl: base colour x colour map x vertex colour, (N, 4) linear RGBA."""
    return materials.base_color[material] * materials.sample(materials.color_maps, material, uv0, np.ones(4)) * vertex_color


def surface_emission(materials: MaterialTable, material: np.ndarray, uv0: np.ndarray) -> np.ndarray:
    """material.glsl: emissive factor x emissive map, (N, 3) radiance."""
    return materials.emissive[material] * materials.sample(materials.emissive_maps, material, uv0, np.ones(3))


def lightmap_light(lightmap: np.ndarray, uv1: np.ndarray) -> np.ndarray:
    """lightmap.glsl: the baked incident light (N, 3) at lightmap UVs uv1 (N, 2), edges clamped."""
    return sample_bilinear(lightmap, uv1, wrap="clamp")[:, :3]
