"""Cameras: the USD camera model (perspective / orthographic, thin lens) as a small float64 table and
one numba function that turns film and lens samples into a ray.

The film rectangle follows `UsdGeom.Camera`: apertures and focal length in scene units, the image
fitted to the aperture with UsdRender's default `aspectRatioConformPolicy = expandAperture` (the
aperture grows in one direction so that no part of the authored frustum is cropped).  The thin-lens
model (Cook et al. 1984; pbrt-v4 `PerspectiveCamera`) puts the plane of focus at `focus_distance`
along the view axis: a lens sample (u, v) moves the ray origin on a disk of radius `lens_radius` and
the ray passes through the pinhole ray's point on the focal plane.
"""
import math

import numba as nb
import numpy as np

from .. import description as D
from .features import F_LENS, F_ORTHO, F_TIME
from .jit import INLINE_JIT, JIT
from .tables import (C_FAR, C_FOCUS, C_HALF_H, C_HALF_W, C_LENS, C_M, C_M1, C_MOVING, C_NEAR,  # noqa: F401
                     C_OFF_X, C_OFF_Y, C_ORTHO, CAM_COLS, CAMERA)
from .vecmath import normalize, sincos_quarter

# the table's columns (C_*) are declared in tables.CAMERA


def camera_table(cam: D.Camera, width: int, height: int, origin: np.ndarray, *,
                 depth_of_field: bool = True, motion_blur: bool = True) -> np.ndarray:
    """Pack `cam` for an image of width x height pixels, relative to world position `origin`."""
    t = np.zeros(CAMERA.width, np.float64)
    m0 = np.array(cam.matrix, np.float64)
    m1 = m0 if (cam.motion is None or not motion_blur) else np.array(cam.motion[-1], np.float64)
    if cam.motion is not None and motion_blur:
        m0 = np.array(cam.motion[0], np.float64)
    rel = []
    for m in (m0, m1):
        mm = m[:3, :].copy()
        mm[:, 3] -= origin
        rel.append(mm.ravel())
    hap, vap = float(cam.horizontal_aperture), float(cam.vertical_aperture)
    if hap <= 0 or vap <= 0:
        hap, vap = 2.0955, 1.5291
    image_aspect = width / height
    if image_aspect >= hap / vap:        # expandAperture: grow the height or the width
        hap = vap * image_aspect
    else:
        vap = hap / image_aspect
    ortho = cam.projection == 'orthographic'
    f = max(float(cam.focal_length), 1e-12)
    scale = 1.0 if ortho else 1.0 / f
    use_lens = depth_of_field and cam.lens_radius > 0 and not ortho and cam.focus_distance > 0
    CAMERA.write(t, M=rel[0], M1=rel[1], MOVING=0.0 if np.array_equal(m0, m1) else 1.0,
                 ORTHO=1.0 if ortho else 0.0, HALF_W=0.5 * hap * scale, HALF_H=0.5 * vap * scale,
                 OFF_X=cam.horizontal_aperture_offset * scale, OFF_Y=cam.vertical_aperture_offset * scale,
                 LENS=cam.lens_radius if use_lens else 0.0, FOCUS=cam.focus_distance if use_lens else 1.0,
                 NEAR=max(cam.clip_near, 0.0), FAR=cam.clip_far if math.isfinite(cam.clip_far) else np.inf)
    return t


@nb.njit(**INLINE_JIT)
def _concentric_disk(u, v):
    """Shirley-Chiu concentric map of [0,1)^2 onto the unit disk (keeps stratification).  The
    angle is pi/4 * (b/a) or pi/2 - pi/4 * (a/b): one quarter-range sine/cosine either way."""
    a = 2.0 * u - 1.0
    b = 2.0 * v - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        sn, cs = sincos_quarter((math.pi / 4.0) * (b / a))
        return a * cs, a * sn
    sn, cs = sincos_quarter((math.pi / 4.0) * (a / b))
    return b * sn, b * cs


