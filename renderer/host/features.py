"""The kernel features of a render: what its scene and options need of the kernels
(`kernel/features.py`), read from the very tables the kernels will read, so that a kernel specialised
for them computes exactly what the general kernel computes.

`RTC_KERNELS=general` in the environment renders every scene with the general kernel instead (one
compile serves every scene: the test suite uses it; tests/renderer/test_specialize.py checks that
the specialised kernels give the general kernel's images bit for bit).
"""
from __future__ import annotations

import os

import numpy as np

from .. import description as D
from ..kernel.features import FILTER_IDS, SAMPLER_IDS, Features, bits
from ..kernel.tables import (C_LENS, C_ORTHO, GP_CURVES, GP_HAS_COLORS, GP_HAS_NORMALS, GP_HAS_UVS, GP_MESH, GP_SPHERE,
                             LF_COURSE, LF_GAIN, LF_IES, LF_SHAPED, MF_CLEARCOAT, MF_EMIT, MF_GAIN, MF_OPACITY,
                             MF_OPACITY_CUT, MI_DIFFUSE_TEX, MI_EMISSION_TEX, MI_MODEL, MI_NORMAL_TEX, MI_SCALAR_TEX,
                             MI_SPECULAR_TEX, MI_VERTEX_COLOR, S_OPACITY, TI_UDIM, VC_OPACITY)


def general_kernels() -> bool:
    """True if the environment asks for the general kernel for every scene (RTC_KERNELS=general)."""
    return os.environ.get('RTC_KERNELS', '').strip().lower() == 'general'


def constant_opacity(mf: np.ndarray) -> np.ndarray:
    """The opacity of each material row of mf without a texture: its input, or with an opacityThreshold > 0,
    0 below it and 1 at or above it (`kernel/materials.opacity`)."""
    a, cut = mf[:, MF_OPACITY].astype(np.float64), mf[:, MF_OPACITY_CUT].astype(np.float64)
    return np.where(cut > 0.0, (a >= cut).astype(np.float64), a)


def see_through(data) -> bool:
    """Whether a surface of the built scene tables `data` lets some rays through: a UsdPreviewSurface that
    a gprim can have, with opacity < 1, an opacity texture or per-corner opacities (`VC_OPACITY`)."""
    used = np.unique(np.concatenate([data.gp_material, data.matset[data.matset >= 0]]))
    mi, mf = data.mat_i[used], data.mat_f[used]
    open_ = (constant_opacity(mf) < 1.0) | (mi[:, MI_SCALAR_TEX + S_OPACITY] >= 0) | \
        (mi[:, MI_VERTEX_COLOR] & VC_OPACITY != 0)
    return bool(np.any(open_[mi[:, MI_MODEL] == D.PREVIEW_SURFACE]))


def scene_features(data, options, ctab: np.ndarray, use_time: bool, lights=None) -> Features:
    """The `Features` of a render of the built scene tables `data` (`build.SceneData`) with resolved
    `options`, camera table `ctab` and shutter sampling `use_time`; `lights`: the path integrator's
    `PathLights` record (None for cook)."""
    path = options.integrator == 'path'
    used = np.unique(np.concatenate([data.gp_material, data.matset[data.matset >= 0]]))     # materials hit can have
    mi, mf = data.mat_i[used], data.mat_f[used]
    kinds = data.li_type[data.li_type >= 0]
    rows = np.flatnonzero(data.li_type >= 0)
    course = data.li_f[rows, LF_COURSE] != 0.0
    domes = rows[kinds == D.DOME]
    rects = rows[kinds == D.RECT]
    mesh_flags = data.gp_flags[data.gp_kind == GP_MESH]          # (a sphere's flags are not read)
    return Features(
        samplers=1 << SAMPLER_IDS[options.sampler], filters=1 << FILTER_IDS[options.filter],
        models=bits(np.unique(mi[:, MI_MODEL])), lights=bits(np.unique(kinds)),
        course_lights=bool(not path and np.any(course)), lux_lights=bool(path or np.any(~course)),
        dome_texture=bool(np.any(data.li_tex[domes] >= 0)), rect_texture=bool(np.any(data.li_tex[rects] >= 0)),
        shaping=bool(np.any(data.li_f[rows, LF_SHAPED] != 0.0)),
        ies=bool(np.any(data.li_f[rows, LF_IES] >= 0.0)),
        light_gains=bool(np.any(data.li_f[rows, LF_GAIN:LF_GAIN + 2] != 1.0)
                         or np.any(mf[:, MF_GAIN:MF_GAIN + 2] != 1.0)),
        light_shapes=bool(path and lights is not None and lights.shapes.shape[0] > 0),
        surface_lights=bool(path and lights is not None and lights.n_surface > 0),
        tile_lights=bool(path and lights is not None and lights.leaf_k.shape[0] > 0),
        textures=bool(np.any(mi[:, [MI_DIFFUSE_TEX, MI_SPECULAR_TEX, MI_EMISSION_TEX]] >= 0)
                      or np.any(mi[:, MI_SCALAR_TEX:MI_SCALAR_TEX + 5] >= 0) or np.any(mi[:, MI_NORMAL_TEX] >= 0)),
        normal_maps=bool(np.any(mi[:, MI_NORMAL_TEX] >= 0)),
        udim=bool(np.any(data.tex_i[:, TI_UDIM] >= 0)),
        opacity=see_through(data),
        emission=bool(np.any(mf[:, MF_EMIT:MF_EMIT + 3] != 0.0)),
        clearcoat=bool(np.any(mf[:, MF_CLEARCOAT] != 0.0)),
        spheres=bool(np.any(data.gp_kind == GP_SPHERE)), curves=bool(np.any(data.gp_kind == GP_CURVES)),
        normals=bool(np.any(mesh_flags & GP_HAS_NORMALS)), uvs=bool(np.any(mesh_flags & GP_HAS_UVS)),
        colors=bool(np.any(data.gp_flags & GP_HAS_COLORS) and np.any(mi[:, MI_VERTEX_COLOR] != 0)),
        xf_motion=data.in_xf.shape[1] > 1, ortho=bool(ctab[C_ORTHO] != 0.0), lens=bool(ctab[C_LENS] > 0.0),
        time=bool(use_time))
