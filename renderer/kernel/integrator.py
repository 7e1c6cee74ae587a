"""Cook-style distribution ray tracing (Cook, Porter, Carpenter 1984).

Each camera sample is one point of the whole integrand domain: pixel position (reconstruction
filter), lens position (depth of field), time (motion blur), and per bounce one 2D sample per light
(soft shadows), one 2D sample for the glossy / GGX direction and one for the discrete choices
(Fresnel reflect-or-refract, transparency).  The sampler maps (pixel, sample index, dimension) to
stratified or low-discrepancy numbers; dimensions are decorrelated by the sampler's per-pair
scrambling.  Light transport is Whitted's plus Cook's distributions: direct light from every light
at every hit, and one specular continuation (mirror, glossy, glaze, refraction) per bounce, chosen
stochastically where there are several, up to `max_depth` bounces.  Diffuse interreflection is not
simulated (as in the course).

The kernel is a megakernel: one numba-parallel loop over image tiles, each thread tracing whole
paths on the two-level Embree scene: camera rays and first-hit shadow rays (the coherent ones) in
16-ray packets (rtcIntersect16 / rtcOccluded16), deeper bounces (which start at the surface: tnear 0,
tfar infinite) with rtcIntersect1 / rtcOccluded1.  Tiles are visited in a scattered order so that both
threads get a mix of cheap and expensive regions.  Every random number is a pure function of (seed,
pixel, sample index, dimension), so the image is bit-identical for a given seed whatever the thread
count, and passes of samples add up exactly to one render.

Ray recording (for benchmarks/bench_render.py, which replays the renderer's own rays on bare Embree):
`render_pass(..., rec)` with `rec = new_ray_record(...)` stores every traced ray; with `rec=None`
(the default) numba compiles a separate specialisation in which the recording branches are pruned
at compile time, so rendering pays nothing for the feature.
"""
import math

import numba as nb
import numpy as np

from .. import description as D
from .cameras import camera_rays
from .dimensions import DIM_PIXEL, DIM_TIME, bsdf_dim, choice_dim, light_dim
from .filters import filter_offset
from .jit import INLINE_JIT, PARALLEL_JIT, SHADING_INLINE_JIT, SHADING_JIT
from .lights import escaped_radiance, light_is_area, sample_light
from .materials import (colors, direct, fresnel_dielectric, has_diffuse_lobe, mirror_weight, preview_params,
                        refract, sample_ggx_h, smith_g, _schlick)
from .samplers import SOBOL, sample_1d, sample_2d, sample_pixel_lens, sobol_packet
from .shapes import surface
from .tables import C_FAR, C_NEAR, MF_ATTEN, MF_EMIT, MF_IOR, MF_OPACITY, MF_ROUGH, MI_MODEL
from .trace import (GEOM_ID, INST_ID, INST_PRIM_ID, INVALID, PACKET, PRIM_ID, TFAR, U, V, intersect1,
                    intersect16, new_packet16, new_ray_buffer, occluded1, occluded16, set_ray16)
from .vecmath import dot, normalize, offset_origin, onb, reflect

# counters (per tile): rays by kind, samples dropped as non-finite, and how many of the shadow rays were
# first-hit ones traced in packets (also the ray record's kind for those)
RAYS_CAMERA, RAYS_SHADOW, RAYS_SECONDARY, BAD_SAMPLES, RAYS_SHADOW_PACKET = 0, 1, 2, 3, 4
N_COUNTERS = 5
# ray record fields (float32 columns of rec[0])
R_OX, R_OY, R_OZ, R_DX, R_DY, R_DZ, R_TNEAR, R_TFAR, R_TIME = range(9)
R_FIELDS = 9
TILE = 8
SHADOW_EPS = 1e-5