@nb.njit(**INLINE_JIT)
def generate_ray(cam, fx, fy, lens_u, lens_v, time):
    """Ray for film position (fx, fy) in [0,1]^2 (x right, y down, as image pixels), a lens sample and
    a shutter time in [0,1].  Returns origin and unit direction in camera-relative world space.
    The renderer traces packets with `camera_rays`, which computes these rays for 16 lanes at once in
    branch-free, vectorised loops and is tested against this function bit for bit (a shared
    implementation measured 1.5 % slower in the packet kernel)."""
    sx = (2.0 * fx - 1.0) * cam[C_HALF_W] + cam[C_OFF_X]
    sy = (1.0 - 2.0 * fy) * cam[C_HALF_H] + cam[C_OFF_Y]
    if cam[C_ORTHO] != 0.0:
        o = (sx, sy, 0.0)
        d = (0.0, 0.0, -1.0)
    else:
        o = (0.0, 0.0, 0.0)
        if cam[C_LENS] > 0.0:
            lx, ly = _concentric_disk(lens_u, lens_v)
            lx *= cam[C_LENS]
            ly *= cam[C_LENS]
            fd = cam[C_FOCUS]                  # the pinhole ray meets the focal plane z = -focus
            o = (lx, ly, 0.0)                  # at (sx, sy, -1) * focus
            d = (sx * fd - lx, sy * fd - ly, -fd)
        else:
            d = (sx, sy, -1.0)
    # d needs no normalising here: the world direction below is normalised, and M (d / |d|) / |M (d / |d|)|
    # = M d / |M d| (one square root and reciprocal per ray instead of two)
    # camera -> world (lerp the two shutter matrices when the camera moves)
    a = time if cam[C_MOVING] != 0.0 else 0.0
    wo = (_m(cam, 0, a) * o[0] + _m(cam, 1, a) * o[1] + _m(cam, 2, a) * o[2] + _m(cam, 3, a),
          _m(cam, 4, a) * o[0] + _m(cam, 5, a) * o[1] + _m(cam, 6, a) * o[2] + _m(cam, 7, a),
          _m(cam, 8, a) * o[0] + _m(cam, 9, a) * o[1] + _m(cam, 10, a) * o[2] + _m(cam, 11, a))
    wd = normalize((_m(cam, 0, a) * d[0] + _m(cam, 1, a) * d[1] + _m(cam, 2, a) * d[2],
                    _m(cam, 4, a) * d[0] + _m(cam, 5, a) * d[1] + _m(cam, 6, a) * d[2],
                    _m(cam, 8, a) * d[0] + _m(cam, 9, a) * d[1] + _m(cam, 10, a) * d[2]))
    return wo, wd


@nb.njit(**INLINE_JIT)
def _m(cam, i, a):
    return _mix(a, cam[C_M + i], cam[C_M1 + i])


@nb.njit(**INLINE_JIT)
def _mix(a, x0, x1):
    """(1 - a) x0 + a x1: a matrix entry at shutter time a.  (The entry's index stays with the caller: an
    integer constant passed to a compiled function makes numba compile it once per constant.)"""
    return (1.0 - a) * x0 + a * x1


@nb.njit(**INLINE_JIT)
def _concentric_disk_select(u, v):
    """`_concentric_disk` without branches (selects only, the same values), for vectorised loops."""
    a = 2.0 * u - 1.0
    b = 2.0 * v - 1.0
    big = abs(a) > abs(b)
    r = a if big else b
    q = b if big else a
    sn, cs = sincos_quarter((math.pi / 4.0) * (q / r))       # 0/0 only at the centre, masked below
    zero = a == 0.0 and b == 0.0
    lx = 0.0 if zero else (r * cs if big else r * sn)
    ly = 0.0 if zero else (r * sn if big else r * cs)
    return lx, ly


