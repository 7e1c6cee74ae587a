"""Emissive surfaces as lights of the path integrator: every placement of a mesh or sphere gprim whose
resolved material emits (UsdPreviewSurface `emissiveColor`, or a mesh with UsdLux MeshLightAPI, which the
stage reader turns into that material's emission) is one light of the light tree; a static one is sampled
uniformly by area over its world-space triangles or its world-space sphere (ellipsoids and moving
placements below).  A point cloud (a sphere gprim of many balls, UsdGeom.Points) is a light a ball at each
placement, a placement's balls consecutive lights (a hit's light: its gprim slot's first plus its primitive).

Sidedness: an emissive surface emits the same radiance from both of its sides (as Storm, Cycles and
today's emission at a hit do; the renderer shades every gprim on both sides).  Light samples use
|cos| at the light; the light tree's phi (largest intensity, `light_selection.py`) is A L, its cone the
triangles' normal cone marked two-sided.

Tables (the `PathLights` fields `sl_*`; light j of these is light `surface_first + j` of the tree):
  sl_f   float64 (n, tables.SURFACE_LIGHT_F): emitted radiance, total area A, a sphere's centre and radius
         (and the inverse of its axes, its radius times the placement's linear part: a point's direction
         in the sphere's own frame, for its texture coordinates); an ellipsoid's centre, axes A and their
         inverse, and 4 pi |det A| as its AREA
  sl_i   int64 (n, tables.SURFACE_LIGHT_I): first world triangle, number of triangles (0: a sphere or an
         ellipsoid), 1 for an ellipsoid; its emissiveColor texture (-1: none) and its gprim
  sl_tri float64 (triangles, 3, 3): world (camera-relative) triangles, one copy per placement
  sl_cdf float64 (triangles,): cumulative area of a light's triangles over A, ending at exactly 1
  sl_row int64 (placement rows of `SceneData`): offset into sl_idx of the row's gprims, -1 if none emits
  sl_idx int64: per gprim slot of such a row, its light (tree index; a point cloud's first) or -1
The world triangles are copied per placement: meant for the few emissive meshes scenes have; more than
MAX_TRIANGLES of them are warned about (memory, build time), and more than MAX_BALLS emissive spheres.

A sphere placed by a matrix that is no similarity is an ellipsoid, centre + A n for the unit vectors n:
a light sampled uniformly in n, whose density per unit area on the ellipsoid is 1 / (4 pi |det A| |A^-T n|)
(the area element of the map n -> A n), exact at every point (`kernel/surface_lights.py`).

An emissive UsdPreviewSurface with opacity a < 1, which rays find with probability a (and cross with
1 - a), is a light of radiance a times its emission: the average a ray finds.  Where a BSDF-sampled ray
does find it, its emission gets the MIS weight of a light sample of that point (the weights depend on the
direction only, so both strategies stay unbiased); a shadow ray to a point on it stops short of the point
and crosses other see-through surfaces, parts of the same light among them, with 1 - a each.

A moving placement (motion blur) is a light too: its object-space triangles or sphere, drawn as a static
one's are, are placed at the ray's time by the matrix Embree traced it with (`trace.instance_transform`),
and the density per unit area is divided by the area scale |cof(M) n| of that matrix at the point (n
its unit object normal), for light samples and BSDF hits alike.  Its tree bounds hold it over the
shutter (`_moving_bounds`).

An emissiveColor driven by a texture (UsdUVTexture) emits the texture's value at each point: the
radiance above is the emissiveColor's factor, and the kernel looks the texture up at the point a light
sample draws (the triangle and barycentrics on a mesh, its st primvar interpolated; a sphere's direction
in its own frame) as `kernel/shapes.surface` does at a ray's hit, so both strategies see one emission.
The light tree's phi uses the texture's mean absolute value (`texture_mean`).  An opacity driven by a texture (a
cut-out, `opacityThreshold`) multiplies the emission at each point in the same way (`SLI_OPACITY_MAT`): light samples
see a(x) E(x), the average of what rays, which find the point with probability a(x), see.

A curves gprim (UsdGeom.BasisCurves drawn as Embree's round curves) is a light a segment at each placement, a
placement's segments consecutive lights (a hit's light: its gprim slot's first plus its primitive, as a cloud's
balls): its world control points and radii (CTRL), sampled in u by bins weighted by what each sends the shading point
and uniformly in angle around the tube's circle, the density per unit area f(u) / (2 pi J) at the point, J the
tube's area element there (`kernel/curves.tube_point`, `kernel/surface_lights._curve_point`), for light samples and
hits alike.  A linear segment (CURVE_LINEAR) is the side of its cone, stored as the straight Bezier whose tube of
circles that side is (`cone_sides`); its round ends and joints are lights of their own (CURVE_CAP, `curve_caps`: a
sphere's part outside the cones that meet it), which a segment names at its two ends.  Its tree bounds: the control
points' box grown by its largest radius, phi its largest projected area
(about A / pi) times its luminance.  Only placements by a similarity (the world tube is the tube of the world curve)
that do not move, and untextured emission and opacity.

Not lights (their emission is still added where a ray hits them, with weight 1): materials whose
emission has no luminance; emissive ribbons (Embree tessellates them: no light sample can draw the point a ray finds
on one), curves placed by a non-uniform scale or moving, or of a textured emission (warned).
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .. import description as D
from ..kernel.tables import (CURVE_CAP, CURVE_CUBIC, CURVE_LINEAR, GP_CURVES, GP_LINEAR, GP_MESH, GP_RIBBON,
                             GP_SPHERE, MF_EMIT, MI_EMISSION_TEX, MI_MODEL, MI_SCALAR_TEX, MI_VERTEX_COLOR, S_OPACITY,
                             SLI_GPRIM, SURFACE_LIGHT_F, SURFACE_LIGHT_I, TF_BIAS, TF_SCALE, TI_BYTES, TI_CHANNELS,
                             TI_HEIGHT, TI_OFFSET, TI_UDIM, TI_UDIM_ROWS, TI_WIDTH, VC_OPACITY)
from . import curve_caps
from .features import constant_opacity
from .light_tree import ENTIRE

MAX_TRIANGLES = 100_000
MAX_BALLS = 100_000
MAX_SEGMENTS = 100_000
_LUM = np.array([0.2126, 0.7152, 0.0722])
SurfaceLights = namedtuple('SurfaceLights', ['sl_f', 'sl_i', 'sl_tri', 'sl_cdf', 'sl_row', 'sl_idx', 'bounds'])


def _row_counts(data, mask: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Rows of `table` each gprim of `mask` owns (its offset gp_off up to the next one's; 0 elsewhere)."""
    counts = np.zeros(len(data.gp_kind), np.int64)
    gprims = np.flatnonzero(mask)
    if len(gprims):
        off = data.gp_off[gprims]
        order = np.argsort(off, kind='stable')
        ends = np.append(off[order][1:], len(table))
        counts[gprims[order]] = ends - off[order]
    return counts


