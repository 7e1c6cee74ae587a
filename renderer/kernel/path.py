"""The path integrator: unbiased path tracing with next-event estimation and BSDF sampling combined
by multiple importance sampling (Veach 1997, ch. 9; power heuristic, beta = 2).

At every vertex a path collects the light it sees (emission of the light shapes its last ray
crossed, of the surface it hit - emissive surfaces are lights too, `surface_lights.py` -, of the sky
if it escaped: MIS-weighted against the light sample that could have found the same light), then
samples one light chosen from the light tree (`light_tree.choose_lights`: by power, distance and
orientation; one or two more where one light outshines the rest; at the first vertex of a scene of many
lights, from its tile's table: `tile_lights.py`) towards which it casts a shadow ray,
then samples its BSDF for the next ray (`bsdf.sample_seen`, from the vertex's `bsdf.seen_from` record,
which its light samples evaluate too).  Delta lights (point, distant without angle) are found by
next-event estimation alone, delta lobes (mirror, dielectric) by BSDF sampling alone.  `max_depth` D
counts bounces as pbrt does: D = 0 is emission only, D = 1 direct light only.  After RR_DEPTH bounces,
Russian roulette ends a path with probability 1 - min(1, max throughput) (throughput without the
1/eta^2 of refraction) and reweights the survivors: unbiased.  No value is clamped.

Strategies (`STRATEGIES`, for tests and benchmarks): 'mis' (the default), 'nee' (light sampling
alone for the light shapes and skies, BSDF sampling still continues paths and finds delta-lobe
paths), 'bsdf' (BSDF sampling alone: delta lights contribute nothing).

Records (`records.py`): a pass's `PassParams`, a path's `SampleKey`, the `Tracer` (Embree scene, ray
buffers, counters), `ShadingPoint`s, a `Vertex` (the frame and ray origin next-event estimation needs)
and a `PrevVertex` (what a BSDF-sampled ray left behind: the MIS weight of the light it finds).

Sampling: every random number is `sample_2d/1d(sampler, seed, pixel, index, spp, pair)`; the pairs
are DIM_PIXEL, DIM_LENS, DIM_TIME (camera) and per path vertex v the PATH_PAIRS pairs from
`path_dim(v, P_*)`: light point (2D), light choice, BSDF direction (2D), lobe choice (also the
opacity choice, rescaled), roulette.  Pure functions of their arguments: images are bit-identical
whatever the thread count or the split into passes.  Camera rays are traced in packets of 16
(Embree's coherent mode: `trace.intersect_packet_coherent`; 16 or 8 at a time, `trace.Packet`), BSDF rays
alone (rtcIntersect1).  A shadow ray only decides whether its light sample counts, so where no surface is
see-through and Embree runs packets natively it is queued with its contribution (`_defer_shadow`) and
traced with 15 others (`trace.occluded_packet`: Embree's fixed cost per query shared by 8 or 16 rays), the unoccluded
contributions added to their lanes' light once the camera packet's paths are done; in scenes with
see-through surfaces (partial opacity) shadow rays are traced alone, through them
(`shadow_transmittance`).
"""

import math

import numba as nb
import numpy as np

from .. import description as D
from .bsdf import (BLACK, course_bsdf, diffuse_share, evaluate_parts, evaluate_seen, is_delta, preview_bsdf,
                   sample_seen, seen_from)
from .camera_stage import camera_rays_into, camera_samples, next_samples
from .dimensions import P_BSDF, P_CHOICE, P_LIGHT, P_LOBE, P_RR, path_dim
from .features import (B_COOL_TO_WARM, B_DIELECTRIC, B_PREVIEW_SURFACE, F_CLEARCOAT, F_EMISSION, F_LIGHT_GAINS,
                       F_LIGHT_SHAPES, F_MODELS, F_OPACITY, F_SURFACE_LIGHTS)
