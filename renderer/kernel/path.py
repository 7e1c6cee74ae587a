"""The path integrator: unbiased path tracing with next-event estimation and BSDF sampling combined
by multiple importance sampling (Veach 1997, ch. 9; power heuristic, beta = 2).

At every vertex a path collects the light it sees (emission of the light shapes its last ray
crossed, of the surface it hit, of the sky if it escaped: MIS-weighted against the light sample
that could have found the same light), then samples one light chosen by power (`choose_light`:
alias table) towards which it casts a shadow ray, then samples its BSDF (`bsdf.sample`) for the
next ray.  Delta lights (point, distant without angle) are found by next-event estimation alone,
delta lobes (mirror, dielectric) by BSDF sampling alone.  `max_depth` D counts bounces as pbrt does:
D = 0 is emission only, D = 1 direct light only.  After RR_DEPTH bounces, Russian roulette ends a
path with probability 1 - min(1, max throughput) (throughput without the 1/eta^2 of refraction) and
reweights the survivors: unbiased.  No value is clamped.

Strategies (`STRATEGIES`, for tests and benchmarks): 'mis' (the default), 'nee' (light sampling
alone for the light shapes and skies, BSDF sampling still continues paths and finds delta-lobe
paths), 'bsdf' (BSDF sampling alone: delta lights contribute nothing).

Sampling: every random number is `sample_2d/1d(sampler, seed, pixel, index, spp, pair)`; the pairs
are DIM_PIXEL, DIM_LENS, DIM_TIME (camera) and per path vertex v the PATH_PAIRS pairs from
`path_dim(v, P_*)`: light point (2D), light choice, BSDF direction (2D), lobe choice (also the
opacity choice, rescaled), roulette.  Pure functions of their arguments: images are bit-identical
whatever the thread count or the split into passes.  Camera rays are traced in 16-ray packets
(rtcIntersect16), every later ray alone (rtcIntersect1 / rtcOccluded1).
"""
import math

import numba as nb
import numpy as np

from .. import description as D
from .bsdf import BLACK, course_bsdf, evaluate, is_delta, preview_bsdf, sample
from .cameras import camera_rays
from .dimensions import DIM_PIXEL, DIM_TIME, P_BSDF, P_CHOICE, P_LIGHT, P_LOBE, P_RR, path_dim
from .filters import filter_offset
from .integrator import BAD_SAMPLES, N_COUNTERS, RAYS_CAMERA, RAYS_SECONDARY, RAYS_SHADOW, _shading_point
from .light_sampling import area_emission, choose_light, escaped_emission, sample_ld
from .materials import GOOCH_ALPHA, GOOCH_BETA, GOOCH_BLUE, GOOCH_YELLOW, preview_params
from .jit import KERNEL_JIT, SHADING_INLINE_JIT, SHADING_JIT
from .samplers import SOBOL, sample_1d, sample_2d, sample_pixel_lens, sobol_packet
from .tables import (C_FAR, C_NEAR, MF_ATTEN, MF_CC_ROUGH, MF_CLEARCOAT, MF_EMIT, MF_EXP, MF_IOR, MF_MIRROR, MF_OPACITY,
                     MF_ROUGH)
from .records import Ray, Tracer
from .tiles import TILE, n_tiles, next_tile
from .trace import (PACKET, TFAR, alloc_packet16, alloc_ray_buffer, intersect1, intersect16, lane_hit, occluded1,
                    set_ray16)
from .vecmath import dot, offset_origin, onb, to_world

STRATEGIES = {'mis': 0, 'nee': 1, 'bsdf': 2}
MIS, NEE_ONLY, BSDF_ONLY = 0, 1, 2
# emission weights of `light_sampling.area_emission`
W_POWER, W_ONE, W_ZERO = 0, 1, 2
RR_DEPTH = 3
PASS_THROUGH_MAX = 64          # transparent surfaces a path may cross without a bounce
SHADOW_EPS = 1e-5


@nb.njit(**SHADING_INLINE_JIT)
def vertex_bsdf(S, mat, model, kd, ks, front):
    """The `bsdf.Bsdf` of material `mat` (textured colours kd, ks) seen from the front or the back."""
    mf = S.mat_f
    if model == D.PREVIEW_SURFACE:
        diff, f0, f90, alpha = preview_params(S, mat, kd, ks)
        ca = max(float(mf[mat, MF_CC_ROUGH]), 0.001)
        return preview_bsdf(diff, f0, f90, alpha, np.float64(mf[mat, MF_CLEARCOAT]), ca * ca)
    cool = BLACK
    if model == D.COOL_TO_WARM:
        cool = (GOOCH_ALPHA * kd[0], GOOCH_ALPHA * kd[1], GOOCH_BLUE + GOOCH_ALPHA * kd[2])
        kd = (GOOCH_YELLOW + GOOCH_BETA * kd[0], GOOCH_YELLOW + GOOCH_BETA * kd[1], GOOCH_BETA * kd[2])
    return course_bsdf(model, kd, ks, float(mf[mat, MF_EXP]), float(mf[mat, MF_MIRROR]), float(mf[mat, MF_ROUGH]),
                       float(mf[mat, MF_IOR]), front, cool)