def _triangle_counts(data) -> np.ndarray:
    """Triangles of each gprim (0 for a sphere)."""
    return _row_counts(data, data.gp_kind == GP_MESH, data.tri_v)


def _segment_counts(data) -> np.ndarray:
    """Segments of each curves gprim (0 for the others)."""
    return _row_counts(data, data.gp_kind == GP_CURVES, data.crv)


def _ball_counts(data) -> np.ndarray:
    """Spheres of each sphere gprim (1, or a point cloud's points; 0 for a mesh, and for a sphere moved to the
    unit-sphere container: an ellipsoid placed as its instance, a gprim of that container)."""
    return _row_counts(data, (data.gp_kind == GP_SPHERE) & (data.gp_off >= 0), data.sph)


def texture_mean(data, k: int) -> np.ndarray:
    """The mean absolute RGB value of texture k of the scene tables (its texels with the UsdUVTexture scale
    and bias, channels as `kernel/textures.sample_texture` reads them: one or two channels are grey); a UDIM
    texture's, the mean of its tiles' means (missing ones 0: a tile is a unit square of texture coordinates)."""
    first = int(data.tex_i[k, TI_UDIM])
    if first >= 0:
        tiles = range(first + 1, first + 1 + 10 * int(data.tex_i[k, TI_UDIM_ROWS]))
        return np.mean([texture_mean(data, j) for j in tiles], axis=0)
    off, w, h, ch, srgb = (int(data.tex_i[k, c]) for c in (TI_OFFSET, TI_WIDTH, TI_HEIGHT, TI_CHANNELS, TI_BYTES))
    raw = (data.tex_data if srgb < 0 else data.tex_bytes)[off:off + w * h * ch].reshape(-1, ch)
    px = (raw if srgb < 0 else np.stack([data.tex_lut[int(c < srgb), raw[:, c]] for c in range(ch)], 1)).astype(float)
    rgb = px[:, [c if ch >= 3 else 0 for c in range(3)]]
    return np.abs(rgb * data.tex_f[k, TF_SCALE:TF_SCALE + 3] + data.tex_f[k, TF_BIAS:TF_BIAS + 3]).mean(0)


