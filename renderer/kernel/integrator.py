"""Cook-style distribution ray tracing (Cook, Porter, Carpenter 1984).

Each camera sample is one point of the whole integrand domain: pixel position (reconstruction
filter), lens position (depth of field), time (motion blur), and per bounce one 2D sample per light
(soft shadows), one 2D sample for the glossy / GGX direction and one for the discrete choices
(Fresnel reflect-or-refract, transparency).  A shadow ray crosses partly transparent UsdPreviewSurfaces (opacity
a < 1, which camera rays pass through with probability 1 - a) with their product of 1 - a (`_transmittance`),
and stops at any other surface.  The sampler maps (pixel, sample index, dimension) to
stratified or low-discrepancy numbers; dimensions are decorrelated by the sampler's per-pair
scrambling.  Light transport is Whitted's plus Cook's distributions: direct light from every light
at every hit, and one specular continuation (mirror, glossy, glaze, refraction) per bounce, chosen
stochastically where there are several, up to `max_depth` bounces.  Diffuse interreflection is not
simulated (as in the course).

The kernel is a megakernel: one numba-parallel loop over image tiles, each thread tracing whole
paths on the two-level Embree scene: camera rays and first-hit shadow rays (the coherent ones) in
packets of 16 (`trace.Packet`: one 16-wide query, or two 8-wide ones where the CPU has no 16-wide
kernels), deeper bounces (which start at the surface: tnear 0,
tfar infinite) with rtcIntersect1 / rtcOccluded1.  Tiles are visited in a scattered order so that both
threads get a mix of cheap and expensive regions.  Every random number is a pure function of (seed,
pixel, sample index, dimension), so the image is bit-identical for a given seed whatever the thread
count, and passes of samples add up exactly to one render.

The kernels pass named records (`records.py`): a pass's `PassParams`, a path's `Path` (its
`SampleKey`, packet lane and time), `ShadingPoint`s, the `PathState` (radiance, throughput, medium),
the per-thread `Tracer` (Embree scene, ray buffer, counters, the first-hit `ShadowQueue`) and the
camera stage's `Lanes`.  The sample dimensions come from `dimensions.py`.  `Tracer.rec`: None (every
render), or a `ray_record.RayRecord` that receives every ray traced (benchmarks; `record_if` compiles to
nothing when it is None).
"""
import math

import numba as nb
import numpy as np

from .. import description as D
from .camera_stage import camera_rays_into, camera_samples, next_samples
from .dimensions import bsdf_dim, choice_dim, light_dim
from .features import (B_COOL_TO_WARM, B_DIELECTRIC, B_MIRRORING, B_PREVIEW_SURFACE, B_SOBOL, F_COLORS, F_EMISSION,
                       F_LIGHT_GAINS, F_MODELS, F_NORMAL_MAPS, F_OPACITY, F_SAMPLERS, F_TEXTURES)
from .jit import INLINE_JIT, KERNEL_JIT, SHADING_INLINE_JIT, SHADING_JIT, STAGE_JIT
from .lights import (CAMERA_SHARE, SPECULAR_SHARE, escaped_radiance, gained_by, light_is_area, lobe_gains,
                     sample_course_light, split_by)
from .materials import (colors, direct, direct_parts, emission, fresnel_dielectric, has_diffuse_lobe, material_gains,
                        mirror_weight, opacity, preview_params, refract, sample_ggx_h, scalars, smith_g, _schlick)
from .normal_maps import mapped_normal
from .ray_record import record_if
from .records import (Continuation, Lanes, Path, PathState, Ray, SampleKey, Scratch, ShadingPoint, ShadowQueue,
                      TileLights, Tracer)
from .samplers import SOBOL, sample_1d, sample_2d, sobol_packet
from .shapes import corner_color, corner_opacity, hit_gprim, surface
from .tables import (C_FAR, C_NEAR, MF_ATTEN, MF_IOR, MF_ROUGH, MI_MODEL, MI_NORMAL_TEX, MI_SCALAR_TEX, MI_VERTEX_COLOR,
                     S_OPACITY, VC_COLOR)
