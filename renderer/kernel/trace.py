"""Ray queries callable from numba kernels, cacheable (``@njit(cache=True)``).

Why symbols by name
-------------------
A numba kernel that calls a ctypes function object embeds the function's address as a
"dynamic global" and can never be cached (every process recompiles, ~1.5 s per kernel).  Instead,
this module declares the Embree entry points by name only, as ``numba.types.ExternalFunction``
("rtc_emb4_rtcIntersect1", ...): compiled code refers to the *name*, which the JIT linker resolves
in every process - so cached kernels load.  The host's binding (`host/embree.py`) registers those
names with LLVM (``llvmlite.binding.add_symbol``) when it loads the library, before any kernel is
compiled or a cached one linked (every render builds its scene through that binding first).  The
``rtc_emb4_`` prefix keeps these symbols apart from any other Embree in the process (e.g.
Mitsuba's libembree3).  Nothing here imports the binding: the kernel layer holds no ctypes objects.
Numba invalidates a cache entry only when the kernel's own source file changes; `renderer/__init__.py`
therefore keys the whole cache directory on a hash of every renderer source file.

Single rays (RTCRayHit, 96 B, 16-byte aligned)
----------------------------------------------
A caller-owned scratch buffer viewed both as float32 and uint32 (``new_ray_buffer()``); after
``intersect1`` the hit is read at these element indices (byte offset / 4):

    ORG_X..ORG_Z 0-2, TNEAR 3, DIR_X..DIR_Z 4-6, TIME 7, TFAR 8 (= hit t), MASK 9, RAY_ID 10,
    FLAGS 11, NG_X..NG_Z 12-14, U 15, V 16, PRIM_ID 17, GEOM_ID 18, INST_ID 19, INST_PRIM_ID 20

(RTCRay is 12 fields; RTCHit is aligned to 16 B so the record is 96 B, not 84.)  Ng is the
unnormalised geometric normal in the prototype's (object) space, t is in world ray units.
INST_ID is the top-level geomID (= instance group) and INST_PRIM_ID the row in the group.
Misses leave Ng/u/v/primID stale: read them only if the query returned True.

Packets of 16 (RTCRayHit16, SoA, 64-byte aligned)
-------------------------------------------------
Field f of lane j is element ``f * 16 + j`` (same field numbers as above); ``valid`` is int32[16],
-1 = active.  Packets pay off for coherent rays (camera rays in tiles, shadow rays from coherent
hits); for incoherent bounces single rays are faster (embree.md section 9).
"""
from __future__ import annotations

import numba
import numpy as np
from numba import types

from .jit import INLINE_JIT

__all__ = [
    "SYMBOL_PREFIX", "EXTERNAL_FUNCTIONS",
    "rtcIntersect1", "rtcOccluded1", "rtcIntersect16", "rtcOccluded16", "rtcGetGeometry",
    "rtcGetGeometryTransformEx",
    "new_ray_buffer", "intersect1", "occluded1", "instance_transform",
    "new_packet16", "set_ray16", "intersect16", "occluded16",
]

SYMBOL_PREFIX = "rtc_emb4_"        # host/embree.py registers LIB.<name> as SYMBOL_PREFIX + <name>
EXTERNAL_FUNCTIONS = {}            # Embree function name -> its numba declaration


def _external(name: str, signature):
    fn = types.ExternalFunction(SYMBOL_PREFIX + name, signature)
    EXTERNAL_FUNCTIONS[name] = fn
    return fn