def _emitting(data, rows: np.ndarray, slot: int, g: int, means: dict):
    """(emission of the light that gprim slot `slot` (gprim g) is at each placement row of `rows`, mask of
    the rows where it is a light), with the material resolution of `kernel/shapes.surface`.  A see-through
    UsdPreviewSurface (opacity a < 1: rays find it with probability a, `path.trace_path`) emits a times its
    emission on average: the light's.  The emission rows are (R, 7): the radiance (times its emissiveColor
    texture where it has one, column 3, else -1: the kernel looks the texture up at each point), the
    luminance of its mean over the surface (the light tree's phi; a textured one's from its texture's
    mean value, `means`: {texture: mean}, filled as needed), the material whose opacity texture multiplies
    the emission at each point (column 5, -1: none; the tree's phi leaves it out: an upper bound), and the material
    (column 6: its MeshLightAPI lobe gains, MF_GAIN)."""
    base = data.in_matset[rows]
    mat = np.full(len(rows), -1, np.int64)
    has = base >= 0
    mat[has] = data.matset[base[has] + slot]
    mat = np.where(mat >= 0, mat, data.gp_material[g])
    emit = data.mat_f[mat, MF_EMIT:MF_EMIT + 3].astype(np.float64)
    opacity = constant_opacity(data.mat_f[mat])
    see_through = (data.mat_i[mat, MI_MODEL] == D.PREVIEW_SURFACE) & (opacity < 1.0)
    emit[see_through] *= np.maximum(opacity[see_through], 0.0)[:, None]
    tex = data.mat_i[mat, MI_EMISSION_TEX].astype(np.int64)
    mean = np.ones((len(rows), 3))
    for k in np.unique(tex[tex >= 0]):
        if int(k) not in means:
            means[int(k)] = texture_mean(data, int(k))
        mean[tex == k] = means[int(k)]
    lum = (np.abs(emit) * mean) @ _LUM
    # an opacity texture or per-corner opacities: the kernel multiplies the emission by the opacity at each point
    cut = ((data.mat_i[mat, MI_SCALAR_TEX + S_OPACITY] >= 0) | (data.mat_i[mat, MI_VERTEX_COLOR] & VC_OPACITY != 0)) & \
        (data.mat_i[mat, MI_MODEL] == D.PREVIEW_SURFACE)
    return (np.column_stack([emit, tex, lum, np.where(cut, mat, -1), mat]),
            (lum > 0.0) & np.all(np.isfinite(emit), 1))


def _bounds(tri: np.ndarray, phi: np.ndarray) -> list:
    """Light-tree bounds of each placement's triangles tri (R, n, 3, 3): box, phi, the normals' cone
    (two-sided)."""
    cr = np.cross(tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0])
    out = []
    for r in range(len(tri)):
        ok = np.linalg.norm(cr[r], axis=1) > 0.0
        w = cr[r].sum(0)
        nw = float(np.linalg.norm(w))
        cone = ENTIRE
        if nw > 0.0 and ok.any():
            w = w / nw
            n = cr[r][ok] / np.linalg.norm(cr[r][ok], axis=1)[:, None]
            cos_o = float(np.min(n @ w))
            if cos_o >= 0.0:
                cone = (w, min(cos_o, 1.0))
        pts = tri[r].reshape(-1, 3)
        out.append((pts.min(0), pts.max(0), float(phi[r]), cone, True))
    return out


def surface_lights(data, first: int, warn=None) -> SurfaceLights:
    """The emissive surfaces of the built scene tables `data` (`build.SceneData`) as lights numbered
    from `first` (the number of the scene's other lights); `warn(message)` is told of a scene with more
    than MAX_TRIANGLES emissive triangles or MAX_BALLS emissive spheres."""
    glowing = np.any(data.mat_f[:, MF_EMIT:MF_EMIT + 3] != 0.0, axis=1)
    if not glowing.any():                         # the common case: nothing to look at
        return surface_lights_none()
    counts = _triangle_counts(data)
    n_rows = len(data.in_proto)
    xf = data.in_xf[:n_rows]
    static = np.all(xf == xf[:, :1], axis=(1, 2, 3)) if n_rows else np.zeros(0, bool)
    ends = np.append(data.pr_gp_start[1:], len(data.gp_kind))
    groups, balls, movers = [], [], []  # (rows, slot, world triangles (R, n, 3, 3) | placed balls, emission)
    tubes = []                          # (rows, slot, world control points (R, n, 4, 4), emission, linear)
    means = {}
    n_balls = _ball_counts(data)
    n_segments = _segment_counts(data)
    glowing_curves = 0
    for c in range(len(data.pr_gp_start)):
        rows = np.flatnonzero(data.in_proto[:n_rows] == c)
        if not len(rows):
            continue
        own = not np.any(data.in_matset[rows] >= 0)       # every placement uses the gprims' own materials
        for g in range(int(data.pr_gp_start[c]), int(ends[c])):
            if data.gp_kind[g] == GP_CURVES:
                if (not own or glowing[data.gp_material[g]]) and n_segments[g]:
                    placed, others = _curve_lights(data, rows, g - int(data.pr_gp_start[c]), g, means, static,
                                                   int(n_segments[g]))
                    tubes += placed
                    glowing_curves += others
                continue
            sphere = data.gp_kind[g] == GP_SPHERE
            if (own and not glowing[data.gp_material[g]]) or (n_balls[g] if sphere else counts[g]) == 0:
                continue                                  # no emission, a mesh without triangles, an ellipsoid
            slot = g - int(data.pr_gp_start[c])
            emit, ok = _emitting(data, rows, slot, g, means)
            m = xf[rows, 0]
            if sphere:
                ok &= _invertible(m)
            off = int(data.gp_off[g])
            obj = np.asarray(data.sph[off:off + n_balls[g]] if sphere else data.tri_v[off:off + counts[g]], np.float64)
            moving = ok & ~static[rows]
            if moving.any():
                movers.append((rows[moving], slot, obj, xf[rows[moving]], emit[moving]))
            ok &= static[rows]
            if not ok.any():
                continue
            emit = emit[ok]
            if sphere:
                balls.append((rows[ok], slot, _placed_balls(obj, m[ok]), emit))
                continue
            world = np.einsum('rij,nvj->rnvi', m[ok][:, :, :3], obj) + m[ok][:, None, None, :, 3]
            groups.append((rows[ok], slot, world, emit))
    n_tri = sum(w.shape[0] * w.shape[1] for _, _, w, _ in groups)
    if n_tri > MAX_TRIANGLES and warn is not None:
        warn(f'{n_tri} emissive triangles (placements of emissive meshes) are lights of the path integrator: '
             f'more than {MAX_TRIANGLES}, they cost memory and build time (one world-space copy each)')
    n_balls = sum(b[2][1].size for b in balls) + sum(len(m[0]) * len(m[2]) for m in movers if m[2].ndim == 2)
    if n_balls > MAX_BALLS and warn is not None:
        warn(f'{n_balls} emissive spheres (placements of emissive spheres and the points of emissive point clouds) '
             f'are lights of the path integrator: more than {MAX_BALLS}, they cost memory (~350 bytes each) and '
             'build time')
    n_tubes = sum(t[2].shape[0] * t[2].shape[1] for t in tubes)
    if n_tubes > MAX_SEGMENTS and warn is not None:
        warn(f'{n_tubes} emissive curve segments (placements of emissive curves) are lights of the path integrator: '
             f'more than {MAX_SEGMENTS}, they cost memory (~500 bytes each) and build time')
    if glowing_curves and warn is not None:
        warn(f'{glowing_curves} emissive curves gprims (ribbons, textured emission, or moving or '
             'non-uniformly scaled placements): the rays that meet them see their emission, but they are not lights '
             'the path integrator samples (their light is noisier than an emissive mesh\'s)')
    return _tables(data, groups, balls, first, movers, tubes)