from .tiles import claim_tile
from .trace import (MASK, MASK_ALL, PACKET, TFAR, alloc_packet, alloc_ray_buffer, hit_of, intersect1,
                    intersect_packet_coherent, lane_hit, occluded1, occluded_packet, set_packet_ray, slot)
from .vecmath import dot, normalize, offset_origin, onb, reflect

# counters (per tile): rays by kind, samples dropped as non-finite, and how many of the shadow rays were
# first-hit ones traced in packets (also the ray record's kind for those)
RAYS_CAMERA, RAYS_SHADOW, RAYS_SECONDARY, BAD_SAMPLES, RAYS_SHADOW_PACKET = 0, 1, 2, 3, 4
N_COUNTERS = 5
SHADOW_EPS = 1e-5
PASS_THROUGH_MAX = 64          # transparent surfaces a ray may cross (a path without a bounce, a shadow ray)


@nb.njit(**INLINE_JIT)
def _n_lights(S):
    return S.li_type.shape[0] if S.li_type[0] >= 0 else 0


def new_scratch(n_lights, width=16, camera_width=16, tile_lights=0):
    """One thread's scratch for `render_tiles`, allocated by the host (numpy) once per render: the camera
    `Packet`, the single-ray buffer (f, u), matrix scratch, the tile's counters, the first-hit
    `ShadowQueue`, the camera stage's `Lanes` (structure of arrays, so that its loops over the lanes
    vectorise) and the path integrator's `TileLights` for `tile_lights` lights (`tile_lights.py`; 0: none).
    The queue's packets are traced `width` (16 or 8: `embree.Device.packet_width`) rays at a time, the camera
    packets `camera_width`.  The kernels allocate nothing."""
    f, u = alloc_ray_buffer()
    # the queue: packet, lane of each ray, unoccluded contributions, count, first-hit direct light per
    # lane, and the first hit's light samples (pairs light_dim(0, k): rows 2k, 2k + 1), drawn for the
    # whole packet by `sobol_packet` with the Sobol' sampler
    queue = ShadowQueue(alloc_packet(width), np.zeros(PACKET, np.int64), np.zeros((PACKET, 3)), np.zeros(1, np.int64),
                        np.zeros((PACKET, 3)), np.zeros((2 * max(n_lights, 1), PACKET)))
    # origins, directions (3, PACKET); times; (pixel, index, x, y); radiance (PACKET, 3); the samples of
    # the pixel and lens pairs (4, PACKET); film positions (2, PACKET); pixel and index as uint32 and
    # the Sobol' packet's scratch
    lanes = Lanes(np.zeros((3, PACKET)), np.zeros((3, PACKET)), np.zeros((1, PACKET)), np.zeros((4, PACKET), np.int64),
                  np.zeros((PACKET, 3)), np.zeros((4, PACKET)), np.zeros((2, PACKET)), np.zeros((2, PACKET), np.uint32),
                  np.zeros((6, PACKET), np.uint32))
    return Scratch(alloc_packet(camera_width), f, u, np.empty((3, 4)), np.empty(12, np.float32), np.zeros(N_COUNTERS, np.int64),
                   queue, lanes, None, new_tile_lights(tile_lights))


def new_tile_lights(n=0):
    """A thread's `TileLights` for n lights (`tile_lights.py`; 0: a scene whose light tree chooses alone)."""
    return TileLights(np.zeros(n, np.float32), np.zeros(n), np.zeros(n + 1), np.zeros(2))


@nb.njit(**STAGE_JIT)
def _first_hit_light_samples(S, pp, lanes, n, light_u):
    """With the Sobol' sampler, the first hit's light samples of the packet's lanes, drawn at once
    (vectorised) into the queue's `light_u` (pairs light_dim(0, k): rows 2k, 2k + 1)."""
    n_lights = _n_lights(S)
    for k in range(n_lights):
        if light_is_area(S, k):
            sobol_packet(pp.seed, light_dim(0, k, n_lights), lanes.key32[0], lanes.key32[1], n, np.int64(2), lanes.work,
                         light_u[2 * k:2 * k + 2])