def new_ray_record(width, height, rays_per_tile):
    """Arrays for recording up to `rays_per_tile` rays of every 8x8 tile: (rays float32
    (n_tiles, cap, R_FIELDS), kind int8 (n_tiles, cap) = RAYS_CAMERA, RAYS_SHADOW (traced alone),
    RAYS_SHADOW_PACKET (first hit: traced in a packet) or RAYS_SECONDARY,
    count int64 (n_tiles,) = rays traced, including those beyond the capacity)."""
    ntiles = ((width + TILE - 1) // TILE) * ((height + TILE - 1) // TILE)
    return (np.zeros((ntiles, rays_per_tile, R_FIELDS), np.float32),
            np.full((ntiles, rays_per_tile), -1, np.int8), np.zeros(ntiles, np.int64))


@nb.njit(**INLINE_JIT)
def _record(rec, tile, kind, ox, oy, oz, dx, dy, dz, tnear, tfar, time):
    n = rec[2][tile]
    if n < rec[0].shape[1]:
        r = rec[0]
        r[tile, n, R_OX] = ox
        r[tile, n, R_OY] = oy
        r[tile, n, R_OZ] = oz
        r[tile, n, R_DX] = dx
        r[tile, n, R_DY] = dy
        r[tile, n, R_DZ] = dz
        r[tile, n, R_TNEAR] = tnear
        r[tile, n, R_TFAR] = tfar
        r[tile, n, R_TIME] = time
        rec[1][tile, n] = kind
    rec[2][tile] = n + 1


@nb.njit(**INLINE_JIT)
def new_tile_scratch(n_lights):
    """Per-thread scratch of `render_tile`: the camera packet, the first-hit shadow queue and the
    per-lane state, structure-of-arrays so that the camera stage's loops over the lanes vectorise
    (allocated by `render_pass` once per tile; the shading code allocates nothing)."""
    cvalid, cf, cu = new_packet16()
    qvalid, qf, qu = new_packet16()
    # the queue: packet, lane of each ray, unoccluded contributions, count, first-hit direct light per
    # lane, and the first hit's light samples (pairs light_dim(0, k): rows 2k, 2k + 1), drawn for the
    # whole packet by `sobol_packet` with the Sobol' sampler
    queue = (qvalid, qf, qu, np.zeros(PACKET, np.int64), np.zeros((PACKET, 3)), np.zeros(1, np.int64),
             np.zeros((PACKET, 3)), np.zeros((2 * max(n_lights, 1), PACKET)))
    # origins, directions (3, PACKET); times; (pixel, index, x, y); radiance (PACKET, 3); the samples of
    # the pixel and lens pairs (4, PACKET); film positions (2, PACKET); pixel and index as uint32 and
    # the Sobol' packet's scratch
    lanes = (np.zeros((3, PACKET)), np.zeros((3, PACKET)), np.zeros((1, PACKET)), np.zeros((4, PACKET), np.int64),
             np.zeros((PACKET, 3)), np.zeros((4, PACKET)), np.zeros((2, PACKET)), np.zeros((2, PACKET), np.uint32),
             np.zeros((6, PACKET), np.uint32))
    return (cvalid, cf, cu), queue, lanes


@nb.njit(**SHADING_JIT)
def render_tile(S, scene, cam, x0, y0, x1, y1, width, height, s0, s1, spp, sampler, filt, seed, max_depth,
                use_lens, use_time, f, u, m, m32, counts, rec, tile, accum, packet, queue, lanes):
    """Add samples [s0, s1) of the pixels [x0, x1) x [y0, y1) to `accum`.

    The tile's (pixel, sample) pairs, pixel-major, are traced 16 at a time: their camera rays as one
    rtcIntersect16 packet (16 samples of one pixel, or neighbouring pixels when a pass has few
    samples), their first-hit shadow rays through a queue flushed as rtcOccluded16 packets; deeper
    bounces use single rays.  Each lane's radiance is (path without the first-hit direct light) +
    (first-hit direct light), the latter summed per lane in light order, so a sample's value does
    not depend on which lanes share its packets: images stay bit-identical across thread counts
    and pass splits.  One call per tile: the scene tables cross the call boundary once.
    (Shading the first hits in stages, one short loop over the 16 lanes per stage - shading points,
    direct light, continuations - was measured: no gain, 0.98-1.02x.)"""
    cvalid, cf, cu = packet
    lane_o, lane_d, lane_ts, lane_id, lane_L, lane_u, lane_f, lane_pi, work = lanes
    lane_t = lane_ts[0]
    ldir = queue[6]
    lsamp = queue[7]
    n_lights = S.li_type.shape[0] if S.li_type[0] >= 0 else 0
    total = (x1 - x0) * (y1 - y0) * (s1 - s0)
    n_pl = 4 if use_lens else 2
    # the next (pixel, sample) pair: sample `nidx` of pixel (nx, ny), advanced pixel-major (counters, not
    # three integer divisions per sample)
    nidx = s0
    nx = x0
    ny = y0
    for first in range(0, total, PACKET):
        n = min(PACKET, total - first)
        for j in range(PACKET):
            cvalid[j] = 0
        # the camera stage as loops over the lanes: which samples, their random numbers (Sobol':
        # `sobol_packet`, vectorised), filter offsets, then the rays (`camera_rays`, vectorised)
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
        if sampler == SOBOL:
            sobol_packet(seed, DIM_PIXEL, lane_pi[0], lane_pi[1], n, n_pl, work, lane_u)
            if use_time:
                sobol_packet(seed, DIM_TIME, lane_pi[0], lane_pi[1], n, 1, work, lane_ts)
            for k in range(n_lights):
                if light_is_area(S, k):
                    sobol_packet(seed, light_dim(0, k, n_lights), lane_pi[0], lane_pi[1], n, 2, work, lsamp[2 * k:2 * k + 2])
        else:
            for j in range(n):
                if use_lens:
                    a, b, lu, lv = sample_pixel_lens(sampler, seed, lane_id[0, j], lane_id[1, j], spp)
                    lane_u[2, j] = lu
                    lane_u[3, j] = lv
                else:
                    a, b = sample_2d(sampler, seed, lane_id[0, j], lane_id[1, j], spp, DIM_PIXEL)
                lane_u[0, j] = a
                lane_u[1, j] = b
        for j in range(n):
            if sampler != SOBOL:
                lane_t[j] = sample_1d(sampler, seed, lane_id[0, j], lane_id[1, j], spp, DIM_TIME) if use_time else 0.0
            elif not use_time:
                lane_t[j] = 0.0
            lane_f[0, j], lane_f[1, j] = filter_offset(filt, lane_u[0, j], lane_u[1, j])
        for j in range(n):                  # vectorised: film positions
            lane_f[0, j] = (lane_id[2, j] + 0.5 + lane_f[0, j]) / width
            lane_f[1, j] = (lane_id[3, j] + 0.5 + lane_f[1, j]) / height
        camera_rays(cam, n, lane_f[0], lane_f[1], lane_u[2], lane_u[3], lane_t, lane_o, lane_d)
        for j in range(n):
            set_ray16(cvalid, cf, cu, j, lane_o[0, j], lane_o[1, j], lane_o[2, j], lane_d[0, j], lane_d[1, j],
                      lane_d[2, j], cam[C_NEAR], cam[C_FAR], lane_t[j])
            if rec is not None:
                _record(rec, tile, RAYS_CAMERA, lane_o[0, j], lane_o[1, j], lane_o[2, j], lane_d[0, j], lane_d[1, j],
                        lane_d[2, j], cam[C_NEAR], cam[C_FAR], lane_t[j])
            for k in range(3):
                ldir[j, k] = 0.0
        intersect16(scene, cvalid, cf)
        counts[RAYS_CAMERA] += n
        for j in range(n):
            r, g, bl = trace_path(S, scene, (lane_o[0, j], lane_o[1, j], lane_o[2, j]),
                                  (lane_d[0, j], lane_d[1, j], lane_d[2, j]), lane_t[j],
                                  (sampler, seed, lane_id[0, j], lane_id[1, j], spp), max_depth, f, u, m, m32, counts,
                                  rec, tile, cf, cu, j, queue, 0, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0))
            lane_L[j, 0] = r
            lane_L[j, 1] = g
            lane_L[j, 2] = bl
        _flush_shadows(scene, queue)
        for j in range(n):
            r = lane_L[j, 0] + ldir[j, 0]
            g = lane_L[j, 1] + ldir[j, 1]
            bl = lane_L[j, 2] + ldir[j, 2]
            if math.isfinite(r) and math.isfinite(g) and math.isfinite(bl):
                x = lane_id[2, j]
                y = lane_id[3, j]
                accum[y, x, 0] += r
                accum[y, x, 1] += g
                accum[y, x, 2] += bl
            else:
                counts[BAD_SAMPLES] += 1


