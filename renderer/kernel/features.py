"""Kernel features: what a render's kernels must be able to do, known before they are compiled.

rtc compiles for each render kernels that hold only the code paths its scene and options can reach
(Cycles' feature-adaptive kernels, pbrt-v4's templates, in numba's terms).  A kernel function tests a
feature as a module-level constant, in one of two forms:

    if F_TEXTURES and td >= 0:                                            # a yes/no feature
    if F_MODELS & B_DIELECTRIC and (F_MODELS == B_DIELECTRIC or model == D.DIELECTRIC):
                                                                          # one of a set: a bit mask

numba folds a condition made of constants before it types a function (dead-branch pruning), so the
code of a feature the scene does not use - and every function only that code calls - is never typed,
lowered or optimised: it costs no compile time and no run time.  With the second form a kernel that can
only meet one member of the set (`F_MODELS == B_DIELECTRIC`) does not even test the runtime value.

The kernel modules import these names with the values of `ALL` below: every feature possible.  That is
the *general* kernel, which tests and tools call directly and which renders any scene.
`specialize.specialize(entry, features)` returns an entry point whose functions see a scene's own
`Features` instead (host/build.py `scene_features` computes them from the very tables the kernels
read, so a specialised kernel computes exactly what the general one computes, bit for bit).

A feature is worth a constant only where its code costs compile time: see benchmarks/RESULTS.md
(issue 12) for what each one saves.
"""
from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, fields

from .. import description as D

# members of the sets, as the bit masks kernels test (1 << the id the tables and options use)
SAMPLER_IDS = {'independent': 0, 'stratified': 1, 'cmj': 2, 'sobol': 3}      # = samplers.SAMPLER_NAMES
FILTER_IDS = {'box': 0, 'tent': 1, 'gaussian': 2}                           # = filters.FILTER_NAMES
LIGHT_IDS = {'point': D.POINT, 'rect': D.RECT, 'disk': D.DISK, 'sphere': D.SPHERE, 'distant': D.DISTANT,
             'dome': D.DOME, 'cylinder': D.CYLINDER}


def bits(ids) -> int:
    """The bit mask of a set of ids."""
    m = 0
    for i in ids:
        m |= 1 << int(i)
    return m


@dataclass(frozen=True)
class Features:
    """What a kernel must handle.  Masks hold `1 << id` of every member that may occur; booleans say
    whether a yes/no feature may occur.  Constants `F_<FIELD>` in the kernels."""
    samplers: int            # samplers.SAMPLER_NAMES ids
    filters: int             # filters.FILTER_NAMES ids
    models: int              # description material models (MI_MODEL)
    lights: int              # description light types (li_type)
    course_lights: bool      # a light the cook integrator shades with the course's semantics (LF_COURSE)
    lux_lights: bool         # a light the cook integrator shades with UsdLux radiometry (every light in path)
    dome_texture: bool       # a dome light with a lat-long image
    rect_texture: bool       # a rect light with an image (`lights.rect_radiance`, `rect_sampling.py`)
    shaping: bool            # a light shaped by UsdLux.ShapingAPI (a spotlight's cone, focus: `lights.shaped`)
    ies: bool                # a light shaped by an IES profile (`ies_profiles.py`)
    light_gains: bool        # a light whose effect on diffuse and specular lobes differs (UsdLux inputs:diffuse,
                             # inputs:specular other than 1: `lights.lobe_gains`)
    light_shapes: bool       # a light BSDF rays can hit (path: rect, disk, sphere, cylinder)
    surface_lights: bool     # path: an emissive surface is a light (host/surface_lights.py)
    tile_lights: bool        # path: a tile's first vertices choose their lights from its table (`tile_lights.py`)
    textures: bool           # a material with an image texture
    normal_maps: bool        # a UsdPreviewSurface whose normal a texture gives (`normal_maps.py`)
    udim: bool               # a UDIM texture (tiles 1001, 1002, ...: `textures.udim_tile`)
    opacity: bool            # a UsdPreviewSurface with opacity < 1
    emission: bool           # a material with emissive colour
    clearcoat: bool          # a UsdPreviewSurface with clearcoat > 0
    spheres: bool            # an implicit sphere gprim
    curves: bool             # a curves gprim (UsdGeom.BasisCurves)
    normals: bool            # a mesh with shading normals
    uvs: bool                # a mesh with texture coordinates
    colors: bool             # a mesh (or point cloud) with per-corner displayColor whose material shades by it
    xf_motion: bool          # placements with more than one transform step
    ortho: bool              # the camera is orthographic
    lens: bool               # the lens is sampled (depth of field)
    time: bool               # the shutter is sampled (motion blur)

    def constants(self) -> dict:
        """{'F_SAMPLERS': ..., ...}: the module-level names kernels test."""
        return {'F_' + k.upper(): (int(v) if isinstance(v, bool) else v) for k, v in asdict(self).items()}

    def key(self) -> str:
        """A short name of this feature set (part of the specialised functions' names, hence of their
        cache files)."""
        text = ','.join(f'{k}={v}' for k, v in sorted(self.constants().items()))
        return hashlib.sha1(text.encode()).hexdigest()[:10]

    def describe(self) -> str:
        """The features that are on, for messages and benchmarks ('sobol gaussian lambertian ...')."""
        names = []
        for label, mask, table in (('', self.samplers, SAMPLER_IDS), ('', self.filters, FILTER_IDS),
                                   ('', self.models, D.MODEL_NAMES), ('light:', self.lights, LIGHT_IDS)):
            names += [label + n for n, i in table.items() if mask >> i & 1]
        names += [f.name for f in fields(self) if f.type == 'bool' and getattr(self, f.name)]
        return ' '.join(names)


