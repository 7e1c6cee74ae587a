"""ctypes binding to Embree 4 and the two-level scene build.

The library is the ``libembree4`` bundled in the embreex wheel (``embreex.libs/``); embreex's own
Python API is not used.  Facts about this build (enum values, struct layouts, instance arrays,
motion blur) are documented and verified in ``/work/shared/embree.md``.

Structure of a renderer scene
-----------------------------
* one **prototype scene** (one BVH) per container: ``Device.prototype_scene(meshes, spheres)``;
  each mesh / sphere set is one geometry, geomIDs in list order, meshes first (then round linear
  curves: the path integrator's cylinder lights, `light_selection.shape_geometry`; then a geometry per
  curves gprim, `CurveGeometry`).
* one **top scene** of instances: ``Device.top_scene(prototypes, groups)``; each
  ``InstanceGroup`` becomes one ``RTC_GEOMETRY_TYPE_INSTANCE_ARRAY`` whose geomID is the group's
  position in ``groups``.  A hit therefore reads: ``instID`` = group, ``instPrimID`` = row of the
  group, ``geomID``/``primID`` = geometry / primitive inside the prototype scene.  A top scene may
  also hold geometry of its own (``direct``: placed once, no instance around it); a hit on that
  reads ``instID`` = RTC_INVALID_GEOMETRY_ID and ``geomID`` = its id in the top scene.
  Embree in this build supports one instance level only: nesting must be flattened by the caller.

Ownership: every ``Device``/``Scene`` object owns one Embree reference and releases it in
``close()`` (also via ``with`` and, as a safety net, ``__del__``).  Embree reference-counts
internally (a scene retains its device, an instance array retains its prototype scenes), so
closing objects in any order is safe.  Geometry data is copied into Embree-owned buffers
(``rtcSetNewGeometryBuffer``): no numpy array has to outlive the call, and steady-state memory is
the same as with shared buffers (measured, see ``benchmarks/RESULTS.md``).  The one exception is user
geometry (the path integrator's spheres and cylinders, ``user_geometry.py``), whose rows Embree reads through a raw
pointer: a ``Scene`` keeps them (``Scene.keep``), with those of every prototype it instances.
"""
from __future__ import annotations

import ctypes
import glob
import os
from dataclasses import dataclass

import embreex
import numpy as np

from .. import description as D

__all__ = [
    "Device", "Scene", "InstanceGroup", "CurveGeometry", "EmbreeError", "decompose_affine", "LIB", "LIBRARY_PATH",
]


def _find_library() -> str:
    libs = os.path.join(os.path.dirname(os.path.dirname(embreex.__file__)), "embreex.libs")
    found = glob.glob(os.path.join(libs, "libembree4-*.so.4"))
    if not found:
        raise ImportError(f"libembree4 not found in {libs} (is the embreex wheel installed?)")
    return found[0]


LIBRARY_PATH = _find_library()
LIB = ctypes.CDLL(LIBRARY_PATH)

# ----------------------------------------------------------------------------- enums (embree4 v4.4.0)
RTC_ERROR_NONE = 0
RTC_ERROR_UNKNOWN = 1
RTC_ERROR_INVALID_ARGUMENT = 2
RTC_ERROR_INVALID_OPERATION = 3
RTC_ERROR_OUT_OF_MEMORY = 4
RTC_ERROR_UNSUPPORTED_CPU = 5
RTC_ERROR_CANCELLED = 6
_ERROR_NAMES = {
    RTC_ERROR_UNKNOWN: "RTC_ERROR_UNKNOWN", RTC_ERROR_INVALID_ARGUMENT: "RTC_ERROR_INVALID_ARGUMENT",
    RTC_ERROR_INVALID_OPERATION: "RTC_ERROR_INVALID_OPERATION",
    RTC_ERROR_OUT_OF_MEMORY: "RTC_ERROR_OUT_OF_MEMORY",
    RTC_ERROR_UNSUPPORTED_CPU: "RTC_ERROR_UNSUPPORTED_CPU", RTC_ERROR_CANCELLED: "RTC_ERROR_CANCELLED",
}