from .integrator import (BAD_SAMPLES, N_COUNTERS, PASS_THROUGH_MAX, RAYS_CAMERA, RAYS_SECONDARY, RAYS_SHADOW,
                         RAYS_SHADOW_PACKET, _enqueue_shadow, _flush_shadows, _shading_point, cross_surface)
from .jit import KERNEL_JIT, SHADING_INLINE_JIT, STAGE_JIT
from .light_sampling import escaped_emission, sample_ld_lobe, shape_emission, shape_mask
from .light_tree import NO_SAMPLE, choose_lights, lone_light
from .lights import CAMERA_SHARE, gained_by, lobe_gains, shaped, split_by
from .materials import (GOOCH_ALPHA, GOOCH_BETA, GOOCH_BLUE, GOOCH_YELLOW, emission, material_gains, preview_params,
                        scalar)
from .ray_record import record_if
from .lobe_sampling import NO_LOBE, glossy_lobe
from .records import Path, PrevVertex, Ray, SampleKey, Tracer, Vertex
from .samplers import sample_1d_inlined as sample_1d, sample_2d_inlined as sample_2d
from .surface_lights import sample_surface, shadow_ray, surface_emission
from .tables import (C_FAR, C_NEAR, MF_ATTEN, MF_CC_ROUGH, MF_CLEARCOAT, MF_EXP, MF_IOR, MF_MIRROR, MF_ROUGH,
                     S_CC_ROUGH, S_CLEARCOAT, SLI_MAT)
from .tile_lights import build_tile_lights, choose_tile_lights, tiled
from .tiles import claim_tile
from .trace import (GEOM_ID, INST_ID, INVALID, MASK, MASK_ALL, MASK_SURFACES, PACKET, PRIM_ID, TFAR,
                    intersect1_masked, intersect1_surfaces, intersect_packet_coherent, lane_hit,
                    occluded1_surfaces, placed_hit, slot)
from .vecmath import add, dot, offset_origin, onb, to_world

STRATEGIES = {'mis': 0, 'nee': 1, 'bsdf': 2}
MIS, NEE_ONLY, BSDF_ONLY = 0, 1, 2
# emission weights of `light_sampling.area_emission` (PrevVertex.mode)
W_POWER, W_ONE, W_ZERO = 0, 1, 2
RR_DEPTH = 3
SHADOW_EPS = 1e-5


@nb.njit(**STAGE_JIT)
def vertex_bsdf(S, sp):
    """The `bsdf.Bsdf` of the shading point's material (its textured colours) seen from its side."""
    mf = S.mat_f
    mat = sp.mat
    kd = sp.kd
    if F_MODELS & B_PREVIEW_SURFACE and (F_MODELS == B_PREVIEW_SURFACE or sp.model == D.PREVIEW_SURFACE):
        diff, f0, f90, alpha = preview_params(S, mat, kd, sp.ks, sp.rmo)
        if F_CLEARCOAT:
            ca = max(scalar(S, mat, sp.st, MF_CC_ROUGH, S_CC_ROUGH), 0.001)
            return preview_bsdf(diff, f0, f90, alpha, scalar(S, mat, sp.st, MF_CLEARCOAT, S_CLEARCOAT), ca * ca)
        return preview_bsdf(diff, f0, f90, alpha, 0.0, 1e-6)
    cool = BLACK
    if F_MODELS & B_COOL_TO_WARM and (F_MODELS == B_COOL_TO_WARM or sp.model == D.COOL_TO_WARM):
        cool = (GOOCH_ALPHA * kd[0], GOOCH_ALPHA * kd[1], GOOCH_BLUE + GOOCH_ALPHA * kd[2])
        kd = (GOOCH_YELLOW + GOOCH_BETA * kd[0], GOOCH_YELLOW + GOOCH_BETA * kd[1], GOOCH_BETA * kd[2])
    return course_bsdf(sp.model, kd, sp.ks, float(mf[mat, MF_EXP]), float(mf[mat, MF_MIRROR]),
                       float(mf[mat, MF_ROUGH]), float(mf[mat, MF_IOR]), sp.front, cool)