@nb.njit(**STAGE_JIT)
def render_tile(S, tr, pp, tile, packet, lanes, accum):
    """Add samples [pp.s0, pp.s1) of the pixels of `tile` to `accum`.

    The tile's (pixel, sample) pairs, pixel-major, are traced 16 at a time: their camera rays as one
    packet (16 samples of one pixel, or neighbouring pixels when a pass has few samples), their
    first-hit shadow rays through a queue flushed as packets (`trace.occluded_packet`); deeper
    bounces use single rays.  Each lane's radiance is (path without the first-hit direct light) +
    (first-hit direct light), the latter summed per lane in light order, so a sample's value does
    not depend on which lanes share its packets: images stay bit-identical across thread counts
    and pass splits.  One call per tile: the scene tables cross the call boundary once.
    (Shading the first hits in stages, one short loop over the 16 lanes per stage - shading points,
    direct light, continuations - was measured: no gain, 0.98-1.02x.)"""
    cam = pp.cam
    ldir = tr.queue.direct
    ids = lanes.ids
    lane_t = lanes.time[0]
    lo = lanes.o
    ld = lanes.d
    total = (tile.x1 - tile.x0) * (tile.y1 - tile.y0) * (pp.s1 - pp.s0)
    cursor = (pp.s0, tile.x0, tile.y0)
    for first in range(0, total, PACKET):
        # the camera stage as loops over the lanes: which samples, their random numbers (Sobol':
        # `sobol_packet`, vectorised), filter offsets, then the rays (`camera_rays`, vectorised)
        n, cursor = next_samples(pp, tile, lanes, first, cursor)
        camera_samples(pp, lanes, n)
        if F_SAMPLERS & B_SOBOL and (F_SAMPLERS == B_SOBOL or pp.sampler == SOBOL):
            _first_hit_light_samples(S, pp, lanes, n, tr.queue.light_u)
        camera_rays_into(pp, lanes, packet, n)
        for j in range(n):
            record_if(tr.rec, tr.tile, RAYS_CAMERA, (lo[0, j], lo[1, j], lo[2, j]), (ld[0, j], ld[1, j], ld[2, j]),
                      cam[C_NEAR], cam[C_FAR], lane_t[j])
            for k in range(3):
                ldir[j, k] = 0.0
        intersect_packet_coherent(tr.scene, packet)
        tr.counts[RAYS_CAMERA] += n
        for j in range(n):
            path = Path(SampleKey(pp.sampler, pp.seed, ids[0, j], ids[1, j], pp.spp), j, lane_t[j])
            r, g, bl = trace_path(S, tr, path, Ray((lo[0, j], lo[1, j], lo[2, j]), (ld[0, j], ld[1, j], ld[2, j])),
                                  pp.max_depth, packet)
            lanes.L[j, 0] = r
            lanes.L[j, 1] = g
            lanes.L[j, 2] = bl
        _flush_shadows(tr.scene, tr.queue)
        _accumulate(lanes, ldir, n, accum, (pp.window[0], pp.window[1]), tr.counts)


@nb.njit(**STAGE_JIT)
def _accumulate(lanes, ldir, n, accum, origin, counts):
    """Add each lane's radiance (path + first-hit direct light) to its pixel of `accum`, whose pixel (0, 0)
    is image pixel `origin`; count non-finite ones."""
    ox, oy = origin
    for j in range(n):
        r = lanes.L[j, 0] + ldir[j, 0]
        g = lanes.L[j, 1] + ldir[j, 1]
        bl = lanes.L[j, 2] + ldir[j, 2]
        if math.isfinite(r) and math.isfinite(g) and math.isfinite(bl):
            x = lanes.ids[2, j] - ox
            y = lanes.ids[3, j] - oy
            accum[y, x, 0] += r
            accum[y, x, 1] += g
            accum[y, x, 2] += bl
        else:
            counts[BAD_SAMPLES] += 1