def _curve_lights(data, rows: np.ndarray, slot: int, g: int, means: dict, static: np.ndarray, n: int):
    """([(rows, slot, world control points (R, n, 4, 4), emission)] of the placements of curves gprim g (n segments)
    whose segments are lights, 1 if some other placement emits but is no light else 0).  Lights: round tubes (cubic
    segments, linear segments' cone sides; not ribbons) of an untextured emission, placed still by a similarity (a
    uniform scale: the world tube is then the tube of the world curve and radius, which `kernel/surface_lights`
    samples)."""
    emit, ok = _emitting(data, rows, slot, g, means)
    m = data.in_xf[rows, 0]
    scale = _similarity(m)
    tube = not data.gp_flags[g] & GP_RIBBON
    lit = ok & static[rows] & (scale > 0.0) & (emit[:, 3] < 0) & (emit[:, 5] < 0) & tube
    off = int(data.gp_off[g])
    ctrl = np.asarray(data.crv[off:off + n], np.float64)
    placed = []
    if lit.any():
        world = np.empty((int(lit.sum()), n, 4, 4))
        world[..., :3] = np.einsum('rij,nvj->rnvi', m[lit][:, :, :3], ctrl[..., :3]) + m[lit][:, None, None, :, 3]
        world[..., 3] = ctrl[None, ..., 3] * scale[lit][:, None, None]
        placed.append((rows[lit], slot, world, emit[lit], bool(data.gp_flags[g] & GP_LINEAR)))
    return placed, int((ok & ~lit).any())


def cone_sides(ends: np.ndarray) -> np.ndarray:
    """The side of each linear segment (..., 4, 4: its ends x, y, z, radius in rows 0 and 1) as the straight Bezier
    segment (controls at thirds) whose tube of circles it is.  Embree's round linear segment is the envelope of the
    spheres of radius r(u) = r0 + u (r1 - r0) centred on c(u) = p0 + u L d: the cone tangent to its end spheres, and
    the parts of those spheres beyond it.  The envelope's circle of sphere u lies where (x - c(u)) . d = -r(u) s,
    s = (r1 - r0) / L, with radius r(u) sqrt(1 - s^2): the tube of circles of the line from p0 - r0 s d to
    p1 - r1 s d, radii r0 sqrt(1 - s^2) to r1 sqrt(1 - s^2).  A segment with no side (L = 0, or |s| >= 1: one end's
    sphere holds the other's) becomes a point of radius 0: no area, never drawn."""
    p0, p1 = ends[..., 0, :3], ends[..., 1, :3]
    r0, r1 = ends[..., 0, 3], ends[..., 1, 3]
    length = np.linalg.norm(p1 - p0, axis=-1)
    ok = length > 0.0
    safe = np.where(ok, length, 1.0)
    d = (p1 - p0) / safe[..., None]
    s = (r1 - r0) / safe
    ok &= np.abs(s) < 1.0
    k = np.sqrt(np.maximum(1.0 - s * s, 0.0))
    a, b = p0 - (r0 * s)[..., None] * d, p1 - (r1 * s)[..., None] * d
    t = np.arange(4) / 3.0
    out = np.empty(ends.shape[:-2] + (4, 4))
    out[..., :3] = (1.0 - t)[:, None] * a[..., None, :] + t[:, None] * b[..., None, :]
    out[..., 3] = ((1.0 - t) * (r0 * k)[..., None] + t * (r1 * k)[..., None])
    out[~ok] = 0.0
    out[~ok, :, :3] = p0[~ok][:, None, :]
    return out