@nb.njit(**SHADING_INLINE_JIT)
def queues_shadows(L):
    """Whether a light sample's shadow ray waits in the queue for a packet (`_defer_shadow`): where
    Embree runs packets with its own 16- or 8-wide kernels (`PathLights.shadow_packets`) and no surface is
    see-through (a see-through surface needs `shadow_transmittance`'s walk through it)."""
    return L.shadow_packets and not (F_OPACITY and L.see_through)


@nb.njit(**STAGE_JIT)
def next_event(S, L, tr, key, v, vtx, b, strategy):
    """Light from the light samples at path vertex v (its `Vertex` vtx, its BSDF b seen from the
    vertex's wo: `bsdf.seen_from`): one, and a side sample or two where the light tree splits
    (`light_tree.choose_lights`; at a first vertex the tile's choice, `tile_lights.py`; each of another light,
    all from the same light-point sample), each MIS-weighted against BSDF sampling; not yet multiplied by
    the path throughput."""
    lone = lone_light(L)
    if lone >= 0:
        main, side1, side2 = (lone, 1.0), NO_SAMPLE, NO_SAMPLE
    else:
        u = sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp, path_dim(v, P_CHOICE))
        if tiled(L, v):                                              # a first vertex: the tile's choice
            main, side1, side2 = choose_tile_lights(L, tr.tl, u)
        else:
            main, side1, side2 = choose_lights(L, vtx.p, vtx.ns, u)
    if main[0] < 0 and side1[0] < 0 and side2[0] < 0:
        return BLACK
    u = sample_2d(key.sampler, key.seed, key.pixel, key.index, key.spp, path_dim(v, P_LIGHT))
    c = light_sample(S, L, tr, vtx, b, strategy, main, u)
    if side1[0] >= 0:
        c = add(c, light_sample(S, L, tr, vtx, b, strategy, side1, u))
    if side2[0] >= 0:
        c = add(c, light_sample(S, L, tr, vtx, b, strategy, side2, u))
    return c


@nb.njit(**STAGE_JIT)
def light_sample(S, L, tr, vtx, b, strategy, chosen, u):
    """Light from one sample u = (u1, u2) of light chosen = (k, its expected number of samples pk) at
    vertex vtx."""
    k, pk = chosen
    if k < 0:
        return BLACK
    if F_SURFACE_LIGHTS and k >= L.surface_first:
        wi, dist, Le, pdf, delta = sample_surface(S, L, tr, k, vtx.p, vtx.time, u[0], u[1])
    else:
        wi, dist, Le, pdf, delta = sample_ld_lobe(S, L, k, vtx, u)
        Le = shaped(S, k, wi, Le)                        # (a spotlight's cone and focus)
    if not pdf > 0.0 or dot(wi, vtx.ng) <= 0.0:
        return BLACK
    il = (dot(wi, vtx.tt), dot(wi, vtx.bb), dot(wi, vtx.ns))
    gains = _gains(S, L, k)
    if F_LIGHT_GAINS and (gains[0] != 1.0 or gains[1] != 1.0):      # (its effect on each kind of lobe)
        fc, fd, pb = evaluate_parts(b, il)
        fc = split_by(gains, fc, fd)
    else:
        fc, pb = evaluate_seen(b, il)
    if fc[0] == 0.0 and fc[1] == 0.0 and fc[2] == 0.0:
        return BLACK
    pl = pk * pdf
    w = 1.0 if (delta or strategy == NEE_ONLY) else pl * pl / (pl * pl + pb * pb)
    smax = dist * (1.0 - SHADOW_EPS) if dist < np.inf else np.inf
    ws = wi
    if F_SURFACE_LIGHTS and k >= L.surface_first:        # a point on a surface: aimed at from po
        ws, smax = shadow_ray(vtx, wi, dist, SHADOW_EPS)
        if not smax > 0.0:
            return BLACK
    if queues_shadows(L):
        s = w / pl
        T = vtx.T
        c = (T[0] * fc[0] * Le[0] * s, T[1] * fc[1] * Le[1] * s, T[2] * fc[2] * Le[2] * s)
        _defer_shadow(tr, vtx, ws, smax, c)
        return BLACK
    vis = shadow_transmittance(S, L, tr, vtx.po, ws, smax, vtx.time)
    if vis == 0.0:
        return BLACK
    s = vis * w / pl
    return fc[0] * Le[0] * s, fc[1] * Le[1] * s, fc[2] * Le[2] * s