@nb.njit(**STAGE_JIT)
def _enqueue_shadow(tr, lane, po, wi, smax, time, c, mask):
    """Queue a shadow ray (ray mask `mask`) whose unoccluded contribution c = (r, g, b) goes to `lane`'s
    light (`ShadowQueue.direct`); the queue is traced as one packet when it holds 16."""
    q = tr.queue
    n = q.count[0]
    set_packet_ray(q.packet, n, po, wi, 0.0, smax, time)
    q.packet.u[slot(q.packet, MASK, n)] = mask
    q.lane[n] = lane
    q.contrib[n, 0] = c[0]
    q.contrib[n, 1] = c[1]
    q.contrib[n, 2] = c[2]
    q.count[0] = n + 1
    if n + 1 == PACKET:
        _flush_shadows(tr.scene, q)


@nb.njit(**SHADING_JIT)
def _flush_shadows(scene, q):
    """Trace the queued shadow rays as one packet (`trace.occluded_packet`); add the unoccluded contributions
    to their lanes' first-hit direct light."""
    n = q.count[0]
    if n == 0:
        return
    occluded_packet(scene, q.packet)
    qf = q.packet.f
    for e in range(n):
        if qf[slot(q.packet, TFAR, e)] != -np.inf:
            j = q.lane[e]
            q.direct[j, 0] += q.contrib[e, 0]
            q.direct[j, 1] += q.contrib[e, 1]
            q.direct[j, 2] += q.contrib[e, 2]
        q.packet.valid[e] = 0
    q.count[0] = 0


@nb.njit(**STAGE_JIT)
def _shading_point(S, tr, ray, time):
    """The `ShadingPoint` of the ray's hit (in the tracer's ray buffer), its normals turned towards
    the viewer (front: the ray hit the outside), with the material's colours there."""
    dvec = ray.d
    hit = hit_of(tr.f, tr.u)
    p, ng, ns, st, g, mat = surface(S, tr.scene, hit, ray.o, dvec, time, tr.m, tr.m32)
    if F_NORMAL_MAPS and S.mat_i[mat, MI_NORMAL_TEX] >= 0:       # (tr.m: the hit's placement, from `surface`)
        ns = mapped_normal(S, tr.m, hit, g, p, ns, st, S.mat_i[mat, MI_NORMAL_TEX])
    model = S.mat_i[mat, MI_MODEL]
    front = dot(ng, dvec) < 0.0
    if not front:
        ng = (-ng[0], -ng[1], -ng[2])
        ns = (-ns[0], -ns[1], -ns[2])
    if dot(ns, dvec) > 0.0:            # interpolated normal facing away: use the true one
        ns = ng
    wo = (-dvec[0], -dvec[1], -dvec[2])
    kd, ks = colors(S, mat, st)
    if F_COLORS and S.mat_i[mat, MI_VERTEX_COLOR] & VC_COLOR:   # (the displayColor fallback: a mesh's, a cloud's)
        c = corner_color(S, g, hit)
        kd = (kd[0] * c[0], kd[1] * c[1], kd[2] * c[2])
    rmo = scalars(S, mat, st, corner_opacity(S, mat, g, hit.prim_id, hit.u, hit.v))
    return ShadingPoint(p, ng, ns, st, mat, model, front, wo, kd, ks, rmo)


@nb.njit(**STAGE_JIT)
def _light_sample(S, path, depth, k, n_lights, queue):
    """The 2D sample of light k at bounce `depth` ((0.5, 0.5) for point and distant lights)."""
    u1 = 0.5
    u2 = 0.5
    if light_is_area(S, k):
        key = path.key
        if F_SAMPLERS & B_SOBOL and depth == 0 and (F_SAMPLERS == B_SOBOL or key.sampler == SOBOL):
            # drawn with the camera packet
            u1 = queue.light_u[2 * k, path.lane]
            u2 = queue.light_u[2 * k + 1, path.lane]
        else:
            u1, u2 = sample_2d(key.sampler, key.seed, key.pixel, key.index, key.spp, light_dim(depth, k, n_lights))
    return u1, u2


