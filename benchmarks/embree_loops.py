"""Bare Embree loops for the benchmarks and tests: rays in, hits out, no shading.

They measure what Embree alone costs on given rays (benchmarks/bench_embree.py, bench_render.py's
replay of the renderer's own rays) and check packets against single rays (tests/renderer/test_embree.py).
They use the renderer's ray queries (`rtc.renderer.kernel.trace`) but are no part of the renderer:
nothing in it imports this module, so no render compiles or loads them.
"""
from __future__ import annotations

import numba
import numpy as np

from rtc.renderer.kernel.jit import INLINE_JIT, JIT
from rtc.renderer.kernel.light_sampling import shape_mask
from rtc.renderer.kernel.trace import (GEOM_ID, INST_ID, INST_PRIM_ID, INVALID, MASK, MASK_ALL, MASK_SURFACES, PACKET,
                                       PRIM_ID, TFAR, intersect1, intersect1_masked, intersect_packet,
                                       intersect_packet_coherent, new_packet, new_ray_buffer, occluded1,
                                       occluded1_surfaces, occluded_packet, set_packet_ray, slot)

# rays per work item, and the prime stride that scatters work items over threads (numba hands each
# thread a contiguous block of a prange; images are not uniform)
CHUNK = 256
_SCATTER = 7919


@numba.njit(**INLINE_JIT)
def _work_item(i, n_items):
    """Visit work items in the order (i * 7919) % n (a permutation unless 7919 divides n)."""
    stride = _SCATTER if n_items % _SCATTER != 0 else 1
    return (i * stride) % n_items