@nb.njit(**INLINE_JIT)
def _to_world(cam, a, o0, o1, o2, d0, d1, d2):
    """`generate_ray`'s camera-to-world step with the matrix entries read from the table once per
    packet (locals, so that stores to the output arrays do not force reloads)."""
    m = (_mix(a, cam[C_M], cam[C_M1]), _mix(a, cam[C_M + 1], cam[C_M1 + 1]), _mix(a, cam[C_M + 2], cam[C_M1 + 2]),
         _mix(a, cam[C_M + 3], cam[C_M1 + 3]), _mix(a, cam[C_M + 4], cam[C_M1 + 4]),
         _mix(a, cam[C_M + 5], cam[C_M1 + 5]), _mix(a, cam[C_M + 6], cam[C_M1 + 6]),
         _mix(a, cam[C_M + 7], cam[C_M1 + 7]), _mix(a, cam[C_M + 8], cam[C_M1 + 8]),
         _mix(a, cam[C_M + 9], cam[C_M1 + 9]), _mix(a, cam[C_M + 10], cam[C_M1 + 10]),
         _mix(a, cam[C_M + 11], cam[C_M1 + 11]))
    wo = (m[0] * o0 + m[1] * o1 + m[2] * o2 + m[3], m[4] * o0 + m[5] * o1 + m[6] * o2 + m[7],
          m[8] * o0 + m[9] * o1 + m[10] * o2 + m[11])
    wd = normalize((m[0] * d0 + m[1] * d1 + m[2] * d2, m[4] * d0 + m[5] * d1 + m[6] * d2,
                    m[8] * d0 + m[9] * d1 + m[10] * d2))
    return wo, wd


@nb.njit(**JIT, error_model='numpy')
def camera_rays(cam, n, fx, fy, lens, time, o, d):
    """`generate_ray` for the lanes j < n of a packet: film positions fx[j], fy[j], lens samples
    lens = (lens_u, lens_v): lens_u[j], lens_v[j], shutter times time[j] -> origins o[:, j] and unit directions d[:, j]
    (float64 (3, PACKET)), the same values bit for bit.  One branch-free loop over the lanes per
    camera model (IEEE division: 0/0 at the lens centre is masked, not an exception), which LLVM
    vectorises."""
    lens_u, lens_v = lens
    c = (cam[0], cam[1], cam[2], cam[3], cam[4], cam[5], cam[6], cam[7], cam[8], cam[9], cam[10], cam[11],
         cam[12], cam[13], cam[14], cam[15], cam[16], cam[17], cam[18], cam[19], cam[20], cam[21], cam[22],
         cam[23])
    hw = cam[C_HALF_W]
    hh = cam[C_HALF_H]
    offx = cam[C_OFF_X]
    offy = cam[C_OFF_Y]
    moving = F_TIME and cam[C_MOVING] != 0.0
    lens = cam[C_LENS]
    fd = cam[C_FOCUS]
    if F_ORTHO and cam[C_ORTHO] != 0.0:
        for j in range(n):
            a = time[j] if moving else 0.0
            wo, wd = _to_world(c, a, (2.0 * fx[j] - 1.0) * hw + offx, (1.0 - 2.0 * fy[j]) * hh + offy, 0.0,
                               0.0, 0.0, -1.0)
            o[0, j], o[1, j], o[2, j] = wo
            d[0, j], d[1, j], d[2, j] = wd
    elif F_LENS and lens > 0.0:
        for j in range(n):
            sx = (2.0 * fx[j] - 1.0) * hw + offx
            sy = (1.0 - 2.0 * fy[j]) * hh + offy
            lx, ly = _concentric_disk_select(lens_u[j], lens_v[j])
            lx *= lens
            ly *= lens
            a = time[j] if moving else 0.0
            wo, wd = _to_world(c, a, lx, ly, 0.0, sx * fd - lx, sy * fd - ly, -fd)
            o[0, j], o[1, j], o[2, j] = wo
            d[0, j], d[1, j], d[2, j] = wd
    else:
        for j in range(n):
            a = time[j] if moving else 0.0
            wo, wd = _to_world(c, a, 0.0, 0.0, 0.0, (2.0 * fx[j] - 1.0) * hw + offx,
                               (1.0 - 2.0 * fy[j]) * hh + offy, -1.0)
            o[0, j], o[1, j], o[2, j] = wo
            d[0, j], d[1, j], d[2, j] = wd
