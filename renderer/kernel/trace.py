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
from .records import Hit, Packet

__all__ = [
    "SYMBOL_PREFIX", "EXTERNAL_FUNCTIONS",
    "rtcIntersect1", "rtcOccluded1", "rtcIntersect16", "rtcOccluded16", "rtcGetGeometry",
    "rtcGetGeometryTransformEx",
    "new_ray_buffer", "intersect1", "occluded1", "hit_of", "instance_transform",
    "new_packet16", "set_ray16", "intersect16", "intersect16_coherent", "occluded16", "lane_hit",
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
# ray masks of the path integrator's top level (host/build.py `path_top`): a ray meets a
# geometry iff ray mask & geometry mask != 0; camera and BSDF rays meet everything but the one-sided
# light shapes they cannot see the emitting side of (`light_sampling.shape_mask`), shadow rays only
# surfaces (light shapes occlude nothing)
MASK_SURFACES, MASK_LIGHT_SHAPES = 1, 2
MASK_FACING = 4                    # planar light shapes facing one way: bit MASK_FACING << group (path integrator)
MASK_ALL = _ALL_MASK              # a ray that meets every geometry (the cook integrator's scenes have no masks)
_XFM_ROW_MAJOR = 0x9134



# ----------------------------------------------------------------------------- host-side allocation
def alloc_ray_buffer():
    """`new_ray_buffer` for the host (numpy): a render thread's scratch is allocated before the pass."""
    buf = np.zeros(RAYHIT_FLOATS + 4, np.float32)
    start = ((16 - buf.ctypes.data % 16) % 16) // 4
    buf = buf[start:start + RAYHIT_FLOATS]
    return buf, buf.view(np.uint32)


def alloc_packet16():
    """`new_packet16` for the host (numpy): a `Packet` whose ray block is 64-B aligned."""
    raw = np.zeros(PACKET_FLOATS + PACKET + 16, np.float32)
    start = ((64 - raw.ctypes.data % 64) % 64) // 4
    f = raw[start:start + PACKET_FLOATS]
    valid = raw[start + PACKET_FLOATS:start + PACKET_FLOATS + PACKET].view(np.int32)
    return Packet(valid, f, f.view(np.uint32))


# ----------------------------------------------------------------------------- single rays
@numba.njit(**INLINE_JIT)
def new_ray_buffer():
    """A 96-B RTCRayHit scratch record: (float32[24], uint32[24]) views of the same memory.
    numba allocates arrays 32-B aligned (Embree needs 16).  Allocate once per thread/work item."""
    buf = np.empty(RAYHIT_FLOATS, np.float32)
    return buf, buf.view(np.uint32)


@numba.njit(**INLINE_JIT)
def _set_ray(f, u, o, d, tnear, tfar, time):
    f[ORG_X] = o[0]
    f[ORG_Y] = o[1]
    f[ORG_Z] = o[2]
    f[TNEAR] = tnear
    f[DIR_X] = d[0]
    f[DIR_Y] = d[1]
    f[DIR_Z] = d[2]
    f[TIME] = time
    f[TFAR] = tfar
    u[MASK] = _ALL_MASK
    u[RAY_ID] = 0
    u[FLAGS] = 0


@numba.njit(**INLINE_JIT)
def intersect1(scene, f, u, o, d, tnear, tfar, time):
    """Closest hit of the ray (origin o, direction d: triples); True if something was hit (then
    f[TFAR] = t and the hit fields are set, read them with `hit_of`).  scene: ``Scene.handle``;
    f, u: ``new_ray_buffer()``; time in [0, 1] (shutter)."""
    return intersect1_masked(scene, f, u, (o, d), tnear, tfar, time, _ALL_MASK)


@numba.njit(**INLINE_JIT)
def intersect1_masked(scene, f, u, ray, tnear, tfar, time, mask):
    """`intersect1` of ray = (o, d) with ray mask `mask` (a ray meets the geometries whose mask shares a
    bit with it)."""
    _set_ray(f, u, ray[0], ray[1], tnear, tfar, time)
    u[MASK] = mask
    u[GEOM_ID] = INVALID
    u[INST_ID] = INVALID
    u[INST_PRIM_ID] = INVALID
    rtcIntersect1(scene, f.ctypes.data, 0)
    return u[GEOM_ID] != INVALID


@numba.njit(**INLINE_JIT)
def occluded1(scene, f, u, o, d, tnear, tfar, time):
    """True if anything lies on the ray within [tnear, tfar] (any hit; uses the first 48 B of
    the buffer: Embree sets tfar to -inf when occluded)."""
    _set_ray(f, u, o, d, tnear, tfar, time)
    rtcOccluded1(scene, f.ctypes.data, 0)
    return f[TFAR] == -np.inf


@numba.njit(**INLINE_JIT)
def occluded1_surfaces(scene, f, u, o, d, tnear, tfar, time):
    """`occluded1` against surfaces only (ray mask MASK_SURFACES: light shapes do not occlude)."""
    _set_ray(f, u, o, d, tnear, tfar, time)
    u[MASK] = MASK_SURFACES
    rtcOccluded1(scene, f.ctypes.data, 0)
    return f[TFAR] == -np.inf


@numba.njit(**INLINE_JIT)
def intersect1_surfaces(scene, f, u, o, d, tnear, tfar, time):
    """`intersect1` against surfaces only (ray mask MASK_SURFACES: no light shapes)."""
    return intersect1_masked(scene, f, u, (o, d), tnear, tfar, time, MASK_SURFACES)


@numba.njit(**INLINE_JIT)
def hit_of(f, u):
    """The `Hit` in a ray buffer after `intersect1` returned True (or `lane_hit` copied one)."""
    return Hit(u[INST_ID], u[INST_PRIM_ID], u[GEOM_ID], u[PRIM_ID], float(f[U]), float(f[V]), float(f[TFAR]))


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
    """A `Packet`: (valid int32[16], float32[336], uint32[336]) for RTCRayHit16, 64-B aligned.
    One over-allocated array: numba only guarantees 32-B alignment."""
    raw = np.empty(PACKET_FLOATS + PACKET + 16, np.float32)
    start = ((64 - raw.ctypes.data % 64) % 64) // 4
    f = raw[start:start + PACKET_FLOATS]
    valid = raw[start + PACKET_FLOATS:start + PACKET_FLOATS + PACKET].view(np.int32)   # 1344 B: 64-B aligned
    valid[:] = 0
    return Packet(valid, f, f.view(np.uint32))


@numba.njit(**INLINE_JIT)
def set_ray16(packet, lane, o, d, tnear, tfar, time):
    """Fill lane ``lane`` of a packet with a ray (and mark it valid / reset its hit ids)."""
    f = packet.f
    u = packet.u
    f[ORG_X * PACKET + lane] = o[0]
    f[ORG_Y * PACKET + lane] = o[1]
    f[ORG_Z * PACKET + lane] = o[2]
    f[TNEAR * PACKET + lane] = tnear
    f[DIR_X * PACKET + lane] = d[0]
    f[DIR_Y * PACKET + lane] = d[1]
    f[DIR_Z * PACKET + lane] = d[2]
    f[TIME * PACKET + lane] = time
    f[TFAR * PACKET + lane] = tfar
    u[MASK * PACKET + lane] = _ALL_MASK
    u[RAY_ID * PACKET + lane] = 0
    u[FLAGS * PACKET + lane] = 0
    u[GEOM_ID * PACKET + lane] = INVALID
    u[INST_ID * PACKET + lane] = INVALID
    u[INST_PRIM_ID * PACKET + lane] = INVALID
    packet.valid[lane] = -1


@numba.njit(**INLINE_JIT)
def intersect16(scene, packet):
    """Closest hits of the valid lanes; lane j hit iff u[GEOM_ID * 16 + j] != INVALID."""
    rtcIntersect16(packet.valid.ctypes.data, scene, packet.f.ctypes.data, 0)


# RTCIntersectArguments (32 B, embree.md; zero-padded): flags = RTC_RAY_QUERY_FLAG_COHERENT (1 << 16), feature
# mask = all.  Embree only reads it (a compile-time constant of the kernels).
_COHERENT_ARGS = np.array([1 << 16, 0xFFFFFFFF] + [0] * 14, np.uint32)


@numba.njit(**INLINE_JIT)
def intersect16_coherent(scene, packet):
    """`intersect16` for rays that travel together: a camera packet (its lanes are samples of the same
    few pixels).  Embree's coherent packet traversal takes them 1.4-2.8x faster than its default
    (incoherent) one, and 2x slower for incoherent rays (`bench_query_cost.py`): camera packets only."""
    rtcIntersect16(packet.valid.ctypes.data, scene, packet.f.ctypes.data, _COHERENT_ARGS.ctypes.data)


@numba.njit(**INLINE_JIT)
def occluded16(scene, packet):
    """Occlusion of the valid lanes; lane j occluded iff f[TFAR * 16 + j] == -inf."""
    rtcOccluded16(packet.valid.ctypes.data, scene, packet.f.ctypes.data, 0)


@numba.njit(**INLINE_JIT)
def lane_hit(packet, lane, f, u):
    """Copy lane `lane` of a traced packet into the single-ray buffer (f, u); True on a hit."""
    cf = packet.f
    cu = packet.u
    f[TFAR] = cf[TFAR * PACKET + lane]
    f[U] = cf[U * PACKET + lane]
    f[V] = cf[V * PACKET + lane]
    u[PRIM_ID] = cu[PRIM_ID * PACKET + lane]
    u[GEOM_ID] = cu[GEOM_ID * PACKET + lane]
    u[INST_ID] = cu[INST_ID * PACKET + lane]
    u[INST_PRIM_ID] = cu[INST_PRIM_ID * PACKET + lane]
    return u[GEOM_ID] != INVALID