_p = types.uintp
# void rtcIntersect1(RTCScene, RTCRayHit*, RTCIntersectArguments* = NULL)
rtcIntersect1 = _external("rtcIntersect1", types.void(_p, _p, _p))
# void rtcOccluded1(RTCScene, RTCRay*, RTCOccludedArguments* = NULL)
rtcOccluded1 = _external("rtcOccluded1", types.void(_p, _p, _p))
# void rtcIntersect16(const int* valid, RTCScene, RTCRayHit16*, RTCIntersectArguments* = NULL)
rtcIntersect16 = _external("rtcIntersect16", types.void(_p, _p, _p, _p))
# void rtcOccluded16(const int* valid, RTCScene, RTCRay16*, RTCOccludedArguments* = NULL)
rtcOccluded16 = _external("rtcOccluded16", types.void(_p, _p, _p, _p))
# RTCGeometry rtcGetGeometry(RTCScene, unsigned geomID)  (plain lookup, safe on a committed scene)
rtcGetGeometry = _external("rtcGetGeometry", _p(_p, types.uint32))
# void rtcGetGeometryTransformEx(RTCGeometry, unsigned instPrimID, float time, RTCFormat, void* xfm)
rtcGetGeometryTransformEx = _external("rtcGetGeometryTransformEx",
                                      types.void(_p, types.uint32, types.float32, types.int32, _p))

# element indices into the ray/hit records (byte offset / 4), see the module docstring
ORG_X, ORG_Y, ORG_Z, TNEAR, DIR_X, DIR_Y, DIR_Z, TIME, TFAR, MASK, RAY_ID, FLAGS = range(12)
NG_X, NG_Y, NG_Z, U, V, PRIM_ID, GEOM_ID, INST_ID, INST_PRIM_ID = range(12, 21)
RAYHIT_FLOATS = 24            # 96 B
PACKET = 16
PACKET_FLOATS = 21 * PACKET   # RTCRayHit16: 21 fields x 16 lanes = 1344 B (Embree writes nothing beyond)
# Embree 4 ABI values (rtcore_common.h; the binding's RTC_INVALID_GEOMETRY_ID and
# RTC_FORMAT_FLOAT3X4_ROW_MAJOR, checked equal by tests/renderer/test_embree.py)
INVALID = 0xFFFFFFFF
_ALL_MASK = 0xFFFFFFFF
_XFM_ROW_MAJOR = 0x9134

# bare tracing loops: rays per work item, and the prime stride that scatters work items over
# threads (numba hands each thread a contiguous block of a prange; images are not uniform)
CHUNK = 256
_SCATTER = 7919


# ----------------------------------------------------------------------------- single rays
@numba.njit(**INLINE_JIT)
def new_ray_buffer():
    """A 96-B RTCRayHit scratch record: (float32[24], uint32[24]) views of the same memory.
    numba allocates arrays 32-B aligned (Embree needs 16).  Allocate once per thread/work item."""
    buf = np.empty(RAYHIT_FLOATS, np.float32)
    return buf, buf.view(np.uint32)


@numba.njit(**INLINE_JIT)
def _set_ray(f, u, ox, oy, oz, dx, dy, dz, tnear, tfar, time):
    f[ORG_X] = ox
    f[ORG_Y] = oy
    f[ORG_Z] = oz
    f[TNEAR] = tnear
    f[DIR_X] = dx
    f[DIR_Y] = dy
    f[DIR_Z] = dz
    f[TIME] = time
    f[TFAR] = tfar
    u[MASK] = _ALL_MASK
    u[RAY_ID] = 0
    u[FLAGS] = 0


@numba.njit(**INLINE_JIT)
def intersect1(scene, f, u, ox, oy, oz, dx, dy, dz, tnear, tfar, time):
    """Closest hit of one ray; True if something was hit (then f[TFAR] = t and the hit fields are
    set).  scene: ``Scene.handle``; f, u: ``new_ray_buffer()``; time in [0, 1] (shutter)."""
    _set_ray(f, u, ox, oy, oz, dx, dy, dz, tnear, tfar, time)
    u[GEOM_ID] = INVALID
    u[INST_ID] = INVALID
    u[INST_PRIM_ID] = INVALID
    rtcIntersect1(scene, f.ctypes.data, 0)
    return u[GEOM_ID] != INVALID


@numba.njit(**INLINE_JIT)
def occluded1(scene, f, u, ox, oy, oz, dx, dy, dz, tnear, tfar, time):
    """True if anything lies on the ray within [tnear, tfar] (any hit; uses the first 48 B of
    the buffer: Embree sets tfar to -inf when occluded)."""
    _set_ray(f, u, ox, oy, oz, dx, dy, dz, tnear, tfar, time)
    rtcOccluded1(scene, f.ctypes.data, 0)
    return f[TFAR] == -np.inf