RTC_GEOMETRY_TYPE_TRIANGLE = 0
RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE = 16
RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE = 24
RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE = 26
RTC_GEOMETRY_TYPE_SPHERE_POINT = 50
RTC_GEOMETRY_TYPE_USER = 120
RTC_GEOMETRY_TYPE_INSTANCE_ARRAY = 122

RTC_BUFFER_TYPE_INDEX = 0
RTC_BUFFER_TYPE_VERTEX = 1
RTC_BUFFER_TYPE_NORMAL = 3
RTC_BUFFER_TYPE_TRANSFORM = 23
RTC_BUFFER_TYPE_FLAGS = 32

RTC_FORMAT_UCHAR = 0x1001
RTC_FORMAT_UINT = 0x5001
RTC_FORMAT_UINT3 = 0x5003
RTC_FORMAT_FLOAT3 = 0x9003
RTC_FORMAT_FLOAT4 = 0x9004
RTC_FORMAT_FLOAT3X4_ROW_MAJOR = 0x9134
RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR = 0x9234
RTC_FORMAT_QUATERNION_DECOMPOSITION = 0xB001

RTC_SCENE_FLAG_NONE = 0
RTC_SCENE_FLAG_ROBUST = 4
# rtcGetDeviceProperty: 1 where rtcIntersect16 / rtcOccluded16 (8: rtcIntersect8 / rtcOccluded8) run Embree's
# own 16-wide (8-wide) kernels: 16 on AVX-512 CPUs, 8 on AVX2 ones (where 16 is 0), VERIFIED on both kinds
RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED = 33
RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED = 34

RTC_INVALID_GEOMETRY_ID = 0xFFFFFFFF

# ----------------------------------------------------------------------------- functions
_vp, _u32, _i32, _f32, _sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_float, ctypes.c_size_t
_ERROR_FUNCTION = ctypes.CFUNCTYPE(None, _vp, _i32, ctypes.c_char_p)   # (userPtr, RTCError, const char*)


def _declare(name, restype, argtypes):
    fn = getattr(LIB, name)
    fn.restype, fn.argtypes = restype, argtypes
    return fn


rtcNewDevice = _declare("rtcNewDevice", _vp, [ctypes.c_char_p])
rtcReleaseDevice = _declare("rtcReleaseDevice", None, [_vp])
rtcGetDeviceError = _declare("rtcGetDeviceError", _i32, [_vp])
rtcGetDeviceProperty = _declare("rtcGetDeviceProperty", ctypes.c_ssize_t, [_vp, _i32])
rtcSetDeviceErrorFunction = _declare("rtcSetDeviceErrorFunction", None, [_vp, _ERROR_FUNCTION, _vp])
rtcNewScene = _declare("rtcNewScene", _vp, [_vp])
rtcReleaseScene = _declare("rtcReleaseScene", None, [_vp])
rtcSetSceneFlags = _declare("rtcSetSceneFlags", None, [_vp, _i32])
rtcCommitScene = _declare("rtcCommitScene", None, [_vp])
rtcGetSceneBounds = _declare("rtcGetSceneBounds", None, [_vp, _vp])
rtcNewGeometry = _declare("rtcNewGeometry", _vp, [_vp, _i32])
rtcReleaseGeometry = _declare("rtcReleaseGeometry", None, [_vp])
rtcCommitGeometry = _declare("rtcCommitGeometry", None, [_vp])
rtcAttachGeometryByID = _declare("rtcAttachGeometryByID", None, [_vp, _vp, _u32])
rtcSetNewGeometryBuffer = _declare("rtcSetNewGeometryBuffer", _vp, [_vp, _i32, _u32, _i32, _sz, _sz])
rtcSetGeometryInstancedScenes = _declare("rtcSetGeometryInstancedScenes", None, [_vp, _vp, _sz])
rtcSetGeometryTimeStepCount = _declare("rtcSetGeometryTimeStepCount", None, [_vp, _u32])
rtcGetGeometry = _declare("rtcGetGeometry", _vp, [_vp, _u32])
rtcSetGeometryMask = _declare("rtcSetGeometryMask", None, [_vp, _u32])
rtcSetGeometryUserPrimitiveCount = _declare("rtcSetGeometryUserPrimitiveCount", None, [_vp, _u32])
rtcSetGeometryUserData = _declare("rtcSetGeometryUserData", None, [_vp, _vp])
rtcSetGeometryBoundsFunction = _declare("rtcSetGeometryBoundsFunction", None, [_vp, _vp, _vp])
rtcSetGeometryIntersectFunction = _declare("rtcSetGeometryIntersectFunction", None, [_vp, _vp])
rtcSetGeometryOccludedFunction = _declare("rtcSetGeometryOccludedFunction", None, [_vp, _vp])
rtcGetGeometryTransformEx = _declare("rtcGetGeometryTransformEx", None, [_vp, _u32, _f32, _i32, _vp])