@nb.njit(**SHADING_INLINE_JIT)
def _gains(S, L, k):
    """The lobe gains of light k: a UsdLux light's inputs:diffuse and inputs:specular (`lights.lobe_gains`), an
    emissive surface's its material's (a MeshLightAPI mesh's, `materials.material_gains`)."""
    if F_SURFACE_LIGHTS and k >= L.surface_first:
        return material_gains(S, L.sl_i[k - L.surface_first, SLI_MAT])
    return lobe_gains(S, k)


@nb.njit(**STAGE_JIT)
def _defer_shadow(tr, vtx, d, smax, c):
    """Queue the shadow ray of a light sample (from vtx.po along d up to smax; surfaces only: light shapes
    occlude nothing) whose unoccluded contribution, throughput included, is c: it goes to the lane's
    deferred direct light (`ShadowQueue.direct`) when the queue is traced, as one packet (`trace.occluded_packet`)
    every 16 rays and at the end of the camera packet's paths (`path_tile`)."""
    tr.counts[RAYS_SHADOW] += 1
    tr.counts[RAYS_SHADOW_PACKET] += 1
    record_if(tr.rec, tr.tile, RAYS_SHADOW_PACKET, vtx.po, d, 0.0, smax, vtx.time)
    _enqueue_shadow(tr, vtx.lane, vtx.po, d, smax, vtx.time, c, MASK_SURFACES)


@nb.njit(**STAGE_JIT)
def shadow_transmittance(S, L, tr, o, d, smax, time):
    """The fraction of light that crosses the shadow ray (o, d) up to smax: 0 behind an opaque
    surface, 1 when nothing is in the way, and across partly transparent UsdPreviewSurfaces (opacity
    a < 1, which camera and BSDF rays find with probability a: `trace_path`) the product of their
    1 - a, so that light sampling and BSDF sampling estimate the same light through them."""
    tr.counts[RAYS_SHADOW] += 1
    record_if(tr.rec, tr.tile, RAYS_SHADOW, o, d, 0.0, smax, time)
    if not F_OPACITY:
        return 0.0 if occluded1_surfaces(tr.scene, tr.f, tr.u, o, d, 0.0, smax, time) else 1.0
    vis = 1.0
    tn = 0.0
    for _ in range(PASS_THROUGH_MAX + 1):
        if not intersect1_surfaces(tr.scene, tr.f, tr.u, o, d, tn, smax, time):
            return vis
        placed_hit(L, tr.u)
        vis, tn = cross_surface(S, tr, o, d, smax, time, vis)
        if vis == 0.0:
            return 0.0
    return 0.0


@nb.njit(**SHADING_INLINE_JIT)
def _origin(p, n, osc):
    """`offset_origin` as float64 (the float32 values exactly)."""
    pt = offset_origin(p, n, osc)
    return float(pt[0]), float(pt[1]), float(pt[2])


@nb.njit(**SHADING_INLINE_JIT)
def _add(L, T, c):
    return L[0] + T[0] * c[0], L[1] + T[1] * c[1], L[2] + T[2] * c[2]