@numba.njit(**INLINE_JIT)
def instance_transform(scene, inst_id, inst_prim_id, time, out):
    """Write the local-to-world matrix of instance (inst_id, inst_prim_id) at ray time ``time``
    into ``out`` (float32[12], row-major 3x4 ``M[:3, :4]``), interpolated exactly as Embree traced it
    (lerped matrices or slerped quaternion decompositions)."""
    geometry = rtcGetGeometry(scene, inst_id)
    rtcGetGeometryTransformEx(geometry, inst_prim_id, np.float32(time), _XFM_ROW_MAJOR, out.ctypes.data)


# ----------------------------------------------------------------------------- packets of 16
@numba.njit(**INLINE_JIT)
def new_packet16():
    """(valid int32[16], float32[336], uint32[336]) for RTCRayHit16 packets, 64-B aligned.
    One over-allocated array: numba only guarantees 32-B alignment."""
    raw = np.empty(PACKET_FLOATS + PACKET + 16, np.float32)
    start = ((64 - raw.ctypes.data % 64) % 64) // 4
    f = raw[start:start + PACKET_FLOATS]
    valid = raw[start + PACKET_FLOATS:start + PACKET_FLOATS + PACKET].view(np.int32)   # 1344 B: 64-B aligned
    valid[:] = 0
    return valid, f, f.view(np.uint32)


@numba.njit(**INLINE_JIT)
def set_ray16(valid, f, u, lane, ox, oy, oz, dx, dy, dz, tnear, tfar, time):
    """Fill lane ``lane`` of a packet with a ray (and mark it valid / reset its hit ids)."""
    f[ORG_X * PACKET + lane] = ox
    f[ORG_Y * PACKET + lane] = oy
    f[ORG_Z * PACKET + lane] = oz
    f[TNEAR * PACKET + lane] = tnear
    f[DIR_X * PACKET + lane] = dx
    f[DIR_Y * PACKET + lane] = dy
    f[DIR_Z * PACKET + lane] = dz
    f[TIME * PACKET + lane] = time
    f[TFAR * PACKET + lane] = tfar
    u[MASK * PACKET + lane] = _ALL_MASK
    u[RAY_ID * PACKET + lane] = 0
    u[FLAGS * PACKET + lane] = 0
    u[GEOM_ID * PACKET + lane] = INVALID
    u[INST_ID * PACKET + lane] = INVALID
    u[INST_PRIM_ID * PACKET + lane] = INVALID
    valid[lane] = -1


@numba.njit(**INLINE_JIT)
def intersect16(scene, valid, f):
    """Closest hits of the valid lanes; lane j hit iff u[GEOM_ID * 16 + j] != INVALID."""
    rtcIntersect16(valid.ctypes.data, scene, f.ctypes.data, 0)


@numba.njit(**INLINE_JIT)
def occluded16(scene, valid, f):
    """Occlusion of the valid lanes; lane j occluded iff f[TFAR * 16 + j] == -inf."""
    rtcOccluded16(valid.ctypes.data, scene, f.ctypes.data, 0)


# ----------------------------------------------------------------------------- bare tracing loops
@numba.njit(**INLINE_JIT)
def _work_item(i, n_items):
    """Visit work items in the order (i * 7919) % n (a permutation unless 7919 divides n)."""
    stride = _SCATTER if n_items % _SCATTER != 0 else 1
    return (i * stride) % n_items