@nb.njit(**SHADING_INLINE_JIT)
def blocking_opacity(S, tr, o, d, time):
    """The opacity a shadow ray (o, d) meets at its hit (in the tracer's ray buffer): a UsdPreviewSurface's (at the
    hit's texture coordinates where a texture drives it), 1 for any other surface (course materials stop it)."""
    hit = hit_of(tr.f, tr.u)
    g, mat = hit_gprim(S, hit)[1:]
    if S.mat_i[mat, MI_MODEL] != D.PREVIEW_SURFACE:
        return 1.0
    st = (0.0, 0.0)
    if F_TEXTURES and S.mat_i[mat, MI_SCALAR_TEX + S_OPACITY] >= 0:
        st = surface(S, tr.scene, hit, o, d, time, tr.m, tr.m32)[3]
    return opacity(S, mat, st, corner_opacity(S, mat, g, hit.prim_id, hit.u, hit.v))


@nb.njit(**SHADING_INLINE_JIT)
def cross_surface(S, tr, o, d, smax, time, vis):
    """After a shadow ray's hit (in the tracer's ray buffer), what crosses it: (vis times 1 - its opacity, 0 where it
    stops the ray; the distance to trace on from, past the hit), the next ray counted."""
    a = blocking_opacity(S, tr, o, d, time)
    if a >= 1.0:
        return 0.0, 0.0
    th = float(tr.f[TFAR])
    tn = th + 1e-5 * max(th, 1e-3)
    tr.counts[RAYS_SHADOW] += 1
    record_if(tr.rec, tr.tile, RAYS_SHADOW, o, d, tn, smax, time)
    return vis * (1.0 - a), tn


@nb.njit(**STAGE_JIT)
def _transmittance(S, tr, o, d, smax, time):
    """The fraction of light that crosses the shadow ray (o, d) up to smax: 0 behind a surface that is not a partly
    transparent UsdPreviewSurface, else the product of 1 - opacity of those it crosses (at the hit's texture
    coordinates where a texture drives the opacity), as camera rays pass them.  Each crossing is a ray more."""
    vis = 1.0
    tn = 0.0
    for _ in range(PASS_THROUGH_MAX + 1):
        if not intersect1(tr.scene, tr.f, tr.u, o, d, tn, smax, time):
            return vis
        vis, tn = cross_surface(S, tr, o, d, smax, time, vis)
        if vis == 0.0:
            return 0.0
    return 0.0


@nb.njit(**STAGE_JIT)
def _direct_light(S, tr, path, sp, depth, state):
    """Direct light at a shading point, one sample per light (soft shadows from area lights), added
    to the radiance state.L with throughput state.T; returns the new L.  At the first hit (depth 0)
    the shadow rays go to the packet queue and their contributions to the lane's first-hit light
    instead."""
    tr_, tg, tb = state.T
    Lr, Lg, Lb = state.L
    n_lights = _n_lights(S)
    po = offset_origin(sp.p, sp.ng, S.offset_scale[0])
    time = path.time
    for k in range(n_lights):
        u1, u2 = _light_sample(S, path, depth, k, n_lights, tr.queue)
        wi, dist, E = sample_course_light(S, k, sp.p, sp.ns, u1, u2)
        if E[0] == 0.0 and E[1] == 0.0 and E[2] == 0.0:
            continue
        if dot(wi, sp.ng) <= 0.0:
            continue
        gains = lobe_gains(S, k)
        if F_LIGHT_GAINS and (gains[0] != 1.0 or gains[1] != 1.0):      # (inputs:diffuse and inputs:specular)
            c, cd = direct_parts(S, sp, wi, E)
            c = split_by(gains, c, cd)
        else:
            c = direct(S, sp, wi, E)
        if c[0] == 0.0 and c[1] == 0.0 and c[2] == 0.0:
            continue
        if F_MODELS & B_COOL_TO_WARM and (F_MODELS == B_COOL_TO_WARM or sp.model == D.COOL_TO_WARM):
            pass                            # Gooch tone shading is unshadowed
        else:
            tr.counts[RAYS_SHADOW] += 1
            smax = dist * (1.0 - SHADOW_EPS) if dist < np.inf else np.inf
            if F_OPACITY and S.see_through[0]:      # see-through surfaces: the shadow ray alone, through them
                record_if(tr.rec, tr.tile, RAYS_SHADOW, po, wi, 0.0, smax, time)
                vis = _transmittance(S, tr, po, wi, smax, time)
                if vis == 0.0:
                    continue
                c = (vis * c[0], vis * c[1], vis * c[2])
            elif depth == 0:             # first hit: traced later, in a packet
                record_if(tr.rec, tr.tile, RAYS_SHADOW_PACKET, po, wi, 0.0, smax, time)
                tr.counts[RAYS_SHADOW_PACKET] += 1
                _enqueue_shadow(tr, path.lane, po, wi, smax, time, (tr_ * c[0], tg * c[1], tb * c[2]), MASK_ALL)
                continue
            else:
                record_if(tr.rec, tr.tile, RAYS_SHADOW, po, wi, 0.0, smax, time)
                if occluded1(tr.scene, tr.f, tr.u, po, wi, 0.0, smax, time):
                    continue
        Lr += tr_ * c[0]
        Lg += tg * c[1]
        Lb += tb * c[2]
    return Lr, Lg, Lb