@nb.njit(**STAGE_JIT)
def find_surface(S, L, tr, path, ray, prev, packet, v):
    """(hit, its distance or inf, emission): the nearest surface along the ray of path vertex v (at v = 0
    the camera ray, already traced as the path's lane of the camera `packet`; Embree's hit left in the
    tracer's ray buffer) and the MIS-weighted emission of the light shapes the ray crosses before it
    (`prev`: the vertex it left).  The light shapes are in the same top level as the surfaces (instances
    L.light_group and after it): a query that meets one is continued just past it."""
    o, d = ray
    mask = MASK_ALL
    if F_LIGHT_SHAPES:                          # (the camera ray's: its lane's in the packet, `path_tile`)
        mask = np.int64(packet.u[slot(packet, MASK, path.lane)]) if v == 0 else shape_mask(L, d)
    if v == 0:
        hit = lane_hit(packet, path.lane, tr.f, tr.u)
    else:
        record_if(tr.rec, tr.tile, RAYS_SECONDARY, o, d, 0.0, np.inf, path.time)
        hit = intersect1_masked(tr.scene, tr.f, tr.u, ray, 0.0, np.inf, path.time, mask)
        tr.counts[RAYS_SECONDARY] += 1
    placed_hit(L, tr.u)
    e = BLACK
    if F_LIGHT_SHAPES:
        for _ in range(2 * L.prim_light.shape[0] + 1):          # a sphere is met twice
            inst = np.int64(tr.u[INST_ID])
            if not hit or L.light_group < 0 or inst < L.light_group or inst == INVALID:   # (the last instances)
                break
            te = float(tr.f[TFAR])
            k = L.prim_light[L.geom_off[tr.u[GEOM_ID]] + tr.u[PRIM_ID]]
            c = shape_emission(S, L, k, ray, te, prev, tr.tl)
            e = (e[0] + c[0], e[1] + c[1], e[2] + c[2])
            tn = te + 1e-5 * max(te, 1e-3)
            record_if(tr.rec, tr.tile, RAYS_SECONDARY, o, d, tn, np.inf, path.time)
            hit = intersect1_masked(tr.scene, tr.f, tr.u, ray, tn, np.inf, path.time, mask)
            tr.counts[RAYS_SECONDARY] += 1
            placed_hit(L, tr.u)
    return hit, (float(tr.f[TFAR]) if hit else np.inf), e


@nb.njit(**SHADING_INLINE_JIT)
def _n_lights(S, L):
    """The number of lights a light sample can choose from (the scene's, its emissive surfaces)."""
    n = S.li_type.shape[0] if S.li_type[0] >= 0 else 0
    if F_SURFACE_LIGHTS:
        n += L.n_surface
    return n


@nb.njit(**SHADING_INLINE_JIT)
def hit_emission(S, L, tr, sp, d, time, prev):
    """Emission of the surface at shading point sp, hit by a ray along d at `time` that left `prev`: the lights
    among emissive surfaces MIS-weighted (`surface_lights.surface_emission`), the others (and every
    emissive surface when the scene has no surface light) with weight 1."""
    em = emission(S, sp.mat, sp.st)
    if F_LIGHT_GAINS:                       # (a MeshLightAPI mesh's gains: as `lights.gained` weighs a light's)
        em = gained_by(material_gains(S, sp.mat), prev[5], em)
    if F_SURFACE_LIGHTS and L.n_surface > 0:
        return surface_emission(S, L, tr, em, (sp.p, sp.ng, d, time, sp.st), prev)
    return em


@nb.njit(**SHADING_INLINE_JIT)
def _share(sb, wi, delta):
    """PrevVertex.share of a BSDF sample: the diffuse share of its value (`bsdf.diffuse_share`) where a light
    has lobe gains (`lights.gained`); unused elsewhere."""
    return diffuse_share(sb, wi, delta) if F_LIGHT_GAINS else CAMERA_SHARE