@nb.njit(**SHADING_INLINE_JIT)
def _enqueue_shadow(scene, queue, lane, po, wi, smax, time, cr, cg, cb):
    """Queue a first-hit shadow ray whose unoccluded contribution (cr, cg, cb) goes to `lane`."""
    qvalid, qf, qu, qlane, qc, qn, ldir, _ = queue
    n = qn[0]
    set_ray16(qvalid, qf, qu, n, po[0], po[1], po[2], wi[0], wi[1], wi[2], 0.0, smax, time)
    qlane[n] = lane
    qc[n, 0] = cr
    qc[n, 1] = cg
    qc[n, 2] = cb
    qn[0] = n + 1
    if n + 1 == PACKET:
        _flush_shadows(scene, queue)


@nb.njit(**SHADING_JIT)
def _flush_shadows(scene, queue):
    """Trace the queued shadow rays as one rtcOccluded16 packet; add the unoccluded contributions
    to their lanes' first-hit direct light."""
    qvalid, qf, qu, qlane, qc, qn, ldir, _ = queue
    n = qn[0]
    if n == 0:
        return
    occluded16(scene, qvalid, qf)
    for e in range(n):
        if qf[TFAR * PACKET + e] != -np.inf:
            j = qlane[e]
            ldir[j, 0] += qc[e, 0]
            ldir[j, 1] += qc[e, 1]
            ldir[j, 2] += qc[e, 2]
        qvalid[e] = 0
    qn[0] = 0