def _register_kernel_symbols() -> None:
    """Give the numba kernels the Embree entry points they declare by name (`kernel/trace.py`:
    SYMBOL_PREFIX + name): LLVM resolves those names when it compiles or links a (cached) kernel,
    so this runs at import, before any kernel can be called."""
    import llvmlite.binding as llvm

    from ..kernel.trace import EXTERNAL_FUNCTIONS, SYMBOL_PREFIX
    for name in EXTERNAL_FUNCTIONS:
        llvm.add_symbol(SYMBOL_PREFIX + name, ctypes.cast(getattr(LIB, name), ctypes.c_void_p).value)


_register_kernel_symbols()


class EmbreeError(RuntimeError):
    """An error reported by Embree (through the device error callback or rtcGetDeviceError)."""


# ----------------------------------------------------------------------------- data
@dataclass
class CurveGeometry:
    """A curves gprim as Embree takes it: `vertices` float32 (n, 4), control points (x, y, z, radius);
    `segments` uint32 (k,), each segment's first vertex.  linear: round linear curves (cones with round joints;
    `flags` uint8 (k,): Embree's RTC_CURVE_FLAG_NEIGHBOR_LEFT (1) / _RIGHT (2), the segments before and after
    it share its ends); else round Bezier curves (four vertices a segment), or with `normals` float32 (n, 3) (a
    vertex's) normal-oriented Bezier curves: flat ribbons facing them."""
    linear: bool
    vertices: np.ndarray
    segments: np.ndarray
    flags: np.ndarray | None = None
    normals: np.ndarray | None = None

    def segment_rows(self) -> np.ndarray:
        """float32 (k, 4, 4): each segment's control points, as Embree reads them (`description.segment_rows`)."""
        return D.segment_rows(self.vertices, self.segments, self.linear)


@dataclass
class InstanceGroup:
    """Placements of prototypes that become ONE instance-array geometry (e.g. a PointInstancer).

    proto_index: uint32 (N,)        index into the ``prototypes`` list of ``Device.top_scene``
    transforms:  float32 (K, N, 3, 4) local-to-world ``M[:3, :4]`` (column vectors, row-major
                 storage) at K motion time steps spread evenly over ray time [0, 1]; K = 1 = static.
    """
    proto_index: np.ndarray
    transforms: np.ndarray