@nb.njit(**SHADING_INLINE_JIT)
def next_event(S, L, scene, smp, v, vtx, b, ws):
    """Light from one light sample at vertex vtx = (p, ng, ns, tt, bb, wo_local, po, time, strategy),
    MIS-weighted, not yet multiplied by the path throughput."""
    sampler, seed, pixel, index, spp = smp
    p, ng, ns, tt, bb, wl, po, time, strategy = vtx
    f, u, counts = ws[0], ws[1], ws[4]
    k, pk = choose_light(L, sample_1d(sampler, seed, pixel, index, spp, path_dim(v, P_CHOICE)))
    u1, u2 = sample_2d(sampler, seed, pixel, index, spp, path_dim(v, P_LIGHT))
    wi, dist, Le, pdf, delta = sample_ld(S, L, k, p, ns, u1, u2)
    if not pdf > 0.0 or dot(wi, ng) <= 0.0:
        return BLACK
    fc, pb = evaluate(b, wl, (dot(wi, tt), dot(wi, bb), dot(wi, ns)))
    if fc[0] == 0.0 and fc[1] == 0.0 and fc[2] == 0.0:
        return BLACK
    pl = pk * pdf
    w = 1.0 if (delta or strategy == NEE_ONLY) else pl * pl / (pl * pl + pb * pb)
    counts[RAYS_SHADOW] += 1
    smax = dist * (1.0 - SHADOW_EPS) if dist < np.inf else np.inf
    if occluded1(scene, f, u, po, wi, 0.0, smax, time):
        return BLACK
    s = w / pl
    return fc[0] * Le[0] * s, fc[1] * Le[1] * s, fc[2] * Le[2] * s


@nb.njit(**SHADING_INLINE_JIT)
def _origin(p, n, osc):
    """`offset_origin` as float64 (the float32 values exactly)."""
    q = offset_origin(p, n, osc)
    return float(q[0]), float(q[1]), float(q[2])


@nb.njit(**SHADING_INLINE_JIT)
def _add(L, T, c):
    return L[0] + T[0] * c[0], L[1] + T[1] * c[1], L[2] + T[2] * c[2]