@nb.njit(**SHADING_INLINE_JIT)
def _shading_point(S, scene, f, u, o, dvec, time, m, m32):
    """The surface hit by the ray (o, dvec) whose hit is in (f, u): (p, ng, ns, st, material, model,
    front), the normals turned towards the viewer (front: the ray hit the outside)."""
    p, ng, ns, st, g, mat = surface(S, scene, u[INST_ID], u[INST_PRIM_ID], u[GEOM_ID], u[PRIM_ID],
                                    float(f[U]), float(f[V]), o, dvec, float(f[TFAR]), time, m, m32)
    model = S.mat_i[mat, MI_MODEL]
    front = dot(ng, dvec) < 0.0
    if not front:
        ng = (-ng[0], -ng[1], -ng[2])
        ns = (-ns[0], -ns[1], -ns[2])
    if dot(ns, dvec) > 0.0:            # interpolated normal facing away: use the true one
        ns = ng
    return p, ng, ns, st, mat, model, front


@nb.njit(**SHADING_INLINE_JIT)
def _direct_light(S, scene, smp, n_lights, p, ng, ns, wo, kd, ks, mat, model, osc, depth, lane, queue, time,
                  f, u, counts, rec, tile, T, L):
    """Direct light at a shading point, one sample per light (soft shadows from area lights), added
    to the radiance L = (Lr, Lg, Lb) with throughput T = (tr, tg, tb); returns the new L.  At the first
    hit (depth 0) the shadow rays go to the packet queue and their contributions to the lane's
    first-hit light instead.  smp = (sampler, seed, pixel, index, spp).  (Arguments are grouped in
    tuples: a call with over 30 arguments compiles to CALL_FUNCTION_EX, which numba cannot inline.)"""
    sampler, seed, pixel, index, spp = smp
    tr, tg, tb = T
    Lr, Lg, Lb = L
    po = offset_origin(p, ng, osc)
    for k in range(n_lights):
        u1 = 0.5
        u2 = 0.5
        if light_is_area(S, k):
            if depth == 0 and sampler == SOBOL:      # drawn with the camera packet
                u1 = queue[7][2 * k, lane]
                u2 = queue[7][2 * k + 1, lane]
            else:
                u1, u2 = sample_2d(sampler, seed, pixel, index, spp, light_dim(depth, k, n_lights))
        wi, dist, E = sample_light(S, k, p, ns, u1, u2)
        if E[0] == 0.0 and E[1] == 0.0 and E[2] == 0.0:
            continue
        if dot(wi, ng) <= 0.0:
            continue
        c = direct(S, mat, kd, ks, ns, wo, wi, E)
        if c[0] == 0.0 and c[1] == 0.0 and c[2] == 0.0:
            continue
        if model != D.COOL_TO_WARM:      # Gooch tone shading is unshadowed
            counts[RAYS_SHADOW] += 1
            smax = dist * (1.0 - SHADOW_EPS) if dist < np.inf else np.inf
            if rec is not None:
                _record(rec, tile, RAYS_SHADOW_PACKET if depth == 0 else RAYS_SHADOW, po[0], po[1], po[2], wi[0],
                        wi[1], wi[2], 0.0, smax, time)
            if depth == 0:               # first hit: traced later, in a packet
                counts[RAYS_SHADOW_PACKET] += 1
                _enqueue_shadow(scene, queue, lane, po, wi, smax, time, tr * c[0], tg * c[1], tb * c[2])
                continue
            if occluded1(scene, f, u, po[0], po[1], po[2], wi[0], wi[1], wi[2], 0.0, smax, time):
                continue
        Lr += tr * c[0]
        Lg += tg * c[1]
        Lb += tb * c[2]
    return Lr, Lg, Lb