@numba.njit(**JIT, parallel=True)
def trace_rays(scene, origins, dirs, tnear, tfar, time, out_t, out_ids):
    """Closest hit for n rays with rtcIntersect1.  origins, dirs: float32 (n, 3); tnear, tfar,
    time: float32 (n,).  out_t float32 (n,) = hit t (tfar on a miss); out_ids uint32 (n, 4) =
    primID, geomID, instID, instPrimID (all INVALID on a miss)."""
    n_items = (origins.shape[0] + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        _trace_item1(scene, _work_item(i, n_items), (origins, dirs, tnear, tfar, time), out_t, out_ids, None)


@numba.njit(**JIT, parallel=True)
def trace_rays_masked(scene, rays, masks, out_t, out_ids, packets):
    """``trace_rays`` (``trace_packets`` traced `packets` = 16 or 8 at a time if `packets`, else single rays)
    of rays = (origins, dirs, tnear, tfar, time), ray r with ray mask masks[r] (uint32 (n,): `ray_masks`)."""
    n_items = (rays[0].shape[0] + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        if packets:
            _trace_item16(scene, _work_item(i, n_items), rays, (out_t, out_ids), False, masks, packets)
        else:
            _trace_item1(scene, _work_item(i, n_items), rays, out_t, out_ids, masks)


@numba.njit(**JIT)
def _trace_item1(scene, item, rays, out_t, out_ids, masks):
    """Work item `item` of `trace_rays` (masks: None, every geometry, or one ray mask per ray)."""
    origins, dirs, tnear, tfar, time = rays
    f, u = new_ray_buffer()
    for r in range(item * CHUNK, min(origins.shape[0], (item + 1) * CHUNK)):
        o, d = (origins[r, 0], origins[r, 1], origins[r, 2]), (dirs[r, 0], dirs[r, 1], dirs[r, 2])
        if masks is None:
            hit = intersect1(scene, f, u, o, d, tnear[r], tfar[r], time[r])
        else:
            hit = intersect1_masked(scene, f, u, (o, d), tnear[r], tfar[r], time[r], masks[r])
        out_t[r] = f[TFAR]
        out_ids[r, 0] = u[PRIM_ID] if hit else INVALID
        out_ids[r, 1] = u[GEOM_ID]
        out_ids[r, 2] = u[INST_ID]
        out_ids[r, 3] = u[INST_PRIM_ID]


@numba.njit(**JIT)
def ray_masks(L, dirs, out):
    """out[r]: the ray mask the path integrator gives a camera or BSDF ray along dirs[r]
    (`light_sampling.shape_mask`; L: its `PathLights`)."""
    for r in range(dirs.shape[0]):
        out[r] = shape_mask(L, (np.float64(dirs[r, 0]), np.float64(dirs[r, 1]), np.float64(dirs[r, 2])))


@numba.njit(**JIT, parallel=True)
def occlude_rays(scene, origins, dirs, tnear, tfar, time, out_occluded, surfaces=False):
    """Occlusion for n rays with rtcOccluded1 (arguments as ``trace_rays``); out_occluded bool (n,);
    surfaces: with the ray mask of the path integrator's shadow rays (`trace.MASK_SURFACES`: light shapes
    occlude nothing), else every geometry occludes."""
    n = origins.shape[0]
    n_items = (n + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        item = _work_item(i, n_items)
        f, u = new_ray_buffer()
        for r in range(item * CHUNK, min(n, (item + 1) * CHUNK)):
            o, d = (origins[r, 0], origins[r, 1], origins[r, 2]), (dirs[r, 0], dirs[r, 1], dirs[r, 2])
            if surfaces:
                out_occluded[r] = occluded1_surfaces(scene, f, u, o, d, tnear[r], tfar[r], time[r])
            else:
                out_occluded[r] = occluded1(scene, f, u, o, d, tnear[r], tfar[r], time[r])


@numba.njit(**INLINE_JIT)
def _load_packet(packet, first, end, origins, dirs, tnear, tfar, time):
    """Fill a 16-ray packet with rays [first, min(first + 16, end)); returns the number of lanes."""
    lanes = min(PACKET, end - first)
    packet.valid[:] = 0
    for j in range(lanes):
        r = first + j
        set_packet_ray(packet, j, (origins[r, 0], origins[r, 1], origins[r, 2]),
                       (dirs[r, 0], dirs[r, 1], dirs[r, 2]), tnear[r], tfar[r], time[r])
    return lanes


@numba.njit(**JIT)
def _trace_item16(scene, item, rays, out, coherent, masks, width):
    """Work item `item` of `trace_packets` (a function of its own: numba's parfor analysis of an
    inlined packet record in the prange body gives wrong results); out = (out_t, out_ids)."""
    origins, dirs, tnear, tfar, time = rays
    out_t, out_ids = out
    n = origins.shape[0]
    packet = new_packet(width)
    f, u = packet.f, packet.u
    end = min(n, (item + 1) * CHUNK)
    for first in range(item * CHUNK, end, PACKET):
        lanes = _load_packet(packet, first, end, origins, dirs, tnear, tfar, time)
        if masks is not None:
            for j in range(lanes):
                u[slot(packet, MASK, j)] = masks[first + j]
        if coherent:
            intersect_packet_coherent(scene, packet)
        else:
            intersect_packet(scene, packet)
        for j in range(lanes):
            r = first + j
            out_t[r] = f[slot(packet, TFAR, j)]
            geom = u[slot(packet, GEOM_ID, j)]
            out_ids[r, 0] = u[slot(packet, PRIM_ID, j)] if geom != INVALID else INVALID
            out_ids[r, 1] = geom
            out_ids[r, 2] = u[slot(packet, INST_ID, j)]
            out_ids[r, 3] = u[slot(packet, INST_PRIM_ID, j)]


@numba.njit(**JIT, parallel=True)
def trace_packets(scene, rays, out_t, out_ids, width=16):
    """``trace_rays`` of rays = (origins, dirs, tnear, tfar, time) in packets of 16 consecutive rays
    (`trace.Packet`, traced `width` = 16 or 8 at a time; order rays coherently, e.g. 4x4 pixel tiles, for
    packets to pay off)."""
    n_items = (rays[0].shape[0] + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        _trace_item16(scene, _work_item(i, n_items), rays, (out_t, out_ids), False, None, width)


@numba.njit(**JIT, parallel=True)
def trace_packets_coherent(scene, rays, out_t, out_ids, width=16):
    """``trace_packets`` in Embree's coherent mode (RTC_RAY_QUERY_FLAG_COHERENT,
    `trace.intersect_packet_coherent`)."""
    n_items = (rays[0].shape[0] + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        _trace_item16(scene, _work_item(i, n_items), rays, (out_t, out_ids), True, None, width)


@numba.njit(**JIT)
def _occlude_item16(scene, item, rays, out_occluded, mask, width):
    """Work item `item` of `occlude_packets` (ray mask `mask`)."""
    origins, dirs, tnear, tfar, time = rays
    n = origins.shape[0]
    packet = new_packet(width)
    end = min(n, (item + 1) * CHUNK)
    for first in range(item * CHUNK, end, PACKET):
        lanes = _load_packet(packet, first, end, origins, dirs, tnear, tfar, time)
        for j in range(lanes):
            packet.u[slot(packet, MASK, j)] = mask
        occluded_packet(scene, packet)
        for j in range(lanes):
            out_occluded[first + j] = packet.f[slot(packet, TFAR, j)] == -np.inf


@numba.njit(**JIT, parallel=True)
def occlude_packets(scene, rays, out_occluded, surfaces=False, width=16):
    """``occlude_rays`` of rays = (origins, dirs, tnear, tfar, time) in packets of 16 consecutive rays
    (traced `width` = 16 or 8 at a time)."""
    n_items = (rays[0].shape[0] + CHUNK - 1) // CHUNK
    mask = MASK_SURFACES if surfaces else MASK_ALL
    for i in numba.prange(n_items):
        _occlude_item16(scene, _work_item(i, n_items), rays, out_occluded, mask, width)