@nb.njit(**SHADING_INLINE_JIT)
def trace_path(S, L, scene, ray, smp, opts, ws):
    """Radiance along the camera ray ray = (o, d, time), already traced as lane ws[7] of the packet
    (ws[5], ws[6]); smp = (sampler, seed, pixel, index, spp); opts = (max_depth, strategy);
    ws = (f, u, m, m32, counts, packet, lane, lf, lu): scratch and counters (lf, lu: the light-shape
    queries' ray buffer)."""
    max_depth, strategy = opts
    f, u, m, m32, counts, packet, lane, lf, lu = ws
    tr = Tracer(scene, f, u, m, m32, counts, 0, 0)
    sampler, seed, pixel, index, spp = smp
    o, d, time = ray
    osc = S.offset_scale[0]
    n_lights = S.li_type.shape[0] if S.li_type[0] >= 0 else 0
    mf = S.mat_f
    Lo = BLACK
    T = (1.0, 1.0, 1.0)
    A = (1.0, 1.0, 1.0)
    es = 1.0                                # 1/eta^2 factors of the throughput, undone for roulette
    prev = (o, (0.0, 0.0, 1.0), 0.0, W_ONE)
    after = W_POWER if strategy == MIS else (W_ZERO if strategy == NEE_ONLY else W_ONE)
    depth = 0
    for v in range(max_depth + 1 + PASS_THROUGH_MAX):
        if v == 0:
            hit = lane_hit(packet, lane, f, u)
        else:
            hit = intersect1(scene, f, u, o, d, 0.0, np.inf, time)
            counts[RAYS_SECONDARY] += 1
        tmax = float(f[TFAR]) if hit else np.inf
        if L.shapes.shape[0] > 0:
            Lo = _add(Lo, T, area_emission(S, L, (o, d), tmax, prev, lf, lu))
        if not hit:
            Lo = _add(Lo, T, escaped_emission(S, L, d, prev))
            break
        if A[0] != 1.0 or A[1] != 1.0 or A[2] != 1.0:
            T = (T[0] * A[0] ** tmax, T[1] * A[1] ** tmax, T[2] * A[2] ** tmax)
        sp = _shading_point(S, tr, Ray(o, d), time)
        p, ng, ns, st, mat, model, front, kd, ks = sp.p, sp.ng, sp.ns, sp.st, sp.mat, sp.model, sp.front, sp.kd, sp.ks
        ul = sample_1d(sampler, seed, pixel, index, spp, path_dim(v, P_LOBE))
        if model == D.PREVIEW_SURFACE:
            opacity = float(mf[mat, MF_OPACITY])
            if opacity < 1.0:
                if ul >= opacity:                 # not there: continue straight on, no bounce
                    o = _origin(p, (-ng[0], -ng[1], -ng[2]), osc)
                    continue
                ul = min(ul / opacity, 0.99999994)
        # emissive surfaces (UsdPreviewSurface emissiveColor): weight 1, no light sample draws them
        Lo = _add(Lo, T, (float(mf[mat, MF_EMIT]), float(mf[mat, MF_EMIT + 1]), float(mf[mat, MF_EMIT + 2])))
        if depth == max_depth:
            break
        b = vertex_bsdf(S, mat, model, kd, ks, front)
        tt, bb = onb(ns)
        wo = (-d[0], -d[1], -d[2])
        wl = (dot(wo, tt), dot(wo, bb), dot(wo, ns))
        po = _origin(p, ng, osc)
        if strategy != BSDF_ONLY and n_lights > 0 and not is_delta(b):
            Lo = _add(Lo, T, next_event(S, L, scene, smp, v, (p, ng, ns, tt, bb, wl, po, time, strategy), b, ws))
        u1, u2 = sample_2d(sampler, seed, pixel, index, spp, path_dim(v, P_BSDF))
        il, w, pdf, delta = sample(b, wl, ul, u1, u2)
        if w[0] == 0.0 and w[1] == 0.0 and w[2] == 0.0:
            break
        wi = to_world(il, tt, bb, ns)
        if il[2] > 0.0:
            if dot(wi, ng) <= 0.0:
                break
            o = po
        else:
            if dot(wi, ng) >= 0.0:
                break
            o = _origin(p, (-ng[0], -ng[1], -ng[2]), osc)
            es /= w[0]
            if front:
                A = (np.float64(mf[mat, MF_ATTEN]), np.float64(mf[mat, MF_ATTEN + 1]), np.float64(mf[mat, MF_ATTEN + 2]))
            else:
                A = (1.0, 1.0, 1.0)
        T = (T[0] * w[0], T[1] * w[1], T[2] * w[2])
        prev = (p, ns, pdf, W_ONE if delta else after)
        d = wi
        depth += 1
        if depth >= RR_DEPTH:
            q = max(T[0], T[1], T[2]) * es
            if q < 1.0:
                if sample_1d(sampler, seed, pixel, index, spp, path_dim(v, P_RR)) >= q:
                    break
                T = (T[0] / q, T[1] / q, T[2] / q)
    return Lo


def new_path_scratch():
    """One render thread's scratch for `render_tiles_path`, allocated by the host (numpy): the camera
    packet, the per-lane camera-stage arrays, a tile's counters and two single-ray buffers (the scene's
    and the light shapes')."""
    packet = alloc_packet16()
    lanes = (np.zeros((3, PACKET)), np.zeros((3, PACKET)), np.zeros((1, PACKET)), np.zeros((4, PACKET), np.int64),
             np.zeros((4, PACKET)), np.zeros((2, PACKET)), np.zeros((2, PACKET), np.uint32),
             np.zeros((6, PACKET), np.uint32))
    f, u = alloc_ray_buffer()
    lf, lu = alloc_ray_buffer()
    return (f, u, np.empty((3, 4)), np.empty(12, np.float32), np.zeros(N_COUNTERS, np.int64), packet, lanes, lf, lu)


@nb.njit(**SHADING_JIT)
def _camera_samples(cam, frame, opts, lanes, n):
    """The camera stage of one packet: random numbers, filter offsets, rays, into `lanes`."""
    width, height, s0, s1, spp = frame
    sampler, filt, seed, max_depth, use_lens, use_time, strategy = opts
    lane_o, lane_d, lane_ts, lane_id, lane_u, lane_f, lane_pi, work = lanes
    lane_t = lane_ts[0]
    if sampler == SOBOL:
        sobol_packet(seed, DIM_PIXEL, lane_pi[0], lane_pi[1], n, 4 if use_lens else 2, work, lane_u)
        if use_time:
            sobol_packet(seed, DIM_TIME, lane_pi[0], lane_pi[1], n, 1, work, lane_ts)
    for j in range(n):
        if sampler != SOBOL:
            a, b, lu, lv = sample_pixel_lens(sampler, seed, lane_id[0, j], lane_id[1, j], spp)
            lane_u[0, j] = a
            lane_u[1, j] = b
            lane_u[2, j] = lu
            lane_u[3, j] = lv
            lane_t[j] = sample_1d(sampler, seed, lane_id[0, j], lane_id[1, j], spp, DIM_TIME) if use_time else 0.0
        elif not use_time:
            lane_t[j] = 0.0
        fx, fy = filter_offset(filt, lane_u[0, j], lane_u[1, j])
        lane_f[0, j] = (lane_id[2, j] + 0.5 + fx) / width
        lane_f[1, j] = (lane_id[3, j] + 0.5 + fy) / height
    camera_rays(cam, n, lane_f[0], lane_f[1], (lane_u[2], lane_u[3]), lane_t, lane_o, lane_d)