@nb.njit(**SHADING_INLINE_JIT)
def _continuation(S, smp, depth, n_lights, p, ng, ns, wo, dvec, kd, ks, mat, model, front, osc, T, A):
    """One specular continuation (mirror, glossy, glaze, refraction; the glossy pair is drawn only
    where a lobe uses it) from throughput T and medium attenuation A: (alive, origin, direction,
    throughput rgb, medium attenuation rgb)."""
    sampler, seed, pixel, index, spp = smp
    tr, tg, tb = T
    ar, ag, ab = A
    mf = S.mat_f
    dead = (False, (0.0, 0.0, 0.0), dvec, tr, tg, tb, ar, ag, ab)
    if model == D.DIELECTRIC:
        ior = float(mf[mat, MF_IOR])
        eta = ior if front else 1.0 / ior
        cos_i = -dot(dvec, ns)
        F, cos_t = fresnel_dielectric(cos_i, eta)
        uc = sample_1d(sampler, seed, pixel, index, spp, choice_dim(depth, n_lights))
        if uc < F:
            nd = reflect(dvec, ns)
            o = offset_origin(p, ng, osc)
        else:
            nd = refract(dvec, ns, eta, cos_i, cos_t)
            o = offset_origin(p, (-ng[0], -ng[1], -ng[2]), osc)
            if front:                        # entering the medium
                ar = float(mf[mat, MF_ATTEN])
                ag = float(mf[mat, MF_ATTEN + 1])
                ab = float(mf[mat, MF_ATTEN + 2])
            else:
                ar = 1.0
                ag = 1.0
                ab = 1.0
        return True, (float(o[0]), float(o[1]), float(o[2])), nd, tr, tg, tb, ar, ag, ab
    if model == D.PREVIEW_SURFACE:
        diff, f0, f90, alpha = preview_params(S, mat, kd, ks)
        g1, g2 = sample_2d(sampler, seed, pixel, index, spp, bsdf_dim(depth, n_lights))
        tt, bb = onb(ns)
        h = normalize(sample_ggx_h(ns, alpha, g1, g2, tt, bb))
        nd = reflect(dvec, h)
        nv = dot(ns, wo)
        nl = dot(ns, nd)
        nh = dot(ns, h)
        vh = dot(wo, h)
        if nl <= 0.0 or nv <= 0.0 or nh <= 0.0 or vh <= 0.0 or dot(nd, ng) <= 0.0:
            return dead
        gw = smith_g(nl, nv, alpha) * vh / (nh * nv)
        wr = _schlick(f0[0], f90[0], vh) * gw
        wg = _schlick(f0[1], f90[1], vh) * gw
        wb = _schlick(f0[2], f90[2], vh) * gw
        # Russian roulette on the continuation weight keeps rough dielectrics cheap
        q = min(1.0, max(wr, max(wg, wb)))
        if q <= 0.0 or sample_1d(sampler, seed, pixel, index, spp, choice_dim(depth, n_lights)) >= q:
            return dead
        o = offset_origin(p, ng, osc)
        return True, (float(o[0]), float(o[1]), float(o[2])), nd, tr * (wr / q), tg * (wg / q), tb * (wb / q), ar, ag, ab
    w = mirror_weight(S, mat, model, ks)
    if w[0] <= 0.0 and w[1] <= 0.0 and w[2] <= 0.0:
        return dead
    nd = reflect(dvec, ns)
    rough = float(mf[mat, MF_ROUGH])
    if rough > 0.0 and model == D.BLINN_PHONG_MIRRORED:
        # the course's glossy reflection: perturb r on a square of side `roughness`
        g1, g2 = sample_2d(sampler, seed, pixel, index, spp, bsdf_dim(depth, n_lights))
        tt, bb = onb(nd)
        a = rough * (g1 - 0.5)
        b = rough * (g2 - 0.5)
        nd = normalize((nd[0] + a * tt[0] + b * bb[0], nd[1] + a * tt[1] + b * bb[1],
                        nd[2] + a * tt[2] + b * bb[2]))
    if dot(nd, ng) <= 0.0:
        return dead
    o = offset_origin(p, ng, osc)
    return True, (float(o[0]), float(o[1]), float(o[2])), nd, tr * w[0], tg * w[1], tb * w[2], ar, ag, ab