def tube_areas(q: np.ndarray, nodes: int = 8, angles: int = 16) -> np.ndarray:
    """Areas of the tubes of circles (`kernel/curves.tube_point`) of Bezier segments q (k, 4, 4: x, y, z, radius),
    integrated over the segment by Gauss-Legendre in u and over the circle at `angles` equal steps (exact for the
    circle's smooth periodic integrand to rounding at these sizes): the light tree's phi, not a density."""
    x, wx = np.polynomial.legendre.leggauss(nodes)
    u, wu = 0.5 * (x + 1.0), 0.5 * wx
    s = 1.0 - u
    b = np.stack([s ** 3, 3 * s * s * u, 3 * s * u * u, u ** 3], 1)
    db = np.stack([-3 * s * s, 3 * s * s - 6 * s * u, 6 * s * u - 3 * u * u, 3 * u * u], 1)
    ddb = np.stack([6 * s, 6 * u - 12 * s, 6 * s - 12 * u, 6 * u], 1)
    e, d, dd = (np.einsum('ui,kic->kuc', w, q) for w in (b, db, ddb))       # (k, nodes, 4)
    speed = np.linalg.norm(d[..., :3], axis=2)
    safe = np.where(speed > 0.0, speed, 1.0)
    t = d[..., :3] / safe[..., None]
    bend = np.linalg.norm(dd[..., :3] - np.sum(dd[..., :3] * t, 2)[..., None] * t, axis=2) / safe
    cos = np.cos(2.0 * np.pi * np.arange(angles) / angles)
    a = speed[..., None] - (e[..., 3] * bend)[..., None] * cos                # (k, nodes, angles)
    jac = np.abs(e[..., 3])[..., None] * np.sqrt(a * a + (d[..., 3] ** 2)[..., None])
    jac = np.where((speed > 0.0)[..., None], jac, 0.0)
    return 2.0 * np.pi * (jac.mean(2) * wu).sum(1)


def _similarity(m: np.ndarray) -> np.ndarray:
    """The uniform scale s of each placement (R, 3, 4) whose linear part is s x a rotation, else 0."""
    lin = m[:, :, :3]
    g = np.einsum('rki,rkj->rij', lin, lin)
    s2 = np.trace(g, axis1=1, axis2=2) / 3.0
    ok = np.all(np.abs(g - s2[:, None, None] * np.eye(3)) <= 1e-9 * s2[:, None, None], axis=(1, 2)) & (s2 > 0)
    return np.where(ok, np.sqrt(np.maximum(s2, 0.0)), 0.0)


def _invertible(m: np.ndarray) -> np.ndarray:
    """Whether each placement's (R, 3, 4) linear part is finite and invertible (a sphere placed by it is
    an ellipsoid, or a sphere if it is a similarity)."""
    det = np.linalg.det(m[:, :, :3])
    scale = np.maximum(np.abs(m[:, :, :3]).max(axis=(1, 2)), 1e-300)
    return np.isfinite(det) & (np.abs(det) > 1e-12 * scale ** 3)


def _placed_balls(cr: np.ndarray, m: np.ndarray):
    """(world centres (R, n, 3), radii (R, n), axes (R, n, 3, 3)) of a sphere gprim's balls cr (n, 4: container
    centre and radius; a point cloud's n) at placements m (R, 3, 4): radius 0 where the placement is no
    similarity (an ellipsoid: centre + axes u for the unit vectors u)."""
    centres = np.einsum('rij,nj->rni', m[:, :, :3], cr[:, :3]) + m[:, None, :, 3]
    axes = cr[None, :, 3, None, None] * m[:, None, :, :3]
    return centres, cr[None, :, 3] * _similarity(m)[:, None], axes