@nb.njit(**SHADING_JIT)
def path_tile(S, L, scene, cam, box, frame, opts, ws, accum):
    """Add samples [s0, s1) of the pixels of box = (x0, y0, x1, y1) to accum; (pixel, sample) pairs
    pixel-major, 16 per camera packet.  ws = (f, u, m, m32, counts, packet, lanes, lf, lu)."""
    x0, y0, x1, y1 = box
    width, height, s0, s1, spp = frame
    sampler, filt, seed, max_depth, use_lens, use_time, strategy = opts
    f, u, m, m32, counts, packet, lanes, lf, lu = ws
    cvalid = packet.valid
    lane_o, lane_d, lane_ts, lane_id, lane_u, lane_f, lane_pi, work = lanes
    total = (x1 - x0) * (y1 - y0) * (s1 - s0)
    nidx = s0
    nx = x0
    ny = y0
    for first in range(0, total, PACKET):
        n = min(PACKET, total - first)
        for j in range(PACKET):
            cvalid[j] = 0
        for j in range(n):
            pixel = ny * width + nx
            lane_id[0, j] = pixel
            lane_id[1, j] = nidx
            lane_id[2, j] = nx
            lane_id[3, j] = ny
            lane_pi[0, j] = pixel
            lane_pi[1, j] = nidx
            nidx += 1
            if nidx == s1:
                nidx = s0
                nx += 1
                if nx == x1:
                    nx = x0
                    ny += 1
        _camera_samples(cam, frame, opts, lanes, n)
        for j in range(n):
            set_ray16(packet, j, (lane_o[0, j], lane_o[1, j], lane_o[2, j]), (lane_d[0, j], lane_d[1, j], lane_d[2, j]),
                      cam[C_NEAR], cam[C_FAR], lane_ts[0, j])
        intersect16(scene, packet)
        counts[RAYS_CAMERA] += n
        for j in range(n):
            c = trace_path(S, L, scene, ((lane_o[0, j], lane_o[1, j], lane_o[2, j]),
                                         (lane_d[0, j], lane_d[1, j], lane_d[2, j]), lane_ts[0, j]),
                           (sampler, seed, lane_id[0, j], lane_id[1, j], spp), (max_depth, strategy),
                           (f, u, m, m32, counts, packet, j, lf, lu))
            if math.isfinite(c[0]) and math.isfinite(c[1]) and math.isfinite(c[2]):
                x = lane_id[2, j]
                y = lane_id[3, j]
                accum[y, x, 0] += c[0]
                accum[y, x, 1] += c[1]
                accum[y, x, 2] += c[2]
            else:
                counts[BAD_SAMPLES] += 1


@nb.njit(**KERNEL_JIT)
def render_tiles_path(S, L, scene, cam, frame, opts, ws, work, accum, counters):
    """Add samples [s0, s1) of the tiles this thread claims (`tiles.next_tile` on the pass's shared
    counter `work`) to accum (height, width, 3) float64 with the path integrator; the host runs it on
    every render thread, each with its own scratch ws (`new_path_scratch`).  frame = (width, height,
    s0, s1, spp); opts = (sampler, filter, seed, max_depth, use_lens, use_time, strategy); counters int64
    (n_tiles, N_COUNTERS), one row per tile."""
    width, height = frame[0], frame[1]
    ntx = (width + TILE - 1) // TILE
    ntiles = n_tiles(width, height)
    counts = ws[4]
    while True:
        tile = next_tile(work, ntiles)
        if tile < 0:
            break
        for k in range(N_COUNTERS):
            counts[k] = 0
        x0 = (tile % ntx) * TILE
        y0 = (tile // ntx) * TILE
        path_tile(S, L, scene, cam, (x0, y0, min(x0 + TILE, width), min(y0 + TILE, height)), frame, opts, ws, accum)
        for k in range(N_COUNTERS):
            counters[tile, k] += counts[k]