@nb.njit(**STAGE_JIT)
def _refraction(S, key, sp, dvec, depth, state):
    """A dielectric's continuation: Fresnel-weighted choice of reflection or refraction."""
    mf = S.mat_f
    osc = S.offset_scale[0]
    ar, ag, ab = state.A
    ior = float(mf[sp.mat, MF_IOR])
    eta = ior if sp.front else 1.0 / ior
    ns = sp.ns
    ng = sp.ng
    cos_i = -dot(dvec, ns)
    F, cos_t = fresnel_dielectric(cos_i, eta)
    uc = sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp, choice_dim(depth, _n_lights(S)))
    if uc < F:
        nd = reflect(dvec, ns)
        o = offset_origin(sp.p, ng, osc)
    else:
        nd = refract(dvec, ns, eta, cos_i, cos_t)
        o = offset_origin(sp.p, (-ng[0], -ng[1], -ng[2]), osc)
        if sp.front:                         # entering the medium
            ar = float(mf[sp.mat, MF_ATTEN])
            ag = float(mf[sp.mat, MF_ATTEN + 1])
            ab = float(mf[sp.mat, MF_ATTEN + 2])
        else:
            ar = 1.0
            ag = 1.0
            ab = 1.0
    return Continuation(True, (np.float64(o[0]), np.float64(o[1]), np.float64(o[2])), nd, state.T, (ar, ag, ab))


@nb.njit(**STAGE_JIT)
def _ggx_reflection(S, key, sp, dvec, depth, state):
    """A UsdPreviewSurface's specular continuation: a GGX-sampled reflection, Russian roulette on its
    weight (keeps rough dielectrics cheap)."""
    tr, tg, tb = state.T
    ns = sp.ns
    n_lights = _n_lights(S)
    dead = Continuation(False, (0.0, 0.0, 0.0), dvec, state.T, state.A)
    diff, f0, f90, alpha = preview_params(S, sp.mat, sp.kd, sp.ks, sp.rmo)
    g1, g2 = sample_2d(key.sampler, key.seed, key.pixel, key.index, key.spp, bsdf_dim(depth, n_lights))
    tt, bb = onb(ns)
    h = normalize(sample_ggx_h(ns, alpha, g1, g2, tt, bb))
    nd = reflect(dvec, h)
    wo = sp.wo
    nv = dot(ns, wo)
    nl = dot(ns, nd)
    nh = dot(ns, h)
    vh = dot(wo, h)
    if nl <= 0.0 or nv <= 0.0 or nh <= 0.0 or vh <= 0.0 or dot(nd, sp.ng) <= 0.0:
        return dead
    gw = smith_g(nl, nv, alpha) * vh / (nh * nv)
    wr = _schlick(f0[0], f90[0], vh) * gw
    wg = _schlick(f0[1], f90[1], vh) * gw
    wb = _schlick(f0[2], f90[2], vh) * gw
    q = min(1.0, max(wr, max(wg, wb)))
    if q <= 0.0 or sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp, choice_dim(depth, n_lights)) >= q:
        return dead
    o = offset_origin(sp.p, sp.ng, S.offset_scale[0])
    return Continuation(True, (np.float64(o[0]), np.float64(o[1]), np.float64(o[2])), nd, (tr * (wr / q), tg * (wg / q), tb * (wb / q)),
                        state.A)