def _ball_rows(data, balls: list, first: int):
    """(sl_f rows, sl_i rows, bounds, row_lights) of the emissive spheres, lights first, first + 1, ...: a
    placement's balls (a point cloud's points) are consecutive lights, so that a hit's light is its gprim
    slot's first one plus its primitive (`kernel/surface_lights.light_of_hit`).  A ball of radius 0 is an
    ellipsoid of its axes (`_placed_balls`); a sphere's texture coordinates use its direction in its own frame
    (INV, the inverse of its axes)."""
    sl_f, sl_i, bounds, row_lights = [], [], [], []
    for rows, slot, (centres, radii, axes), emit in balls:
        R, n = radii.shape
        c, r, a = centres.reshape(-1, 3), radii.ravel(), axes.reshape(-1, 3, 3)
        e = np.repeat(emit, n, axis=0)
        f = np.zeros((R * n, SURFACE_LIGHT_F.width))
        i = np.zeros((R * n, SURFACE_LIGHT_I.width), np.int64)
        ball = r > 0.0
        SURFACE_LIGHT_F.write_rows(f, RAD=e[:, :3], CENTER=c, RADIUS=r, INV=np.linalg.inv(a).reshape(-1, 9),
             AREA=np.where(ball, 4 * np.pi * r ** 2, 4 * np.pi * np.abs(np.linalg.det(a))),
             AXES=np.where(ball[:, None], 0.0, a.reshape(-1, 9)))
        ids = [_texture_ids(data, row, slot, emit[k]) for k, row in enumerate(rows)]
        SURFACE_LIGHT_I.write_rows(i, ELLIPSOID=~ball, EMISSION_TEX=np.repeat([d['EMISSION_TEX'] for d in ids], n),
             GPRIM=np.repeat([d['GPRIM'] for d in ids], n), OPACITY_MAT=np.repeat([d['OPACITY_MAT'] for d in ids], n),
             MAT=np.repeat([d['MAT'] for d in ids], n))
        extent = np.where(ball[:, None], r[:, None], np.sqrt((a * a).sum(2)))
        projected = np.pi * r ** 2                           # an ellipsoid's largest projected area: pi s1 s2
        if not ball.all():
            sv = np.linalg.svd(a[~ball], compute_uv=False)
            projected[~ball] = np.pi * sv[:, 0] * sv[:, 1]
        phi = projected * e[:, 4]
        start = len(bounds)
        bounds += [(lo, hi, float(p), ENTIRE, True) for lo, hi, p in zip(c - extent, c + extent, phi)]
        sl_f += list(f)
        sl_i += list(i)
        row_lights.append((rows, slot, first + start + n * np.arange(R)))
    return sl_f, sl_i, bounds, row_lights


def _instance_ids(data, rows: np.ndarray) -> np.ndarray:
    """(R, 2): the top-level instance (geometry id, index in it) of each placement row."""
    gids = np.flatnonzero(data.grp_base >= 0)
    gids = gids[np.argsort(data.grp_base[gids], kind='stable')]
    gid = gids[np.searchsorted(data.grp_base[gids], rows, side='right') - 1]
    return np.stack([gid, rows - data.grp_base[gid]], 1)


def _moving_bounds(obj: np.ndarray, sphere: bool, xf: np.ndarray, lum: float):
    """Light-tree bounds of a moving placement (xf: its (K, 3, 4) time steps) of an object-space sphere
    (centre, radius) or triangles obj: the union of its world boxes and the largest of its phis over the
    shutter, at 8 times per step interval (exact where Embree lerps the matrices; a rotation it slerps
    may leave that box a little: the tree's importance is a heuristic, and never zero for these lights,
    which emit everywhere: no light is missed)."""
    K = len(xf)
    t = np.linspace(0.0, K - 1.0, 8 * (K - 1) + 1)
    k0 = np.minimum(t.astype(int), K - 2)
    f = (t - k0)[:, None, None]
    ms = (1.0 - f) * xf[k0] + f * xf[k0 + 1]                                    # (T, 3, 4)
    if sphere:
        axes = obj[3] * ms[:, :, :3]
        centres = ms[:, :, :3] @ obj[:3] + ms[:, :, 3]
        ext = np.sqrt((axes * axes).sum(2))
        lo, hi = (centres - ext).min(0), (centres + ext).max(0)
        s = np.linalg.svd(axes, compute_uv=False)
        phi = float(np.max(np.pi * s[:, 0] * s[:, 1]))
    else:
        world = np.einsum('tij,nvj->tnvi', ms[:, :, :3], obj) + ms[:, None, None, :, 3]
        lo, hi = world.min(axis=(0, 1, 2)), world.max(axis=(0, 1, 2))
        cr = np.cross(world[:, :, 1] - world[:, :, 0], world[:, :, 2] - world[:, :, 0])
        phi = float(np.max(0.5 * np.linalg.norm(cr, axis=2).sum(1)))
    return lo, hi, phi * lum, ENTIRE, True


def _mover_rows(data, movers: list, first: int, n_tri: int):
    """(sl_f rows, sl_i rows, object triangles, their cdfs, bounds, row_lights) of the moving placements'
    lights, numbered from `first`, their triangles stored from `n_tri` (one object-space copy per gprim,
    shared by its placements); a sphere gprim's balls (obj (n, 4): a point cloud's points) are consecutive
    lights of each placement."""
    sl_f, sl_i, tris, cdfs, bounds, row_lights = [], [], [], [], [], []
    for rows, slot, obj, xf, emit in movers:
        sphere = obj.ndim == 2
        if not sphere:
            a = 0.5 * np.linalg.norm(np.cross(obj[:, 1] - obj[:, 0], obj[:, 2] - obj[:, 0]), axis=1)
            if not a.sum() > 0.0:
                continue
            cdf = np.cumsum(a) / a.sum()
            cdf[-1] = 1.0
            tris.append(obj)
            cdfs.append(cdf)
        parts = obj if sphere else [obj]
        ids = _instance_ids(data, rows)
        start = len(bounds)
        for r in range(len(rows)):
            for part in parts:
                f = np.zeros(SURFACE_LIGHT_F.width)
                i = np.zeros(SURFACE_LIGHT_I.width, np.int64)
                SURFACE_LIGHT_I.write(i, **_texture_ids(data, rows[r], slot, emit[r]))
                if sphere:
                    SURFACE_LIGHT_F.write(f, RAD=emit[r, :3], AREA=4.0 * np.pi * part[3] ** 2, CENTER=part[:3],
                                          RADIUS=part[3])
                else:
                    SURFACE_LIGHT_F.write(f, RAD=emit[r, :3], AREA=a.sum())
                    SURFACE_LIGHT_I.write(i, FIRST=n_tri, COUNT=len(obj))
                SURFACE_LIGHT_I.write(i, MOVING=1, INST=ids[r, 0], INST_PRIM=ids[r, 1])
                sl_f.append(f)
                sl_i.append(i)
                bounds.append(_moving_bounds(part, sphere, xf[r], float(emit[r, 4])))
        row_lights.append((rows, slot, first + start + len(parts) * np.arange(len(rows))))
        if not sphere:
            n_tri += len(obj)
    return sl_f, sl_i, tris, cdfs, bounds, row_lights