@nb.njit(**SHADING_INLINE_JIT)
def trace_path(S, scene, o, d, time, smp, max_depth, f, u, m, m32, counts, rec, tile, cf, cu, lane, queue,
               depth0, L, T, A):
    """Radiance arriving along the ray (o, d) at shutter time `time`, starting at bounce `depth0`
    with radiance L = (Lr, Lg, Lb) gathered so far, throughput T = (tr, tg, tb) and the Beer
    attenuation A = (ar, ag, ab) of the medium the ray travels in (1 = vacuum);
    smp = (sampler, seed, pixel, index, spp).  Bounce 0 is the camera ray, traced
    as lane `lane` of the packet (cf, cu); its direct light is not included: its shadow rays go to
    `queue` (`_enqueue_shadow`).  (Tracing the first bounce's continuation rays of a packet as one
    more packet was measured: no gain, 0.99-1.02x, at twice the compile time.)
    `rec`: None, or a ray record (`new_ray_record`) to which the rays of tile `tile` are appended."""
    n_lights = S.li_type.shape[0] if S.li_type[0] >= 0 else 0
    osc = S.offset_scale[0]            # scale of the near-origin ray offset (build.offset_scale)
    sampler, seed, pixel, index, spp = smp
    Lr, Lg, Lb = L
    tr, tg, tb = T
    ar, ag, ab = A
    ox, oy, oz = o
    dx, dy, dz = d
    for depth in range(depth0, max_depth + 1):
        if depth == 0:                     # traced in the camera packet: copy the lane's hit
            hit = _lane_hit(cf, cu, lane, f, u)
        else:
            if rec is not None:
                _record(rec, tile, RAYS_SECONDARY, ox, oy, oz, dx, dy, dz, 0.0, np.inf, time)
            hit = intersect1(scene, f, u, ox, oy, oz, dx, dy, dz, 0.0, np.inf, time)
            counts[RAYS_SECONDARY] += 1
        dvec = (float(dx), float(dy), float(dz))
        if not hit:
            e = escaped_radiance(S, dvec)
            Lr += tr * e[0]
            Lg += tg * e[1]
            Lb += tb * e[2]
            break
        t = float(f[TFAR])
        if ar != 1.0 or ag != 1.0 or ab != 1.0:
            tr *= ar ** t
            tg *= ag ** t
            tb *= ab ** t
        p, ng, ns, st, mat, model, front = _shading_point(S, scene, f, u, (float(ox), float(oy), float(oz)),
                                                          dvec, time, m, m32)
        wo = (-dvec[0], -dvec[1], -dvec[2])
        kd, ks = colors(S, mat, st)
        mf = S.mat_f
        # ---- transparency (UsdPreviewSurface opacity): pass straight through with prob. 1 - opacity
        if model == D.PREVIEW_SURFACE:
            opacity = float(mf[mat, MF_OPACITY])
            if opacity < 1.0:
                if sample_1d(sampler, seed, pixel, index, spp, choice_dim(depth, n_lights)) >= opacity:
                    ox, oy, oz = offset_origin(p, (-ng[0], -ng[1], -ng[2]), osc)
                    continue
            Lr += tr * mf[mat, MF_EMIT]
            Lg += tg * mf[mat, MF_EMIT + 1]
            Lb += tb * mf[mat, MF_EMIT + 2]
        if has_diffuse_lobe(model):
            Lr, Lg, Lb = _direct_light(S, scene, smp, n_lights, p, ng, ns, wo, kd, ks, mat, model, osc, depth,
                                       lane, queue, time, f, u, counts, rec, tile, (tr, tg, tb), (Lr, Lg, Lb))
        if depth == max_depth:
            break
        alive, o2, nd, tr, tg, tb, ar, ag, ab = _continuation(S, smp, depth, n_lights, p, ng, ns, wo, dvec, kd, ks,
                                                               mat, model, front, osc, (tr, tg, tb), (ar, ag, ab))
        if not alive:
            break
        ox, oy, oz = o2
        dx, dy, dz = nd
        if tr == 0.0 and tg == 0.0 and tb == 0.0:
            break
    return Lr, Lg, Lb