ALL = Features(samplers=bits(SAMPLER_IDS.values()), filters=bits(FILTER_IDS.values()),
               models=bits(D.MODEL_NAMES.values()), lights=bits(LIGHT_IDS.values()), course_lights=True,
               lux_lights=True, dome_texture=True, rect_texture=True, shaping=True, ies=True, light_gains=True,
               light_shapes=True, surface_lights=True, tile_lights=True, textures=True, normal_maps=True, udim=True,
               opacity=True, emission=True, clearcoat=True, spheres=True, curves=True, normals=True, uvs=True,
               colors=True, xf_motion=True, ortho=True, lens=True, time=True)

# the general kernel's values, imported by the kernel modules
globals().update(ALL.constants())
FEATURE_NAMES = frozenset(ALL.constants())

# bit of each member, for the kernels' tests (B_SOBOL = 1 << samplers.SOBOL, ...)
B_INDEPENDENT, B_STRATIFIED, B_CMJ, B_SOBOL = (1 << SAMPLER_IDS[n] for n in ('independent', 'stratified', 'cmj',
                                                                             'sobol'))
B_BOX, B_TENT, B_GAUSSIAN = (1 << FILTER_IDS[n] for n in ('box', 'tent', 'gaussian'))
B_LAMBERTIAN, B_BLINN_PHONG, B_MIRROR, B_GLAZE, B_BLINN_PHONG_MIRRORED, B_DIELECTRIC, B_COOL_TO_WARM, \
    B_PREVIEW_SURFACE = (1 << m for m in (D.LAMBERTIAN, D.BLINN_PHONG, D.MIRROR, D.GLAZE, D.BLINN_PHONG_MIRRORED,
                                          D.DIELECTRIC, D.COOL_TO_WARM, D.PREVIEW_SURFACE))
B_MIRRORING = B_MIRROR | B_GLAZE | B_BLINN_PHONG_MIRRORED        # course models with a mirror continuation
B_PHONG = B_BLINN_PHONG | B_BLINN_PHONG_MIRRORED                    # a Blinn-Phong highlight (path: a lobe)
B_GGX = B_PREVIEW_SURFACE | B_BLINN_PHONG_MIRRORED                # a GGX lobe (path: rough glossy mirrors too)
B_COURSE_MODELS = B_LAMBERTIAN | B_BLINN_PHONG | B_MIRRORING | B_DIELECTRIC | B_COOL_TO_WARM
B_POINT, B_RECT, B_DISK, B_SPHERE, B_DISTANT, B_DOME, B_CYLINDER = (1 << LIGHT_IDS[n] for n in LIGHT_IDS)
B_PLANAR = B_RECT | B_DISK