def _quaternion_from_rotation(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) as (r, i, j, k) of proper rotation matrices (..., 3, 3) (Shepperd:
    pick the largest of 4|r|^2, 4|i|^2, ... to divide by, for accuracy everywhere)."""
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    d21, d02, d10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
    four = np.stack([1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1)
    s = 2 * np.sqrt(np.maximum(four, 1e-300))          # s = 4 |q_c| for each candidate c
    candidates = np.stack([
        np.stack([s[..., 0] / 4, d21 / s[..., 0], d02 / s[..., 0], d10 / s[..., 0]], -1),
        np.stack([d21 / s[..., 1], s[..., 1] / 4, s01 / s[..., 1], s02 / s[..., 1]], -1),
        np.stack([d02 / s[..., 2], s01 / s[..., 2], s[..., 2] / 4, s12 / s[..., 2]], -1),
        np.stack([d10 / s[..., 3], s02 / s[..., 3], s12 / s[..., 3], s[..., 3] / 4], -1),
    ], -2)
    best = np.argmax(four, -1)[..., None, None]
    q = np.take_along_axis(candidates, best, -2)[..., 0, :]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def decompose_affine(M: np.ndarray) -> np.ndarray:
    """Decompose affine maps (..., 3, 4) or (..., 4, 4) (column vectors) into
    ``RTCQuaternionDecomposition`` records (..., 16) float64, in Embree's field order::

        0 scale_x  1 scale_y  2 scale_z  3 skew_xy  4 skew_xz  5 skew_yz  6 shift_x  7 shift_y
        8 shift_z  9 quaternion_r  10 quaternion_i  11 quaternion_j  12 quaternion_k
        13 translation_x  14 translation_y  15 translation_z

    such that ``M = T(translation) . R(quaternion) . [[sx, kxy, kxz, shx], [0, sy, kyz, shy],
    [0, 0, sz, shz]]`` (verified against rtcGetGeometryTransform).  The 3x3 part is split by a
    QR decomposition L = R U with R a proper rotation; U's diagonal is made positive except that a
    mirroring map (det < 0) gets a negative ``scale_z``.  The whole translation goes into T
    (shift = 0), so Embree's interpolation rotates about the prototype's origin while its origin
    moves linearly.  Rotations between consecutive motion steps must stay below 180 degrees
    (slerp takes the short way).
    """
    M = np.asarray(M, np.float64)[..., :3, :4]
    Q, U = np.linalg.qr(M[..., :3, :3])
    sign = np.where(np.diagonal(U, axis1=-2, axis2=-1) < 0, -1.0, 1.0)
    Q = Q * sign[..., None, :]                         # Q diag(sign) . diag(sign) U = L
    U = U * sign[..., :, None]
    mirrored = np.linalg.det(Q) < 0                    # only if det(L) < 0: move the flip into U
    Q[..., :, 2] = np.where(mirrored[..., None], -Q[..., :, 2], Q[..., :, 2])
    U[..., 2, :] = np.where(mirrored[..., None], -U[..., 2, :], U[..., 2, :])
    out = np.zeros(M.shape[:-2] + (16,))
    out[..., 0:3] = np.diagonal(U, axis1=-2, axis2=-1)
    out[..., 3], out[..., 4], out[..., 5] = U[..., 0, 1], U[..., 0, 2], U[..., 1, 2]
    out[..., 9:13] = _quaternion_from_rotation(Q)
    out[..., 13:16] = M[..., :3, 3]
    return out


_ROTATION_EPS = 1e-5   # radians; below this, matrix lerp and slerp differ by < 1e-10 relative


def _rotates(decomposition: np.ndarray) -> bool:
    """True if the rotation part of (K, N, 16) time steps changes over the shutter."""
    q = decomposition[..., 9:13]
    cos_half = np.abs(np.sum(q[1:] * q[:1], axis=-1))
    return bool(np.any(2 * np.arccos(np.minimum(cos_half, 1.0)) > _ROTATION_EPS))


# ----------------------------------------------------------------------------- device and scenes
class Device:
    """An Embree device (``RTCDevice``), a context manager.

    ``threads``: number of build/render threads Embree may use (config ``threads=N``), None =
    all.  ``config``: further Embree config options, e.g. ``"verbose=1,max_isa=avx2"``.
    Errors are collected by an error callback and raised as ``EmbreeError`` by ``check()``.
    """

    def __init__(self, threads: int | None = None, config: str = ""):
        options = ([f"threads={int(threads)}"] if threads is not None else []) + ([config] if config else [])
        self._handle = rtcNewDevice(",".join(options).encode())
        if not self._handle:
            code = rtcGetDeviceError(None)
            raise EmbreeError(f"rtcNewDevice({','.join(options)!r}) failed: {_ERROR_NAMES.get(code, code)}")
        errors: list[tuple[int, str]] = []       # closed over (not self): no reference cycle
        self._errors = errors
        self._callback = _ERROR_FUNCTION(       # must stay alive as long as the device
            lambda _user, code, message: errors.append((code, message.decode(errors="replace") if message else "")))
        rtcSetDeviceErrorFunction(self._handle, self._callback, None)

    @property
    def handle(self) -> int:
        if not self._handle:
            raise EmbreeError("device is closed")
        return self._handle

    def check(self, what: str = "embree call") -> None:
        """Raise ``EmbreeError`` if Embree reported an error since the last check (clears it)."""
        code = rtcGetDeviceError(self.handle)
        errors = self._errors[:]
        self._errors.clear()
        if not errors and code != RTC_ERROR_NONE:
            errors = [(code, "")]
        if errors:
            raise EmbreeError(f"{what}: " + "; ".join(f"{_ERROR_NAMES.get(c, c)}: {m}" for c, m in errors))

    @property
    def native_ray16(self) -> bool:
        """Whether Embree traces 16-ray packets with 16-wide kernels on this CPU (AVX-512)."""
        return bool(rtcGetDeviceProperty(self.handle, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED))

    @property
    def native_ray8(self) -> bool:
        """Whether Embree traces 8-ray packets with 8-wide kernels on this CPU (AVX2 and AVX-512)."""
        return bool(rtcGetDeviceProperty(self.handle, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED))

    @property
    def packet_width(self) -> int:
        """How many rays of a 16-ray packet (`kernel/trace.Packet`) one Embree query takes: 16 where its
        16-wide kernels run them, else 8 where its 8-wide ones do (AVX2: there a 16-ray query is emulated,
        slower than single rays, and two 8-ray queries 1.7-2.3x faster: `benchmarks/RESULTS.md`), else 16."""
        return 8 if self.native_ray8 and not self.native_ray16 else 16

    @property
    def native_packets(self) -> bool:
        """Whether Embree runs this CPU's packets (`packet_width`) with its own kernels, not emulated."""
        return self.native_ray16 or self.native_ray8

    # -- build
    def prototype_scene(self, meshes: list[tuple[np.ndarray, np.ndarray]],
                        spheres: list[np.ndarray], robust: bool = True, curves: tuple = (),
                        masks: list[int] | None = None, first_id: int = 0, user_shapes: bool = False,
                        curve_gprims: list = ()) -> Scene:
        """One Embree scene (one BVH) holding a container's geometry.

        meshes:  [(vertices float32 (n, 3), triangles uint32 (m, 3))] -> TRIANGLE geometries,
                 geomID 0 .. len(meshes)-1 (all geomIDs: + first_id).
        spheres: [centers_radii float32 (k, 4)] -> SPHERE_POINT geometries (x, y, z, r),
                 geomID len(meshes) + i.
        curves:  [segments float32 (k, 2, 4)] -> ROUND_LINEAR_CURVE geometries of k segments (two
                 vertices x, y, z, radius each: a capsule per segment), geomID len(meshes) + len(spheres) + i.
        robust:  RTC_SCENE_FLAG_ROBUST (watertight; no leaks through shared edges far from the origin).
        masks:   a ray mask per geometry, in geomID order (None: Embree's default).
        first_id: the geomID of the first geometry (the others follow it).
        user_shapes: the spheres and the curves' segments as user geometry (`user_geometry.py`: their ray tests
                 in float64, the rows taken in float64; a segment is then the open cylinder, without the
                 capsule's round ends) instead of SPHERE_POINT and round linear curve geometries; their hits
                 report the same fields.
        curve_gprims: [CurveGeometry] -> round Bezier, round linear or normal-oriented Bezier curve geometries
                 (UsdGeom.BasisCurves), geomIDs after the curves'.
        Hits report Ng in this (object) space, unnormalised: triangles cross(v1-v0, v2-v0),
        spheres p - c; u, v are the barycentric weights of v1, v2.
        """
        keep = []

        def build(scene):
            keep.extend(self._attach_shapes(scene, first_id, meshes, spheres, curves, mask=masks,
                                            user_shapes=user_shapes, curve_gprims=curve_gprims))
            return ()
        return self._build_scene(build, robust, "prototype scene", keep)

    def _attach_shapes(self, scene, first_id: int, meshes, spheres, curves=(), mask: int | list | None = None,
                       user_shapes: bool = False, curve_gprims=()) -> list:
        """Attach meshes, spheres and curves (as `prototype_scene` describes them) to `scene` as geomIDs
        first_id, first_id + 1, ... in that order; mask: the ray mask of every geometry, or a list of one
        per geometry in that order, or None (Embree's default).  -> the arrays Embree reads that must
        outlive the scene (the user geometry's rows)."""
        n = len(meshes) + len(spheres) + len(curves) + len(curve_gprims)
        masks = list(mask) if isinstance(mask, (list, tuple)) else [mask] * n
        if len(masks) != n:
            raise ValueError(f"{len(masks)} masks for {n} geometries")
        for k, (vertices, triangles) in enumerate(meshes):
            vertices = _as_rows(vertices, 3, "mesh vertices")
            triangles = _as_rows(triangles, 3, "mesh triangles")
            if triangles.size and (triangles.min() < 0 or triangles.max() >= len(vertices)):
                raise ValueError(f"mesh {k}: triangle index outside [0, {len(vertices)})")
            self._attach(scene, first_id + k, RTC_GEOMETRY_TYPE_TRIANGLE, [
                (RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, np.float32, vertices),
                (RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, np.uint32, triangles)], mask=masks[k])
        first_id += len(meshes)
        keep = []
        for i, centers_radii in enumerate(spheres):
            if user_shapes:
                keep.append(self._attach_user(scene, first_id + i, "spheres",
                                              _as_rows(centers_radii, 4, "sphere centers_radii"), masks[len(meshes) + i]))
                continue
            self._attach(scene, first_id + i, RTC_GEOMETRY_TYPE_SPHERE_POINT, [
                (RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, np.float32,
                 _as_rows(centers_radii, 4, "sphere centers_radii"))], mask=masks[len(meshes) + i])
        first_id += len(spheres)
        for i, segments in enumerate(curves):
            if user_shapes:
                keep.append(self._attach_user(scene, first_id + i, "cylinders", segments,
                                              masks[len(meshes) + len(spheres) + i]))
                continue
            segments = np.asarray(segments, np.float32).reshape(-1, 2, 4)
            self._attach(scene, first_id + i, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE, [
                (RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, np.float32, segments.reshape(-1, 4)),
                (RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, np.uint32,
                 2 * np.arange(len(segments), dtype=np.uint32))], mask=masks[len(meshes) + len(spheres) + i])
        for i, x in enumerate(curve_gprims):
            vertices = _as_rows(x.vertices, 4, "curve vertices")
            buffers = [(RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, np.float32, vertices),
                       (RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, np.uint32, np.asarray(x.segments, np.uint32))]
            if x.flags is not None:
                buffers.append((RTC_BUFFER_TYPE_FLAGS, 0, RTC_FORMAT_UCHAR, np.uint8, np.asarray(x.flags, np.uint8)))
            kind = RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE if x.linear else RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE
            if x.normals is not None:
                normals = _as_rows(x.normals, 3, "curve normals")
                buffers.append((RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, np.float32, normals))
                kind = RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE
            self._attach(scene, first_id + len(curves) + i, kind, buffers, mask=masks[n - len(curve_gprims) + i])
        return keep

    def top_scene(self, prototypes: list[Scene], groups: list[InstanceGroup], robust: bool = True,
                  quaternion_motion: bool | None = None, masks: list[int] | None = None,
                  direct: list[tuple] = (), user_shapes: bool = False) -> Scene:
        """The top-level scene: one INSTANCE_ARRAY geometry per group, geomID = group index.

        Every group instances the whole ``prototypes`` list through an index buffer
        (``proto_index``); transforms go to one TRANSFORM buffer per time step.
        quaternion_motion: store moving groups' time steps as RTCQuaternionDecomposition so that
        rotations are slerped (Embree lerps matrices element-wise, which shrinks a rotating
        object mid-shutter).  None (default) = only for groups whose rotation changes over the
        shutter; True/False = for all / no moving groups.  Static groups always use plain matrices.
        masks: a ray mask per group (a ray meets a group iff ray mask & group mask != 0); None: Embree's
        default, every ray meets every group.
        direct: [(first geomID, ray mask (or a list of one per geometry) or None, meshes, spheres, curves)]:
        geometry as `prototype_scene`
        takes it, already placed (camera-relative world space), attached to the top level itself as
        geomIDs first, first + 1, ... (meshes, then spheres, then curves): geometry placed once needs no
        instance around it.
        user_shapes: `direct`'s spheres and curves as user geometry (see `prototype_scene`).
        """
        keep = [p.keep for p in prototypes]          # what the instanced prototypes' user geometry reads
        handles = (ctypes.c_void_p * max(len(prototypes), 1))(*[p.handle for p in prototypes])

        def build(scene):
            for geom_id, group in enumerate(groups):
                proto_index = np.asarray(group.proto_index).reshape(-1)
                transforms = np.asarray(group.transforms)
                if transforms.ndim != 4 or transforms.shape[1:] != (len(proto_index), 3, 4):
                    raise ValueError(f"group {geom_id}: transforms must be (K, {len(proto_index)}, 3, 4), "
                                     f"got {transforms.shape}")
                if proto_index.size and (proto_index.min() < 0 or proto_index.max() >= len(prototypes)):
                    raise ValueError(f"group {geom_id}: proto_index outside [0, {len(prototypes)})")
                steps = transforms.shape[0]
                decomposition = decompose_affine(transforms) if steps > 1 and quaternion_motion is not False else None
                if decomposition is not None and (quaternion_motion or _rotates(decomposition)):
                    fmt, per_step = RTC_FORMAT_QUATERNION_DECOMPOSITION, decomposition
                else:   # column-major 3x4: Embree's native AffineSpace layout (columns Lx, Ly, Lz, T)
                    fmt, per_step = RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, transforms.transpose(0, 1, 3, 2)
                instanced = (handles, len(prototypes))
                if len(proto_index) == 1:
                    # an instance array of one instance ignores its index buffer (Embree 4.4: it instances
                    # the first scene of the list), so it gets its own list of the one scene it instances
                    instanced = ((ctypes.c_void_p * 1)(prototypes[int(proto_index[0])].handle), 1)
                    proto_index = np.zeros(1, np.uint32)
                buffers = [(RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, np.uint32, proto_index)]
                buffers += [(RTC_BUFFER_TYPE_TRANSFORM, k, fmt, np.float32, per_step[k]) for k in range(steps)]
                self._attach(scene, geom_id, RTC_GEOMETRY_TYPE_INSTANCE_ARRAY, buffers,
                             instanced=instanced, time_steps=steps,
                             mask=None if masks is None else masks[geom_id])
            for first, mask, meshes, spheres, curves in direct:
                keep.extend(self._attach_shapes(scene, first, meshes, spheres, curves, mask=mask,
                                                user_shapes=user_shapes))
            return tuple(range(len(groups)))
        return self._build_scene(build, robust, "top scene", keep)

    def _build_scene(self, build, robust: bool, what: str, keep: list) -> Scene:
        handle = rtcNewScene(self.handle)
        self.check(f"{what}: rtcNewScene")
        scene = Scene(self, handle)
        scene.keep = keep
        try:
            rtcSetSceneFlags(handle, RTC_SCENE_FLAG_ROBUST if robust else RTC_SCENE_FLAG_NONE)
            scene.group_geom_ids = build(handle)
            rtcCommitScene(handle)
            self.check(f"{what}: rtcCommitScene")
        except BaseException:
            scene.close()
            raise
        return scene

    def _attach(self, scene, geom_id: int, geometry_type: int, buffers, instanced=None, time_steps: int = 1,
                mask: int | None = None):
        """Create a geometry, fill its buffers, commit it and attach it to ``scene`` as ``geom_id``.

        buffers: [(type, slot, format, item dtype, array (count, ...))]; each array is converted
        and copied straight into the Embree-owned buffer (any strides: no temporary copies)."""
        geometry = rtcNewGeometry(self.handle, geometry_type)
        self.check(f"rtcNewGeometry(type {geometry_type})")
        try:
            if instanced is not None:
                rtcSetGeometryInstancedScenes(geometry, ctypes.cast(instanced[0], _vp), instanced[1])
            if time_steps != 1:     # must precede the per-time-step buffers
                rtcSetGeometryTimeStepCount(geometry, time_steps)
            if mask is not None:
                rtcSetGeometryMask(geometry, mask)
            self.check(f"geometry {geom_id}: setup")
            for buffer_type, slot, fmt, dtype, data in buffers:
                item_bytes = int(np.prod(data.shape[1:], dtype=np.int64)) * np.dtype(dtype).itemsize
                pointer = rtcSetNewGeometryBuffer(geometry, buffer_type, slot, fmt, item_bytes, len(data))
                self.check(f"geometry {geom_id}: rtcSetNewGeometryBuffer(type {buffer_type}, slot {slot})")
                if data.size:
                    raw = (ctypes.c_uint8 * (item_bytes * len(data))).from_address(pointer)
                    np.frombuffer(raw, dtype).reshape(data.shape)[...] = data
            rtcCommitGeometry(geometry)
            rtcAttachGeometryByID(scene, geometry, geom_id)
            self.check(f"geometry {geom_id}: commit/attach")
        finally:
            rtcReleaseGeometry(geometry)    # the scene holds its own reference

    def _attach_user(self, scene, geom_id: int, kind: str, data, mask: int | None) -> np.ndarray:
        """Attach `kind` ("spheres": rows x, y, z, r; "cylinders": segments (k, 2, 4)) as user geometry
        ``geom_id`` (`user_geometry.py`); -> the float64 rows its callbacks read, which must outlive every
        scene that holds it."""
        from . import user_geometry as _user           # its callbacks load only where a scene needs them
        if kind == "spheres":
            data, callbacks = _user.sphere_rows(data), _user.SPHERES
        else:
            data, callbacks = _user.cylinder_rows(data), _user.CYLINDERS
        geometry = rtcNewGeometry(self.handle, RTC_GEOMETRY_TYPE_USER)
        self.check(f"geometry {geom_id}: rtcNewGeometry(user)")
        try:
            rtcSetGeometryUserPrimitiveCount(geometry, len(data))
            rtcSetGeometryUserData(geometry, data.ctypes.data)
            rtcSetGeometryBoundsFunction(geometry, callbacks[0], None)
            rtcSetGeometryIntersectFunction(geometry, callbacks[1])
            rtcSetGeometryOccludedFunction(geometry, callbacks[2])
            if mask is not None:
                rtcSetGeometryMask(geometry, mask)
            rtcCommitGeometry(geometry)
            rtcAttachGeometryByID(scene, geometry, geom_id)
            self.check(f"geometry {geom_id}: user {kind}")
        finally:
            rtcReleaseGeometry(geometry)
        return data

    # -- lifetime
    def close(self) -> None:
        """Release this object's device reference (scenes still alive keep Embree's device alive)."""
        if getattr(self, "_handle", None):
            rtcSetDeviceErrorFunction(self._handle, _ERROR_FUNCTION(), None)   # no calls into a dead callback
            rtcReleaseDevice(self._handle)
            self._handle = None

    def __enter__(self) -> Device:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        self.close()