@nb.njit(**STAGE_JIT)
def _mirror_reflection(S, key, sp, dvec, depth, state):
    """The course's mirror (and glossy: r perturbed on a square of side `roughness`) continuation."""
    tr, tg, tb = state.T
    dead = Continuation(False, (0.0, 0.0, 0.0), dvec, state.T, state.A)
    w = mirror_weight(S, sp.mat, sp.model, sp.ks)
    if w[0] <= 0.0 and w[1] <= 0.0 and w[2] <= 0.0:
        return dead
    nd = reflect(dvec, sp.ns)
    rough = float(S.mat_f[sp.mat, MF_ROUGH])
    if rough > 0.0 and sp.model == D.BLINN_PHONG_MIRRORED:
        g1, g2 = sample_2d(key.sampler, key.seed, key.pixel, key.index, key.spp, bsdf_dim(depth, _n_lights(S)))
        tt, bb = onb(nd)
        a = rough * (g1 - 0.5)
        b = rough * (g2 - 0.5)
        nd = normalize((nd[0] + a * tt[0] + b * bb[0], nd[1] + a * tt[1] + b * bb[1],
                        nd[2] + a * tt[2] + b * bb[2]))
    if dot(nd, sp.ng) <= 0.0:
        return dead
    o = offset_origin(sp.p, sp.ng, S.offset_scale[0])
    return Continuation(True, (np.float64(o[0]), np.float64(o[1]), np.float64(o[2])), nd, (tr * w[0], tg * w[1], tb * w[2]), state.A)


@nb.njit(**STAGE_JIT)
def _continuation(S, key, sp, dvec, depth, state):
    """One specular continuation (mirror, glossy, glaze, refraction; the glossy pair is drawn only
    where a lobe uses it) from throughput state.T and medium attenuation state.A."""
    if F_MODELS & B_DIELECTRIC and (F_MODELS == B_DIELECTRIC or sp.model == D.DIELECTRIC):
        return _refraction(S, key, sp, dvec, depth, state)
    if F_MODELS & B_PREVIEW_SURFACE and (F_MODELS == B_PREVIEW_SURFACE or sp.model == D.PREVIEW_SURFACE):
        return _ggx_reflection(S, key, sp, dvec, depth, state)
    if F_MODELS & B_MIRRORING:
        return _mirror_reflection(S, key, sp, dvec, depth, state)
    return Continuation(False, (0.0, 0.0, 0.0), dvec, state.T, state.A)      # no specular lobe


