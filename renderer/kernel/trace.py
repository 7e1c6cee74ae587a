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

Packets of 16 rays (RTCRayHit16, or two RTCRayHit8; SoA, 64-byte aligned)
-------------------------------------------------------------------------
A `Packet` holds 16 lanes traced `2 ** packet.shift` at a time: where Embree runs 16-wide kernels (AVX-512)
one RTCRayHit16, field f of lane j at element ``f * 16 + j``; elsewhere two RTCRayHit8 blocks (lanes 0-7,
8-15), each traced with rtcIntersect8 / rtcOccluded8, which AVX2 CPUs run natively: there a 16-ray query is
emulated and was slower than single rays, where two 8-ray queries take camera, shadow and BSDF rays
1.7-2.3x faster than single rays (`benchmarks/RESULTS.md`).  ``slot(packet, f, j)`` is the element
index either way (same field numbers as above); ``valid`` is int32[16], -1 = active.  Packets pay off
for coherent rays (camera rays in tiles, shadow rays from coherent hits).
"""
from __future__ import annotations

import numba
import numpy as np
from numba import types

from .jit import INLINE_JIT, SHADING_INLINE_JIT
from .records import Hit, Packet

__all__ = [
    "SYMBOL_PREFIX", "EXTERNAL_FUNCTIONS",
    "rtcIntersect1", "rtcOccluded1", "rtcIntersect16", "rtcOccluded16", "rtcIntersect8", "rtcOccluded8",
    "rtcGetGeometry", "rtcGetGeometryTransformEx",
    "new_ray_buffer", "intersect1", "occluded1", "hit_of", "instance_transform",
    "alloc_packet", "new_packet", "slot", "set_packet_ray", "intersect_packet", "intersect_packet_coherent",
    "occluded_packet", "lane_hit", "RAY_LIMIT", "traceable",
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
# the same for 8 rays (RTCRayHit8 / RTCRay8: 32-B aligned, field k of lane j at k * 8 + j)
rtcIntersect8 = _external("rtcIntersect8", types.void(_p, _p, _p, _p))
rtcOccluded8 = _external("rtcOccluded8", types.void(_p, _p, _p, _p))
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


# Embree's own test of a ray it can traverse (`RayK::valid` in its kernels/common/ray.h: every coordinate of the
# origin and direction within +-FLT_LARGE, 1.844e18), which it does not apply (the wheel's Embree is built without
# EMBREE_IGNORE_INVALID_RAYS): a NaN direction crashed its traversal (a RectLight of infinite height lighting
# curves).  A ray that fails it is not traced: it meets nothing, and nothing occludes it.
RAY_LIMIT = 1.844e18


@numba.njit(**INLINE_JIT)
def traceable(o, d):
    """Whether Embree can trace the ray (o, d) (`RAY_LIMIT`; False for NaN)."""
    return (abs(o[0]) <= RAY_LIMIT and abs(o[1]) <= RAY_LIMIT and abs(o[2]) <= RAY_LIMIT
            and abs(d[0]) <= RAY_LIMIT and abs(d[1]) <= RAY_LIMIT and abs(d[2]) <= RAY_LIMIT)


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
    if traceable(ray[0], ray[1]):
        rtcIntersect1(scene, f.ctypes.data, 0)
    return u[GEOM_ID] != INVALID


@numba.njit(**INLINE_JIT)
def occluded1(scene, f, u, o, d, tnear, tfar, time):
    """True if anything lies on the ray within [tnear, tfar] (any hit; uses the first 48 B of
    the buffer: Embree sets tfar to -inf when occluded)."""
    _set_ray(f, u, o, d, tnear, tfar, time)
    if traceable(o, d):
        rtcOccluded1(scene, f.ctypes.data, 0)
    return f[TFAR] == -np.inf


@numba.njit(**INLINE_JIT)
def occluded1_surfaces(scene, f, u, o, d, tnear, tfar, time):
    """`occluded1` against surfaces only (ray mask MASK_SURFACES: light shapes do not occlude)."""
    _set_ray(f, u, o, d, tnear, tfar, time)
    u[MASK] = MASK_SURFACES
    if traceable(o, d):
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


# ----------------------------------------------------------------------------- packets of 16 rays
def _packet_views(raw, width):
    """A `Packet` of `width`-wide blocks on a float32 buffer of PACKET_FLOATS + PACKET + 16 floats: the ray
    blocks from its first 64-B boundary, then the valid mask (int32[16], 64-B aligned: 1344 B later)."""
    start = ((64 - raw.ctypes.data % 64) % 64) // 4
    f = raw[start:start + PACKET_FLOATS]
    valid = raw[start + PACKET_FLOATS:start + PACKET_FLOATS + PACKET].view(np.int32)
    return Packet(valid, f, f.view(np.uint32), 4 if width == 16 else 3)


def alloc_packet(width):
    """`new_packet` for the host (numpy): a `Packet` traced `width` (16 or 8) rays at a time."""
    packet = _packet_views(np.zeros(PACKET_FLOATS + PACKET + 16, np.float32), width)
    packet.valid[:] = 0
    return packet


@numba.njit(**INLINE_JIT)
def new_packet(width):
    """A `Packet` of 16 rays traced `width` (16 or 8) at a time: (valid int32[16], float32[336],
    uint32[336], log2 of the width), 64-B aligned (one over-allocated array: numba only guarantees 32 B)."""
    raw = np.empty(PACKET_FLOATS + PACKET + 16, np.float32)
    start = ((64 - raw.ctypes.data % 64) % 64) // 4
    f = raw[start:start + PACKET_FLOATS]
    valid = raw[start + PACKET_FLOATS:start + PACKET_FLOATS + PACKET].view(np.int32)   # 1344 B: 64-B aligned
    valid[:] = 0
    return Packet(valid, f, f.view(np.uint32), 4 if width == 16 else 3)


@numba.njit(**INLINE_JIT)
def slot(packet, field, lane):
    """Element index of `field` (ORG_X .. INST_PRIM_ID) of lane `lane` (0-15) in a packet: one
    RTCRayHit16 (field * 16 + lane), or two RTCRayHit8 blocks (lanes 0-7, 8-15) of 21 * 8 elements."""
    s = packet.shift
    return (((lane >> s) * 21 + field) << s) + (lane & ((1 << s) - 1))


@numba.njit(**INLINE_JIT)
def set_packet_ray(packet, lane, o, d, tnear, tfar, time):
    """Fill lane ``lane`` of a packet with a ray (and mark it valid / reset its hit ids)."""
    f = packet.f
    u = packet.u
    f[slot(packet, ORG_X, lane)] = o[0]
    f[slot(packet, ORG_Y, lane)] = o[1]
    f[slot(packet, ORG_Z, lane)] = o[2]
    f[slot(packet, TNEAR, lane)] = tnear
    f[slot(packet, DIR_X, lane)] = d[0]
    f[slot(packet, DIR_Y, lane)] = d[1]
    f[slot(packet, DIR_Z, lane)] = d[2]
    f[slot(packet, TIME, lane)] = time
    f[slot(packet, TFAR, lane)] = tfar
    u[slot(packet, MASK, lane)] = _ALL_MASK
    u[slot(packet, RAY_ID, lane)] = 0
    u[slot(packet, FLAGS, lane)] = 0
    u[slot(packet, GEOM_ID, lane)] = INVALID
    u[slot(packet, INST_ID, lane)] = INVALID
    u[slot(packet, INST_PRIM_ID, lane)] = INVALID
    packet.valid[lane] = -1 if traceable(o, d) else 0


@numba.njit(**INLINE_JIT)
def _upper_half(packet):
    """Whether any of lanes 8-15 is valid (an 8-wide packet's second block is traced only then)."""
    for j in range(8, PACKET):
        if packet.valid[j] != 0:
            return True
    return False


# byte offset of an 8-wide packet's second block (21 fields x 8 lanes x 4 B: 32-B aligned, as RTCRayHit8 needs)
# and of its valid mask's second half
_BLOCK8_BYTES = 21 * 8 * 4
_VALID8_BYTES = 8 * 4


@numba.njit(**INLINE_JIT)
def _intersect(scene, packet, args):
    if packet.shift == 4:
        rtcIntersect16(packet.valid.ctypes.data, scene, packet.f.ctypes.data, args)
    else:
        rtcIntersect8(packet.valid.ctypes.data, scene, packet.f.ctypes.data, args)
        if _upper_half(packet):
            rtcIntersect8(packet.valid.ctypes.data + _VALID8_BYTES, scene, packet.f.ctypes.data + _BLOCK8_BYTES, args)


@numba.njit(**INLINE_JIT)
def intersect_packet(scene, packet):
    """Closest hits of the valid lanes; lane j hit iff u[slot(packet, GEOM_ID, j)] != INVALID."""
    _intersect(scene, packet, 0)


# RTCIntersectArguments (32 B, embree.md; zero-padded): flags = RTC_RAY_QUERY_FLAG_COHERENT (1 << 16), feature
# mask = all.  Embree only reads it (a compile-time constant of the kernels).
_COHERENT_ARGS = np.array([1 << 16, 0xFFFFFFFF] + [0] * 14, np.uint32)


@numba.njit(**INLINE_JIT)
def intersect_packet_coherent(scene, packet):
    """`intersect_packet` for rays that travel together: a camera packet (its lanes are samples of the same
    few pixels).  Embree's coherent packet traversal takes them 1.4-2.8x faster than its default
    (incoherent) one, and 2x slower for incoherent rays (`bench_query_cost.py`): camera packets only."""
    _intersect(scene, packet, _COHERENT_ARGS.ctypes.data)


@numba.njit(**INLINE_JIT)
def occluded_packet(scene, packet):
    """Occlusion of the valid lanes; lane j occluded iff f[slot(packet, TFAR, j)] == -inf."""
    if packet.shift == 4:
        rtcOccluded16(packet.valid.ctypes.data, scene, packet.f.ctypes.data, 0)
    else:
        rtcOccluded8(packet.valid.ctypes.data, scene, packet.f.ctypes.data, 0)
        if _upper_half(packet):
            rtcOccluded8(packet.valid.ctypes.data + _VALID8_BYTES, scene, packet.f.ctypes.data + _BLOCK8_BYTES, 0)


@numba.njit(**INLINE_JIT)
def lane_hit(packet, lane, f, u):
    """Copy lane `lane` of a traced packet into the single-ray buffer (f, u); True on a hit."""
    cf = packet.f
    cu = packet.u
    f[TFAR] = cf[slot(packet, TFAR, lane)]
    f[U] = cf[slot(packet, U, lane)]
    f[V] = cf[slot(packet, V, lane)]
    u[PRIM_ID] = cu[slot(packet, PRIM_ID, lane)]
    u[GEOM_ID] = cu[slot(packet, GEOM_ID, lane)]
    u[INST_ID] = cu[slot(packet, INST_ID, lane)]
    u[INST_PRIM_ID] = cu[slot(packet, INST_PRIM_ID, lane)]
    return u[GEOM_ID] != INVALID


@numba.njit(**SHADING_INLINE_JIT)
def placed_hit(L, u):
    """Give a hit on geometry of the path integrator's top level itself (`host/build.path_top`: a scene
    of one level), which Embree reports without an instance, the instance ids of its placement and its
    geometry id in the prototype, as in the built top level (`shapes.hit_gprim` reads them)."""
    if u[INST_ID] == INVALID and u[GEOM_ID] != INVALID and L.direct.shape[0] > 0:
        k = np.int64(u[GEOM_ID]) - L.direct_base
        u[INST_ID] = L.direct[k, 0]
        u[INST_PRIM_ID] = L.direct[k, 1]
        u[GEOM_ID] = L.direct[k, 2]