class Scene:
    """A committed Embree scene (``RTCScene``), owned by this object; a context manager.

    handle:         the RTCScene address, to pass to the numba kernels of ``rtc.renderer.kernel.trace``.
    group_geom_ids: top scene: the geomID of each ``InstanceGroup`` (== its index in ``groups``),
                    so a hit's ``instID`` selects the group and ``instPrimID`` the row in it;
                    () for a prototype scene (whose geomIDs are its meshes, then sphere sets).
    keep:           the host arrays Embree reads through raw pointers (user geometry's rows), its own and
                    those of the prototypes it instances: they live as long as this object, which keeps
                    them after close() too (a scene that instances this one may still be traced).
    """

    def __init__(self, device: Device, handle: int):
        self.device = device          # keeps the error callback alive while the scene exists
        self._handle = handle
        self.group_geom_ids: tuple[int, ...] = ()
        self.keep: list = []

    @property
    def handle(self) -> int:
        if not self._handle:
            raise EmbreeError("scene is closed")
        return self._handle

    def bounds(self) -> np.ndarray:
        """float32 (2, 3): [lower, upper] corner of the scene's bounding box over all time steps."""
        record = _aligned_zeros(8, np.float32, 16)   # RTCBounds: lower xyz, pad, upper xyz, pad; 16-B aligned
        rtcGetSceneBounds(self.handle, record.ctypes.data)
        return np.stack([record[0:3], record[4:7]])

    def close(self) -> None:
        if getattr(self, "_handle", None):
            rtcReleaseScene(self._handle)
            self._handle = None

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self):
        self.close()


def _as_rows(array, width: int, what: str) -> np.ndarray:
    array = np.asarray(array)
    if array.ndim != 2 or array.shape[1] != width:
        raise ValueError(f"{what} must have shape (n, {width}), got {array.shape}")
    return array


def _aligned_zeros(n: int, dtype, alignment: int) -> np.ndarray:
    raw = np.zeros(n * np.dtype(dtype).itemsize + alignment, np.uint8)
    start = -raw.ctypes.data % alignment
    return raw[start:start + n * np.dtype(dtype).itemsize].view(dtype)