@nb.njit(**STAGE_JIT)
def trace_path(S, L, tr, pp, path, ray, packet):
    """Radiance along the camera ray `ray` of `path` (its sample key, its lane of the camera `packet`,
    already traced, and its shutter time)."""
    max_depth, strategy = pp.max_depth, pp.strategy
    key = path.key
    time = path.time
    o, d = ray
    osc = S.offset_scale[0]
    n_lights = _n_lights(S, L)
    mf = S.mat_f
    Lo = BLACK
    T = (1.0, 1.0, 1.0)
    A = (1.0, 1.0, 1.0)
    es = 1.0                                # 1/eta^2 factors of the throughput, undone for roulette
    prev = PrevVertex(o, (0.0, 0.0, 1.0), 0.0, W_ONE, NO_LOBE, CAMERA_SHARE, False)
    after = W_POWER if strategy == MIS else (W_ZERO if strategy == NEE_ONLY else W_ONE)
    depth = 0
    for v in range(max_depth + 1 + PASS_THROUGH_MAX):
        hit, tmax, e = find_surface(S, L, tr, path, Ray(o, d), prev, packet, v)
        Lo = _add(Lo, T, e)
        if not hit:
            Lo = _add(Lo, T, escaped_emission(S, L, d, prev))
            break
        if F_MODELS & B_DIELECTRIC and (A[0] != 1.0 or A[1] != 1.0 or A[2] != 1.0):
            T = (T[0] * A[0] ** tmax, T[1] * A[1] ** tmax, T[2] * A[2] ** tmax)
        sp = _shading_point(S, tr, Ray(o, d), time)
        p, ng, ns = sp.p, sp.ng, sp.ns
        ul = sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp, path_dim(v, P_LOBE))
        if F_OPACITY and sp.model == D.PREVIEW_SURFACE:
            presence = sp.rmo[2]
            if presence < 1.0:
                if ul >= presence:                # not there: continue straight on, no bounce
                    o = _origin(p, (-ng[0], -ng[1], -ng[2]), osc)
                    continue
                ul = min(ul / presence, 0.99999994)
        if F_EMISSION:
            Lo = _add(Lo, T, hit_emission(S, L, tr, sp, d, time, prev))
        if depth == max_depth:
            break
        b = vertex_bsdf(S, sp)
        tt, bb = onb(ns)
        wl = (-dot(d, tt), -dot(d, bb), -dot(d, ns))                 # wo in the shading frame
        po = _origin(p, ng, osc)
        sb = seen_from(b, wl)
        lobe = glossy_lobe(sb, (tt, bb, ns))
        if strategy != BSDF_ONLY and n_lights > 0 and not is_delta(b):
            Lo = _add(Lo, T, next_event(S, L, tr, key, v, Vertex(p, ng, ns, tt, bb, wl, po, time, T, path.lane, lobe),
                                        sb, strategy))
        u1, u2 = sample_2d(key.sampler, key.seed, key.pixel, key.index, key.spp, path_dim(v, P_BSDF))
        il, w, pdf, delta = sample_seen(sb, ul, u1, u2)
        if w[0] == 0.0 and w[1] == 0.0 and w[2] == 0.0:
            break
        wi = to_world(il, tt, bb, ns)
        if il[2] > 0.0:
            if dot(wi, ng) <= 0.0:
                break
            o = po
        elif F_MODELS & B_DIELECTRIC:                  # refraction
            if dot(wi, ng) >= 0.0:
                break
            o = _origin(p, (-ng[0], -ng[1], -ng[2]), osc)
            es /= w[0]
            if sp.front:
                A = (np.float64(mf[sp.mat, MF_ATTEN]), np.float64(mf[sp.mat, MF_ATTEN + 1]),
                     np.float64(mf[sp.mat, MF_ATTEN + 2]))
            else:
                A = (1.0, 1.0, 1.0)
        else:
            break
        T = (T[0] * w[0], T[1] * w[1], T[2] * w[2])
        prev = PrevVertex(p, ns, pdf, W_ONE if delta else after, lobe, _share(sb, il, delta), tiled(L, v))
        d = wi
        depth += 1
        if depth >= RR_DEPTH:
            q = max(T[0], T[1], T[2]) * es
            if q < 1.0:
                if sample_1d(key.sampler, key.seed, key.pixel, key.index, key.spp, path_dim(v, P_RR)) >= q:
                    break
                T = (T[0] / q, T[1] / q, T[2] / q)
    return Lo