@nb.njit(**STAGE_JIT)
def trace_path(S, tr, path, ray, max_depth, packet):
    """Radiance arriving along the camera ray `ray` of `path` (lane path.lane of the traced camera
    `packet`).  Its first hit's direct light is not included: those shadow rays go to the tracer's
    queue (`_enqueue_shadow`).  (Tracing the first bounce's continuation rays of a packet as one more
    packet was measured: no gain, 0.99-1.02x, at twice the compile time.)"""
    key = path.key
    time = path.time
    Lr, Lg, Lb = 0.0, 0.0, 0.0
    tr_, tg, tb = 1.0, 1.0, 1.0
    ar, ag, ab = 1.0, 1.0, 1.0
    ox, oy, oz = ray.o
    dx, dy, dz = ray.d
    n_lights = _n_lights(S)
    osc = S.offset_scale[0]            # scale of the near-origin ray offset (build.offset_scale)
    for depth in range(0, max_depth + 1):
        if depth == 0:                     # traced in the camera packet: copy the lane's hit
            hit = lane_hit(packet, path.lane, tr.f, tr.u)
        else:
            record_if(tr.rec, tr.tile, RAYS_SECONDARY, (ox, oy, oz), (dx, dy, dz), 0.0, np.inf, time)
            hit = intersect1(tr.scene, tr.f, tr.u, (ox, oy, oz), (dx, dy, dz), 0.0, np.inf, time)
            tr.counts[RAYS_SECONDARY] += 1
        dvec = (float(dx), float(dy), float(dz))
        if not hit:                        # (past a specular continuation: the domes' inputs:specular)
            e = escaped_radiance(S, dvec, SPECULAR_SHARE if depth > 0 else CAMERA_SHARE)
            Lr += tr_ * e[0]
            Lg += tg * e[1]
            Lb += tb * e[2]
            break
        t = float(tr.f[TFAR])
        if F_MODELS & B_DIELECTRIC and (ar != 1.0 or ag != 1.0 or ab != 1.0):
            tr_ *= ar ** t
            tg *= ag ** t
            tb *= ab ** t
        sp = _shading_point(S, tr, Ray((float(ox), float(oy), float(oz)), dvec), time)
        mat = sp.mat
        # ---- transparency (UsdPreviewSurface opacity): pass straight through with prob. 1 - opacity
        if F_MODELS & B_PREVIEW_SURFACE and (F_MODELS == B_PREVIEW_SURFACE or sp.model == D.PREVIEW_SURFACE):
            opacity = sp.rmo[2]
            if F_OPACITY and opacity < 1.0:
                if sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp,
                             choice_dim(depth, n_lights)) >= opacity:
                    ox, oy, oz = offset_origin(sp.p, (-sp.ng[0], -sp.ng[1], -sp.ng[2]), osc)
                    continue
            if F_EMISSION:
                em = emission(S, mat, sp.st)
                if F_LIGHT_GAINS:           # (a MeshLightAPI mesh's gains; past a continuation: specular)
                    em = gained_by(material_gains(S, mat), SPECULAR_SHARE if depth > 0 else CAMERA_SHARE, em)
                Lr += tr_ * em[0]
                Lg += tg * em[1]
                Lb += tb * em[2]
        if has_diffuse_lobe(sp.model):
            Lr, Lg, Lb = _direct_light(S, tr, path, sp, depth, PathState((Lr, Lg, Lb), (tr_, tg, tb), (ar, ag, ab)))
        if depth == max_depth:
            break
        nxt = _continuation(S, key, sp, dvec, depth, PathState((Lr, Lg, Lb), (tr_, tg, tb), (ar, ag, ab)))
        if not nxt.alive:
            break
        ox, oy, oz = nxt.o
        dx, dy, dz = nxt.d
        tr_, tg, tb = nxt.T
        ar, ag, ab = nxt.A
        if tr_ == 0.0 and tg == 0.0 and tb == 0.0:
            break
    return Lr, Lg, Lb


@nb.njit(**KERNEL_JIT)
def render_tiles(S, scene, pp, scratch, work, accum, counters):
    """Add samples [pp.s0, pp.s1) of the tiles of the pass's window this thread claims to `accum`
    (window height, width, 3) float64: the host runs it on every render thread at once, each with its own
    `Scratch`; `work` (int64 [1]) is the pass's shared tile counter (`tiles.claim_tile`: the next
    unclaimed tile, atomically), so threads share the tiles dynamically.  pp: `PassParams`; counters: int64
    (n_tiles, N_COUNTERS), one row per tile (no shared writes).  scratch.rec: None, or a
    `ray_record.RayRecord` that receives every ray traced.  Which thread renders a tile changes nothing
    in it: images are bit-identical for any thread count."""
    counts = scratch.counts
    while True:
        tile = claim_tile(pp, work)
        if tile.index < 0:
            break
        for k in range(N_COUNTERS):
            counts[k] = 0
        tr = Tracer(scene, scratch.f, scratch.u, scratch.m, scratch.m32, counts, scratch.queue, tile.index,
                    scratch.rec, scratch.tl)
        render_tile(S, tr, pp, tile, scratch.packet, scratch.lanes, accum)
        for k in range(N_COUNTERS):
            counters[tile.index, k] += counts[k]