def _texture_ids(data, row: int, slot: int, emit: np.ndarray) -> dict:
    """The SLI fields of a light's emissiveColor texture (-1: none) and of its gprim (for the texture
    coordinates of a point on it: its st primvar)."""
    return {'EMISSION_TEX': int(emit[3]), 'GPRIM': int(data.pr_gp_start[data.in_proto[row]]) + slot,
            'OPACITY_MAT': int(emit[5]), 'MAT': int(emit[6])}


def _curve_rows(data, tubes: list, first: int, j_first: int):
    """(sl_f rows, sl_i rows, bounds, row_lights) of the emissive curve segments, lights first, first + 1, ...
    (surface lights j_first, j_first + 1, ...): a placement's segments are consecutive lights, so that a hit's light is
    its gprim slot's first one plus its primitive (`kernel/surface_lights.light_of_hit`); the tree sees a segment's
    control points' box grown by its largest radius (the tube lies inside it) and its largest projected area, about
    A / pi.  A linear gprim's segments (their cones' sides) are followed by the lights of its round ends and joints
    (`curve_caps`), a placement's consecutive, which a segment names at each of its ends (CAP0, CAP1)."""
    sl_f, sl_i, bounds, row_lights = [], [], [], []
    for rows, slot, world, emit, linear in tubes:
        R, n = world.shape[:2]
        q = (cone_sides(world) if linear else world).reshape(-1, 4, 4)
        e = np.repeat(emit, n, axis=0)
        area = tube_areas(q)
        f = np.zeros((R * n, SURFACE_LIGHT_F.width))
        i = np.zeros((R * n, SURFACE_LIGHT_I.width), np.int64)
        SURFACE_LIGHT_F.write_rows(f, RAD=e[:, :3], AREA=area, CTRL=q.reshape(-1, 16))
        SURFACE_LIGHT_I.write_rows(i, CURVE=np.full(R * n, CURVE_LINEAR if linear else CURVE_CUBIC, np.int64),
                                   EMISSION_TEX=np.full(R * n, -1, np.int64), OPACITY_MAT=np.full(R * n, -1, np.int64),
                                   MAT=e[:, 6].astype(np.int64),
                                   GPRIM=np.repeat([_texture_ids(data, row, slot, emit[k])['GPRIM']
                                                    for k, row in enumerate(rows)], n))
        reach = np.abs(q[:, :, 3]).max(1)[:, None]
        lo, hi = q[:, :, :3].min(1) - reach, q[:, :, :3].max(1) + reach
        start = len(bounds)
        bounds += [(a, b, float(p), ENTIRE, True) for a, b, p in zip(lo, hi, area / np.pi * e[:, 4])]
        SURFACE_LIGHT_I.write_rows(i, CAP0=np.full(R * n, -1, np.int64), CAP1=np.full(R * n, -1, np.int64))
        caps = _cap_rows(i, world, emit, j_first + start + R * n) if linear else ([], [], [])
        sl_f += list(f) + caps[0]
        sl_i += list(i) + caps[1]
        bounds += caps[2]
        row_lights.append((rows, slot, first + start + n * np.arange(R)))
    return sl_f, sl_i, bounds, row_lights