@nb.njit(**STAGE_JIT)
def path_tile(S, L, tr, pp, tile, packet, lanes, accum):
    """Add samples [pp.s0, pp.s1) of the pixels of `tile` to accum; (pixel, sample) pairs pixel-major,
    16 per camera packet (`camera_stage`)."""
    lo = lanes.o
    ld = lanes.d
    ids = lanes.ids
    total = (tile.x1 - tile.x0) * (tile.y1 - tile.y0) * (pp.s1 - pp.s0)
    cursor = (pp.s0, tile.x0, tile.y0)
    if tiled(L, 0) and total > 0:
        build_tile_lights(S, L, tr, pp, tile)
    for first in range(0, total, PACKET):
        n, cursor = next_samples(pp, tile, lanes, first, cursor)
        camera_samples(pp, lanes, n)
        camera_rays_into(pp, lanes, packet, n)
        if F_LIGHT_SHAPES and L.facing.shape[0] > 0:        # (`light_sampling.shape_mask`)
            for j in range(n):
                packet.u[slot(packet, MASK, j)] = shape_mask(L, (ld[0, j], ld[1, j], ld[2, j]))
        for j in range(n):
            record_if(tr.rec, tr.tile, RAYS_CAMERA, (lo[0, j], lo[1, j], lo[2, j]), (ld[0, j], ld[1, j], ld[2, j]),
                      pp.cam[C_NEAR], pp.cam[C_FAR], lanes.time[0, j])
        intersect_packet_coherent(tr.scene, packet)
        tr.counts[RAYS_CAMERA] += n
        rad = lanes.L
        for j in range(n):
            path = Path(SampleKey(pp.sampler, pp.seed, ids[0, j], ids[1, j], pp.spp), j, lanes.time[0, j])
            c = trace_path(S, L, tr, pp, path, Ray((lo[0, j], lo[1, j], lo[2, j]), (ld[0, j], ld[1, j], ld[2, j])),
                           packet)
            rad[j, 0] = c[0]
            rad[j, 1] = c[1]
            rad[j, 2] = c[2]
        if queues_shadows(L):                             # the deferred shadow rays (`_defer_shadow`)
            q = tr.queue
            _flush_shadows(tr.scene, q)
            for j in range(n):
                for k in range(3):
                    rad[j, k] += q.direct[j, k]
                    q.direct[j, k] = 0.0
        for j in range(n):
            c = (rad[j, 0], rad[j, 1], rad[j, 2])
            if math.isfinite(c[0]) and math.isfinite(c[1]) and math.isfinite(c[2]):
                x = ids[2, j] - pp.window[0]
                y = ids[3, j] - pp.window[1]
                accum[y, x, 0] += c[0]
                accum[y, x, 1] += c[1]
                accum[y, x, 2] += c[2]
            else:
                tr.counts[BAD_SAMPLES] += 1


@nb.njit(**KERNEL_JIT)
def render_tiles_path(S, L, scene, pp, scratch, work, accum, counters):
    """Add samples [pp.s0, pp.s1) of the tiles of the pass's window this thread claims (`tiles.claim_tile`
    on the pass's shared counter `work`) to accum (window height, width, 3) float64 with the path integrator; the host runs
    it on every render thread, each with its own `Scratch` (`integrator.new_scratch`).  pp:
    `PassParams`; L: `host.light_selection.PathLights`; counters int64 (n_tiles, N_COUNTERS), one row
    per tile."""
    counts = scratch.counts
    while True:
        tile = claim_tile(pp, work)
        if tile.index < 0:
            break
        for k in range(N_COUNTERS):
            counts[k] = 0
        tr = Tracer(scene, scratch.f, scratch.u, scratch.m, scratch.m32, counts, scratch.queue, tile.index,
                    scratch.rec, scratch.tl)
        path_tile(S, L, tr, pp, tile, scratch.packet, scratch.lanes, accum)
        for k in range(N_COUNTERS):
            counters[tile.index, k] += counts[k]