@nb.njit(**SHADING_INLINE_JIT)
def _lane_hit(cf, cu, lane, f, u):
    """Copy lane `lane` of a traced RTCRayHit16 into the single-ray record (f, u); True on a hit."""
    f[TFAR] = cf[TFAR * PACKET + lane]
    f[U] = cf[U * PACKET + lane]
    f[V] = cf[V * PACKET + lane]
    u[PRIM_ID] = cu[PRIM_ID * PACKET + lane]
    u[GEOM_ID] = cu[GEOM_ID * PACKET + lane]
    u[INST_ID] = cu[INST_ID * PACKET + lane]
    u[INST_PRIM_ID] = cu[INST_PRIM_ID * PACKET + lane]
    return u[GEOM_ID] != INVALID


@nb.njit(**PARALLEL_JIT)
def render_pass(S, scene, cam, width, height, s0, s1, spp, sampler, filt, seed, max_depth,
                use_lens, use_time, accum, counters, rec=None):
    """Add samples [s0, s1) of every pixel to `accum` (height, width, 3) float64.
    counters: int64 (n_tiles, N_COUNTERS), one row per tile (no shared writes).
    rec: None, or a ray record (`new_ray_record`) that receives every ray traced."""
    ntx = (width + TILE - 1) // TILE
    nty = (height + TILE - 1) // TILE
    ntiles = ntx * nty
    stride = 7919 if ntiles % 7919 != 0 else 1
    for ti in nb.prange(ntiles):
        tile = (ti * stride) % ntiles
        f, u = new_ray_buffer()
        m = np.empty((3, 4))
        m32 = np.empty(12, np.float32)
        counts = np.zeros(N_COUNTERS, np.int64)
        packet, queue, lanes = new_tile_scratch(S.li_type.shape[0])
        x0 = (tile % ntx) * TILE
        y0 = (tile // ntx) * TILE
        render_tile(S, scene, cam, x0, y0, min(x0 + TILE, width), min(y0 + TILE, height), width, height,
                    s0, s1, spp, sampler, filt, seed, max_depth, use_lens, use_time, f, u, m, m32, counts, rec,
                    tile, accum, packet, queue, lanes)
        for k in range(N_COUNTERS):
            counters[tile, k] += counts[k]