def _cap_rows(seg_i: np.ndarray, world: np.ndarray, emit: np.ndarray, j_cap: int):
    """(sl_f rows, sl_i rows, bounds) of the lights of a linear gprim's round ends and joints (`curve_caps`), the
    first surface light j_cap, m a placement, placement by placement; fills its segments' rows (seg_i, R * n) CAP0
    and CAP1 with them."""
    R, n = world.shape[:2]
    spheres, planes, area, share, caps = curve_caps.round_caps(world[:, :, :2])
    m = spheres.shape[1]
    light = j_cap + m * np.arange(R)[:, None, None] + caps[None]              # (R, n, 2)
    light = np.where(caps[None] >= 0, light, -1).reshape(R * n, 2)
    SURFACE_LIGHT_I.write_rows(seg_i, CAP0=light[:, 0], CAP1=light[:, 1])
    if not m:
        return [], [], []
    e = np.repeat(emit, m, axis=0)
    f = np.zeros((R * m, SURFACE_LIGHT_F.width))
    i = np.zeros((R * m, SURFACE_LIGHT_I.width), np.int64)
    ball = spheres.reshape(-1, 4)
    SURFACE_LIGHT_F.write_rows(f, RAD=e[:, :3], AREA=area.ravel(), CENTER=ball[:, :3], RADIUS=ball[:, 3],
                               CTRL=planes.reshape(R * m, -1))
    none = np.full(R * m, -1, np.int64)
    SURFACE_LIGHT_I.write_rows(i, CURVE=np.full(R * m, CURVE_CAP, np.int64), EMISSION_TEX=none, OPACITY_MAT=none,
                               MAT=e[:, 6].astype(np.int64), GPRIM=np.repeat(seg_i[::n, SLI_GPRIM], m), CAP0=none,
                               CAP1=none)
    phi = (area * share[None]).ravel() / np.pi * e[:, 4]
    bounds = [(c - r, c + r, float(p), ENTIRE, True) for c, r, p in zip(ball[:, :3], ball[:, 3], phi)]
    return list(f), list(i), bounds


def _tables(data, groups: list, balls: list, first: int, movers=(), tubes=()) -> SurfaceLights:
    sl_f, sl_i, tris, cdfs, bounds = [], [], [], [], []
    row_lights = []                               # (rows, slot, light numbers)
    n_light = n_tri = 0
    for rows, slot, world, emit in groups:
        cr = np.cross(world[:, :, 1] - world[:, :, 0], world[:, :, 2] - world[:, :, 0])
        area = 0.5 * np.linalg.norm(cr, axis=2)                       # (R, n)
        total = area.sum(1)
        keep = total > 0.0
        rows, world, emit, area, total = rows[keep], world[keep], emit[keep], area[keep], total[keep]
        R, n = area.shape
        if not R:
            continue
        cdf = np.cumsum(area, 1) / total[:, None]
        cdf[:, -1] = 1.0
        f = np.zeros((R, SURFACE_LIGHT_F.width))
        i = np.zeros((R, SURFACE_LIGHT_I.width), np.int64)
        for r in range(R):
            SURFACE_LIGHT_F.write(f[r], RAD=emit[r, :3], AREA=total[r])
            SURFACE_LIGHT_I.write(i[r], FIRST=n_tri + r * n, COUNT=n, **_texture_ids(data, rows[r], slot, emit[r]))
        sl_f.append(f)
        sl_i.append(i)
        tris.append(world.reshape(-1, 3, 3))
        cdfs.append(cdf.ravel())
        bounds += _bounds(world, total * emit[:, 4])
        row_lights.append((rows, slot, first + n_light + np.arange(R)))
        n_light += R
        n_tri += R * n
    f, i, b, rl = _ball_rows(data, balls, first + n_light)
    f1, i1, b1, rl1 = _curve_rows(data, tubes, first + n_light + len(b), n_light + len(b))
    f, i, b, rl = f + f1, i + i1, b + b1, rl + rl1
    f2, i2, t2, c2, b2, rl2 = _mover_rows(data, movers, first + n_light + len(b), n_tri)
    f, i = f + f2, i + i2
    tris += t2
    cdfs += c2
    sl_f += [np.array(f).reshape(-1, SURFACE_LIGHT_F.width)] if f else []
    sl_i += [np.array(i, np.int64).reshape(-1, SURFACE_LIGHT_I.width)] if i else []
    bounds += b + b2
    row_lights += rl + rl2
    return SurfaceLights(
        sl_f=np.concatenate(sl_f) if sl_f else np.zeros((1, SURFACE_LIGHT_F.width)),
        sl_i=np.concatenate(sl_i) if sl_i else np.zeros((1, SURFACE_LIGHT_I.width), np.int64),
        sl_tri=np.ascontiguousarray(np.concatenate(tris)) if tris else np.zeros((1, 3, 3)),
        sl_cdf=np.concatenate(cdfs) if cdfs else np.ones(1),
        bounds=bounds, **_hit_map(data, row_lights))


def _hit_map(data, row_lights: list) -> dict:
    """sl_row, sl_idx: the light of a hit's (placement row, gprim slot)."""
    if not row_lights:
        return {'sl_row': np.full(1, -1, np.int64), 'sl_idx': np.full(1, -1, np.int64)}
    ends = np.append(data.pr_gp_start[1:], len(data.gp_kind))
    n_gprims = ends - data.pr_gp_start
    lit = np.unique(np.concatenate([rows for rows, _, _ in row_lights]))
    size = n_gprims[data.in_proto[lit]]
    sl_row = np.full(len(data.in_proto), -1, np.int64)
    sl_row[lit] = np.cumsum(size) - size
    sl_idx = np.full(max(int(size.sum()), 1), -1, np.int64)
    for rows, slot, lights in row_lights:
        sl_idx[sl_row[rows] + slot] = lights
    return {'sl_row': sl_row, 'sl_idx': sl_idx}


def surface_lights_none() -> SurfaceLights:
    """The tables of a scene without emissive-surface lights (placeholders the kernels never read)."""
    return _tables(None, [], [], 0)