@numba.njit(parallel=True, nogil=True, cache=True)
def trace_rays(scene, origins, dirs, tnear, tfar, time, out_t, out_ids):
    """Closest hit for n rays with rtcIntersect1.  origins, dirs: float32 (n, 3); tnear, tfar,
    time: float32 (n,).  out_t float32 (n,) = hit t (tfar on a miss); out_ids uint32 (n, 4) =
    primID, geomID, instID, instPrimID (all INVALID on a miss)."""
    n = origins.shape[0]
    n_items = (n + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        item = _work_item(i, n_items)
        f, u = new_ray_buffer()
        for r in range(item * CHUNK, min(n, (item + 1) * CHUNK)):
            hit = intersect1(scene, f, u, origins[r, 0], origins[r, 1], origins[r, 2],
                             dirs[r, 0], dirs[r, 1], dirs[r, 2], tnear[r], tfar[r], time[r])
            out_t[r] = f[TFAR]
            out_ids[r, 0] = u[PRIM_ID] if hit else INVALID
            out_ids[r, 1] = u[GEOM_ID]
            out_ids[r, 2] = u[INST_ID]
            out_ids[r, 3] = u[INST_PRIM_ID]


@numba.njit(parallel=True, nogil=True, cache=True)
def occlude_rays(scene, origins, dirs, tnear, tfar, time, out_occluded):
    """Occlusion for n rays with rtcOccluded1 (arguments as ``trace_rays``); out_occluded bool (n,)."""
    n = origins.shape[0]
    n_items = (n + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        item = _work_item(i, n_items)
        f, u = new_ray_buffer()
        for r in range(item * CHUNK, min(n, (item + 1) * CHUNK)):
            out_occluded[r] = occluded1(scene, f, u, origins[r, 0], origins[r, 1], origins[r, 2],
                                        dirs[r, 0], dirs[r, 1], dirs[r, 2], tnear[r], tfar[r], time[r])


@numba.njit(**INLINE_JIT)
def _load_packet(valid, f, u, first, end, origins, dirs, tnear, tfar, time):
    """Fill a 16-ray packet with rays [first, min(first + 16, end)); returns the number of lanes."""
    lanes = min(PACKET, end - first)
    valid[:] = 0
    for j in range(lanes):
        r = first + j
        set_ray16(valid, f, u, j, origins[r, 0], origins[r, 1], origins[r, 2],
                  dirs[r, 0], dirs[r, 1], dirs[r, 2], tnear[r], tfar[r], time[r])
    return lanes


@numba.njit(parallel=True, nogil=True, cache=True)
def trace_rays16(scene, origins, dirs, tnear, tfar, time, out_t, out_ids):
    """``trace_rays`` with rtcIntersect16 on consecutive groups of 16 rays (order rays coherently,
    e.g. 4x4 pixel tiles, for packets to pay off)."""
    n = origins.shape[0]
    n_items = (n + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        item = _work_item(i, n_items)
        valid, f, u = new_packet16()
        end = min(n, (item + 1) * CHUNK)
        for first in range(item * CHUNK, end, PACKET):
            lanes = _load_packet(valid, f, u, first, end, origins, dirs, tnear, tfar, time)
            intersect16(scene, valid, f)
            for j in range(lanes):
                r = first + j
                out_t[r] = f[TFAR * PACKET + j]
                geom = u[GEOM_ID * PACKET + j]
                out_ids[r, 0] = u[PRIM_ID * PACKET + j] if geom != INVALID else INVALID
                out_ids[r, 1] = geom
                out_ids[r, 2] = u[INST_ID * PACKET + j]
                out_ids[r, 3] = u[INST_PRIM_ID * PACKET + j]


@numba.njit(parallel=True, nogil=True, cache=True)
def occlude_rays16(scene, origins, dirs, tnear, tfar, time, out_occluded):
    """``occlude_rays`` with rtcOccluded16 on consecutive groups of 16 rays."""
    n = origins.shape[0]
    n_items = (n + CHUNK - 1) // CHUNK
    for i in numba.prange(n_items):
        item = _work_item(i, n_items)
        valid, f, u = new_packet16()
        end = min(n, (item + 1) * CHUNK)
        for first in range(item * CHUNK, end, PACKET):
            lanes = _load_packet(valid, f, u, first, end, origins, dirs, tnear, tfar, time)
            occluded16(scene, valid, f)
            for j in range(lanes):
                out_occluded[first + j] = f[TFAR * PACKET + j] == -np.inf
