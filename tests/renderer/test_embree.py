"""rtc.renderer.host.embree / rtc.renderer.kernel.trace against independent analytic answers."""
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest

from benchmarks import embree_loops
from rtc.renderer.kernel import trace
from rtc.renderer.host.embree import Device, EmbreeError, InstanceGroup, decompose_affine, rtcNewGeometry

INVALID = 0xFFFFFFFF
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def dev():
    with Device(threads=2) as device:
        yield device


@numba.njit
def _probe(scene, origins, dirs, time):
    """Single-ray queries through the inline helpers, as an integrator would call them."""
    n = origins.shape[0]
    t = np.full(n, np.inf, np.float32)
    ng = np.zeros((n, 3), np.float32)
    uv = np.zeros((n, 2), np.float32)
    ids = np.full((n, 4), INVALID, np.uint32)
    f, u = trace.new_ray_buffer()
    for i in range(n):
        if trace.intersect1(scene, f, u, (origins[i, 0], origins[i, 1], origins[i, 2]),
                            (dirs[i, 0], dirs[i, 1], dirs[i, 2]), 0.0, np.inf, time[i]):
            t[i] = f[trace.TFAR]
            ng[i, 0], ng[i, 1], ng[i, 2] = f[trace.NG_X], f[trace.NG_Y], f[trace.NG_Z]
            uv[i, 0], uv[i, 1] = f[trace.U], f[trace.V]
            ids[i, 0], ids[i, 1] = u[trace.PRIM_ID], u[trace.GEOM_ID]
            ids[i, 2], ids[i, 3] = u[trace.INST_ID], u[trace.INST_PRIM_ID]
    return t, ng, uv, ids


@numba.njit
def _occluded(scene, o, d, tfar, surfaces_only=False):
    f, u = trace.new_ray_buffer()
    if surfaces_only:           # ray mask MASK_SURFACES (1)
        return trace.occluded1_surfaces(scene, f, u, (o[0], o[1], o[2]), (d[0], d[1], d[2]), 0.0, tfar, 0.0)
    return trace.occluded1(scene, f, u, (o[0], o[1], o[2]), (d[0], d[1], d[2]), 0.0, tfar, 0.0)


@numba.njit
def _transform(scene, inst_id, inst_prim_id, time):
    out = np.empty(12, np.float32)
    trace.instance_transform(scene, inst_id, inst_prim_id, time, out)
    return out.reshape(3, 4)


def probe(scene, origins, dirs, time=0.0):
    origins = np.atleast_2d(np.asarray(origins, np.float32))
    dirs = np.broadcast_to(np.asarray(dirs, np.float32), origins.shape).copy()
    return _probe(scene.handle, origins, dirs, np.broadcast_to(np.float32(time), len(origins)).astype(np.float32))


def translation(x=0.0, y=0.0, z=0.0, scale=1.0):
    return np.array([[scale, 0, 0, x], [0, scale, 0, y], [0, 0, scale, z]], np.float32)


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0]], np.float32)


def uv_sphere(n):
    """Triangulated unit sphere, 2 (n-1) (2n-1) triangles, outward (counter-clockwise) winding."""
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 2 * n), indexing="ij")
    v = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    a = (np.arange(n - 1)[:, None] * 2 * n + np.arange(2 * n - 1)[None, :]).ravel()
    b, c = a + 1, a + 2 * n
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([b, c + 1, c], 1)])
    return v.astype(np.float32), tris.astype(np.uint32)


SQUARE = (np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32),
          np.array([[0, 1, 2], [0, 2, 3]], np.uint32))   # Ng = cross(v1-v0, v2-v0) = (0, 0, 4)


# ----------------------------------------------------------------------------- geometry and ids
def test_instanced_unit_sphere_is_the_analytic_ellipsoid(dev):
    M = np.array([[0.5, 0, 0, 0], [0, 1.5, 0, 1.5], [0, 0, 1, -4]])
    sphere = dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)])
    top = dev.top_scene([sphere], [InstanceGroup(np.zeros(2, np.uint32),
                                                 np.stack([translation(100.0), M])[None].astype(np.float32))])
    origin = np.array([0, 1.5, 0])
    targets = np.array([[0, 1.5, -4], [0.2, 2.0, -4], [-0.3, 1.0, -4.2], [0.1, 2.6, -3.8], [0.4, 1.5, -4]])
    dirs = targets - origin
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, ng, _, ids = probe(top, np.tile(origin, (len(dirs), 1)), dirs)

    # ray in object space: o' = L^-1 (o - T), d' = L^-1 d; |o' + t d'| = 1
    L_inv = np.linalg.inv(M[:, :3])
    o_obj, d_obj = L_inv @ (origin - M[:, 3]), dirs @ L_inv.T
    a, b, c = np.sum(d_obj * d_obj, 1), d_obj @ o_obj, o_obj @ o_obj - 1
    t_exact = (-b - np.sqrt(b * b - a * c)) / a
    np.testing.assert_allclose(t, t_exact, rtol=1e-5)
    assert (ids == [0, 0, 0, 1]).all()     # primID 0, geomID 0, instID = group 0, instPrimID = row 1
    assert top.group_geom_ids == (0,)

    # Ng of a SPHERE_POINT is p - c in object space (unit sphere: the object-space point itself)
    p_obj = o_obj + t_exact[:, None] * d_obj
    np.testing.assert_allclose(ng, p_obj, atol=2e-5)

    np.testing.assert_allclose(top.bounds(), [[-0.5, -1, -5], [101, 3, 1]], atol=1e-6)
    np.testing.assert_allclose(_transform(top.handle, 0, 1, 0.0), M, atol=1e-7)
    miss_t, _, _, miss_ids = probe(top, origin, [0, 0, 1])
    assert miss_t[0] == np.inf and (miss_ids == INVALID).all()

    to_centre = np.array([0, 0, -1.0])           # ellipsoid surface at t = 3
    assert _occluded(top.handle, origin, to_centre, 3.5)
    assert not _occluded(top.handle, origin, to_centre, 2.5)


def test_instance_array_of_three_triangle_prototypes(dev):
    vertices, triangles = SQUARE
    protos = [dev.prototype_scene([(vertices - [0, 0, p], triangles)],
                                  [np.array([[0.5, 0.5, 0.5, 0.25]], np.float32)] if p == 2 else [])
              for p in range(3)]                 # prototype p: square at z = -p; #2 also a sphere (geomID 1)
    proto_index = np.array([2, 0, 1, 0], np.uint32)
    top = dev.top_scene(protos, [InstanceGroup(proto_index,
                                               np.stack([translation(10.0 * r) for r in range(4)])[None])])
    rows = np.arange(4)
    lower = np.stack([10.0 * rows + 0.5, np.full(4, -0.25), np.full(4, 5.0)], 1)   # y < x: triangle 0
    upper = np.stack([10.0 * rows - 0.5, np.full(4, 0.25), np.full(4, 5.0)], 1)    # y > x: triangle 1
    for origins, prim, uv in ((lower, 0, [0.375, 0.375]), (upper, 1, [0.25, 0.375])):
        t, ng, uvs, ids = probe(top, origins, [0, 0, -1])
        np.testing.assert_allclose(t, 5.0 + proto_index, rtol=1e-6)
        np.testing.assert_array_equal(ids, np.stack([np.full(4, prim), np.zeros(4), np.zeros(4), rows], 1))
        np.testing.assert_allclose(ng, np.tile([0, 0, 4.0], (4, 1)), atol=1e-6)
        np.testing.assert_allclose(uvs, np.tile(uv, (4, 1)), atol=1e-6)
    t, _, _, ids = probe(top, [0.5, 0.5, 5.0], [0, 0, -1])    # row 0 = prototype 2: its sphere first
    assert ids[0].tolist() == [0, 1, 0, 0] and abs(t[0] - 4.25) < 1e-6


def test_rays_embree_cannot_trace_meet_nothing(dev):
    """A ray past Embree's own test of a ray it can traverse (`trace.RAY_LIMIT`, 1.844e18 a coordinate; NaN fails it:
    a NaN direction crashed Embree's traversal in the USD fuzzer) is not traced, as single rays and in packets: it
    meets nothing and nothing occludes it, even a ray from 1e19 straight at a square that Embree itself would hit;
    the same ray from 1e18 hits it."""
    vertices, triangles = SQUARE
    proto = dev.prototype_scene([(vertices * np.float32(1e6), triangles)], [])
    top = dev.top_scene([proto], [InstanceGroup(np.zeros(1, np.uint32), translation()[None, None])])
    nan = float('nan')
    origins = np.array([[0, 0, 1e19], [0, 0, 1e18], [0, 0, 5], [nan, 0, 5], [0, 0, 5], [0, 0, 5]], np.float32)
    dirs = np.array([[0, 0, -1], [0, 0, -1], [0, 0, -1], [0, 0, -1], [nan, 0, -1], [0, 0, -2e18]], np.float32)
    expected = [False, True, True, False, False, False]
    t, _, _, ids = probe(top, origins, dirs)
    assert (ids[:, 1] != INVALID).tolist() == expected
    assert abs(t[1] / 1e18 - 1) < 1e-6 and t[2] == 5.0
    assert [_occluded(top.handle, o, d, np.inf) for o, d in zip(origins, dirs)] == expected
    n = len(origins)
    rays = (origins, dirs, np.zeros(n, np.float32), np.full(n, np.inf, np.float32), np.zeros(n, np.float32))
    for width in (16, 8):
        t16, ids16 = np.empty(n, np.float32), np.full((n, 4), 7, np.uint32)
        embree_loops.trace_packets(top.handle, rays, t16, ids16, width)
        assert (ids16[:, 1] != INVALID).tolist() == expected
        occluded = np.empty(n, bool)
        embree_loops.occlude_packets(top.handle, rays, occluded, False, width)
        assert occluded.tolist() == expected
    assert trace.traceable((0.0, 0.0, -1.844e18), (0.0, 1.0, 0.0)) and not trace.traceable((0.0, 0.0, 0.0),
                                                                                              (0.0, 1.9e18, 0.0))


def test_an_instance_array_of_one_instance_instances_its_own_prototype(dev):
    """Embree 4.4 ignores the index buffer of a one-instance array (it instances the first scene of the
    list): top_scene gives such a group a list of its one prototype.  Two one-instance groups of
    prototypes 2 and 1, and the masks a group may carry (shadow rays of mask 1 pass a group of mask 2)."""
    vertices, triangles = SQUARE
    protos = [dev.prototype_scene([(vertices - [0, 0, p], triangles)], []) for p in range(3)]
    top = dev.top_scene(protos, [InstanceGroup(np.array([2], np.uint32), translation(0.0)[None, None]),
                                 InstanceGroup(np.array([1], np.uint32), translation(10.0)[None, None])],
                        masks=[1, 2])
    t, _, _, ids = probe(top, [[0.5, 0.25, 5.0], [10.5, 0.25, 5.0]], [0, 0, -1])
    np.testing.assert_allclose(t, [7.0, 6.0], rtol=1e-6)            # squares at z = -2 and z = -1
    assert ids[:, 2].tolist() == [0, 1]
    assert _occluded(top.handle, (0.5, 0.25, 5.0), (0.0, 0.0, -1.0), 10.0, surfaces_only=True)
    assert not _occluded(top.handle, (10.5, 0.25, 5.0), (0.0, 0.0, -1.0), 10.0, surfaces_only=True)
    assert _occluded(top.handle, (10.5, 0.25, 5.0), (0.0, 0.0, -1.0), 10.0)


def test_ng_is_in_object_space(dev):
    R = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])      # 90 degrees about x: object +z -> world -y
    M = np.hstack([2 * R, [[0], [3], [0]]]).astype(np.float32)
    square = dev.prototype_scene([SQUARE], [])
    top = dev.top_scene([square], [InstanceGroup(np.zeros(1, np.uint32), M[None, None])])
    t, ng, uv, ids = probe(top, [0.5, 10.0, 0.3], [0, -1, 0])
    # world hit (0.5, 3, 0.3) = object (0.25, 0.15, 0): triangle 0, v = (0.15+1)/2, u = (0.25+1)/2 - v
    assert abs(t[0] - 7.0) < 1e-5 and ids[0, 0] == 0
    np.testing.assert_allclose(ng[0], [0, 0, 4], atol=1e-6)   # not the world normal (0, -1, 0)
    np.testing.assert_allclose(uv[0], [0.05, 0.575], atol=1e-6)


# ----------------------------------------------------------------------------- motion blur
def test_translating_instance_over_the_shutter(dev):
    sphere = dev.prototype_scene([], [np.array([[0, 0, 0, 0.5]], np.float32)])
    top = dev.top_scene([sphere], [InstanceGroup(np.zeros(1, np.uint32),
                                                 np.stack([translation(0.0), translation(2.0)])[:, None])])
    for time in (0.0, 0.5, 1.0):
        x = 2 * time                                 # centre of the sphere at this ray time
        origins = [[x, 0, 5], [x + 0.3, 0, 5], [x - 0.6, 0, 5], [x + 0.6, 0, 5]]
        t, _, _, ids = probe(top, origins, [0, 0, -1], time)
        np.testing.assert_allclose(t[:2], [4.5, 5 - np.sqrt(0.25 - 0.09)], rtol=1e-5)
        assert (ids[:2, 1] == 0).all() and (ids[2:] == INVALID).all()


def test_rotating_instance_keeps_its_size_with_quaternion_steps(dev):
    offset = dev.prototype_scene([], [np.array([[1, 0, 0, 0.2]], np.float32)])
    steps = np.stack([rotation_z(0.0), rotation_z(np.pi / 2)])[:, None]
    group = InstanceGroup(np.zeros(1, np.uint32), steps)
    centre = np.array([np.sqrt(0.5), np.sqrt(0.5), 0.0])    # true position at time 0.5 (45 degrees)
    origins = [centre + [0, 0, 5], centre + [0.15, 0, 5]]
    expected = [4.8, 5 - np.sqrt(0.04 - 0.0225)]

    auto = dev.top_scene([offset], [group])                 # rotation detected -> quaternion steps
    forced = dev.top_scene([offset], [group], quaternion_motion=True)
    for top in (auto, forced):
        t, _, _, ids = probe(top, origins, [0, 0, -1], 0.5)
        np.testing.assert_allclose(t, expected, atol=2e-4)  # Embree's slerp uses a fast acos approximation
        L = _transform(top.handle, 0, 0, 0.5)[:, :3]
        np.testing.assert_allclose(L @ L.T, np.eye(3), atol=1e-4)

    lerped = dev.top_scene([offset], [group], quaternion_motion=False)
    t, _, _, ids = probe(lerped, origins, [0, 0, -1], 0.5)   # lerped matrices: centre 0.71 from the axis,
    assert (ids[:, 1] == INVALID).all()                      # radius 0.14 -> the true centre is missed
    np.testing.assert_allclose(np.linalg.det(_transform(lerped.handle, 0, 0, 0.5)[:, :3]), 0.5, atol=1e-6)


def test_decompose_affine_recomposes_and_matches_embree(dev):
    rng = np.random.default_rng(7)
    M = rng.normal(size=(64, 3, 4))
    M[::2, :, 0] *= -1                                       # half of them mirroring
    d = decompose_affine(M)

    r, i, j, k = np.moveaxis(d[:, 9:13], -1, 0)
    R = np.stack([np.stack([1 - 2 * (j * j + k * k), 2 * (i * j - k * r), 2 * (i * k + j * r)], -1),
                  np.stack([2 * (i * j + k * r), 1 - 2 * (i * i + k * k), 2 * (j * k - i * r)], -1),
                  np.stack([2 * (i * k - j * r), 2 * (j * k + i * r), 1 - 2 * (i * i + j * j)], -1)], -2)
    U = np.zeros((64, 3, 4))
    U[:, [0, 1, 2], [0, 1, 2]] = d[:, 0:3]
    U[:, 0, 1], U[:, 0, 2], U[:, 1, 2] = d[:, 3], d[:, 4], d[:, 5]
    U[:, :, 3] = d[:, 6:9]
    recomposed = R @ U
    recomposed[:, :, 3] += d[:, 13:16]
    np.testing.assert_allclose(recomposed, M, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(d[:, 9:13], axis=1), 1, atol=1e-12)
    assert (d[:, 0:2] > 0).all() and ((d[:, 2] < 0) == (np.linalg.det(M[:, :, :3]) < 0)).all()

    sphere = dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)])
    steps = np.stack([M, M]).astype(np.float32)             # two equal steps stored as decompositions
    top = dev.top_scene([sphere], [InstanceGroup(np.zeros(64, np.uint32), steps)], quaternion_motion=True)
    for row in (0, 1, 17, 63):
        np.testing.assert_allclose(_transform(top.handle, 0, row, 0.3), M[row], atol=2e-5)


# ----------------------------------------------------------------------------- errors and lifetime
def test_errors(dev):
    sphere = dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)])
    too_many_steps = np.tile(translation(), (130, 1, 1, 1))    # Embree allows at most 129 time steps
    with pytest.raises(EmbreeError, match="number of time steps is out of range"):
        dev.top_scene([sphere], [InstanceGroup(np.zeros(1, np.uint32), too_many_steps)])
    rtcNewGeometry(dev.handle, 123)                              # no such geometry type
    with pytest.raises(EmbreeError, match="invalid geometry type"):
        dev.check("rtcNewGeometry")
    dev.check()                                                  # errors are cleared once raised

    with pytest.raises(ValueError, match="triangle index"):
        dev.prototype_scene([(SQUARE[0], SQUARE[1] + 2)], [])
    with pytest.raises(ValueError, match="proto_index"):
        dev.top_scene([sphere], [InstanceGroup(np.ones(1, np.uint32), translation()[None, None])])
    with pytest.raises(ValueError, match=r"\(K, 2, 3, 4\)"):
        dev.top_scene([sphere], [InstanceGroup(np.zeros(2, np.uint32), translation()[None, None])])

    sphere.close()
    sphere.close()
    with pytest.raises(EmbreeError, match="closed"):
        sphere.handle


def test_scene_outlives_closed_python_handles():
    """Embree reference counts: a top scene keeps its prototypes and the device alive."""
    device = Device()
    proto = device.prototype_scene([SQUARE], [])
    top = device.top_scene([proto], [InstanceGroup(np.zeros(1, np.uint32), translation()[None, None])])
    proto.close()
    device.close()
    t, _, _, _ = probe(top, [0.5, 0.2, 1], [0, 0, -1])
    assert t[0] == pytest.approx(1.0)
    top.close()


def _rss_mb():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS")) / 1024


def test_build_release_cycles_do_not_leak(dev):
    vertices, triangles = uv_sphere(159)
    assert len(triangles) > 100_000
    transforms = np.stack([translation(3.0 * i) for i in range(10)])[None]

    def cycle():
        with dev.prototype_scene([(vertices, triangles)], []) as proto:
            with dev.top_scene([proto], [InstanceGroup(np.zeros(10, np.uint32), transforms)]):
                pass

    for _ in range(5):
        cycle()
    before = _rss_mb()
    for _ in range(50):
        cycle()
    assert _rss_mb() - before < 20      # one live build is ~10 MB; a leak would add ~500 MB


# ----------------------------------------------------------------------------- bare loops
def _random_scene_and_rays(dev, n_rays):
    rng = np.random.default_rng(3)
    protos = [dev.prototype_scene([uv_sphere(24)], []),
              dev.prototype_scene([SQUARE], [rng.uniform(-1, 1, (20, 4)).astype(np.float32) * [1, 1, 1, 0.3]])]
    n = 64
    linear = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0] * rng.uniform(0.5, 1.5, (n, 1, 1))   # some mirrored
    static = np.concatenate([linear, rng.uniform(-5, 5, (n, 3, 1))], 2)[None].astype(np.float32)
    moving = np.stack([static[0, :8], static[0, :8]])
    moving[1, :, :, 3] += [1.0, 0.5, 0.0]
    top = dev.top_scene(protos, [InstanceGroup(rng.integers(0, 2, n).astype(np.uint32), static),
                                 InstanceGroup(rng.integers(0, 2, 8).astype(np.uint32), moving)])
    origins = rng.uniform(-6, 6, (n_rays, 3)).astype(np.float32)
    dirs = rng.normal(size=(n_rays, 3)).astype(np.float32)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    tnear = np.zeros(n_rays, np.float32)
    tfar = rng.uniform(1, 20, n_rays).astype(np.float32)
    time = rng.uniform(0, 1, n_rays).astype(np.float32)
    return top, (origins, dirs, tnear, tfar, time)


def test_packets_agree_with_single_rays(dev):
    """Packets of 16 traced as one 16-ray query or as two 8-ray ones (`trace.Packet`), in Embree's default
    and coherent modes, find the hits single rays find."""
    top, rays = _random_scene_and_rays(dev, 10_000)
    n = len(rays[0])
    results = []
    t, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
    embree_loops.trace_rays(top.handle, *rays, t, ids)
    results.append((t, ids))
    for kernel in (embree_loops.trace_packets, embree_loops.trace_packets_coherent):
        for width in (16, 8):
            t, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
            kernel(top.handle, rays, t, ids, width)
            results.append((t, ids))
    (t1, ids1), *packets = results
    hit = ids1[:, 1] != INVALID
    assert 0.2 < hit.mean() < 0.9
    for t16, ids16 in packets:
        same = (ids1 == ids16).all(1)
        assert same.mean() > 0.999
        np.testing.assert_allclose(t16[same], t1[same], rtol=1e-5)
    assert (t1[~hit] == rays[3][~hit]).all()          # misses leave tfar

    occluded1 = np.empty(n, bool)
    embree_loops.occlude_rays(top.handle, *rays, occluded1)
    assert (occluded1 == hit).mean() > 0.999
    for width in (16, 8):
        occluded = np.empty(n, bool)
        embree_loops.occlude_packets(top.handle, rays, occluded, False, width)
        assert (occluded == occluded1).mean() > 0.999

    single = probe(top, rays[0][:500], rays[1][:500], 0.0)[3]   # inline helper == bare loop (time 0)
    t0, ids0 = np.empty(500, np.float32), np.empty((500, 4), np.uint32)
    embree_loops.trace_rays(top.handle, rays[0][:500], rays[1][:500], rays[2][:500], np.full(500, np.inf, np.float32),
                     np.zeros(500, np.float32), t0, ids0)
    assert (single == ids0).all()


def test_shadow_replay_carries_the_path_integrators_mask(dev):
    """The benchmarks' occlusion loops with `surfaces`: light shapes (mask MASK_LIGHT_SHAPES) occlude
    nothing, as for the renderer's shadow rays; without it they do."""
    def quad(x0, x1, z):
        v = np.array([[x0, -1, z], [x1, -1, z], [x1, 1, z], [x0, 1, z]], np.float32)
        return dev.prototype_scene([(v, np.array([[0, 1, 2], [0, 2, 3]], np.uint32))], [])
    protos = [quad(-1.0, 0.0, 2.0), quad(0.5, 1.0, 1.0)]         # a surface; a light shape in front
    eye = np.eye(4, dtype=np.float32)[None, None, :3]
    top = dev.top_scene(protos, [InstanceGroup(np.zeros(1, np.uint32), eye), InstanceGroup(np.ones(1, np.uint32), eye)],
                        masks=[trace.MASK_SURFACES, trace.MASK_LIGHT_SHAPES])
    n = 1000
    x = (np.arange(n) + 0.5) / n * 2.0 - 1.0                      # none on an edge
    origins = np.stack([x, np.zeros(n), np.zeros(n)], 1).astype(np.float32)
    dirs = np.tile(np.array([0, 0, 1], np.float32), (n, 1))
    rays = (origins, dirs, np.zeros(n, np.float32), np.full(n, 10, np.float32), np.zeros(n, np.float32))
    loops = (embree_loops.occlude_rays,
             lambda h, *a: embree_loops.occlude_packets(h, a[:5], a[5], a[6], 16),
             lambda h, *a: embree_loops.occlude_packets(h, a[:5], a[5], a[6], 8))
    for k, loop in enumerate(loops):
        for surfaces, expected in ((False, (x < 0) | (x > 0.5)), (True, x < 0)):
            out = np.empty(n, bool)
            loop(top.handle, *rays, out, surfaces)
            assert (out == expected).all(), (k, surfaces)
    for s in [top] + protos:
        s.close()


def test_cached_kernels_load_in_a_fresh_process(tmp_path):
    script = textwrap.dedent("""
        import numpy as np
        from benchmarks import embree_loops
        from rtc.renderer.host.embree import Device, InstanceGroup
        with Device() as dev:
            proto = dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)])
            eye = np.eye(3, 4, dtype=np.float32)[None, None]
            with dev.top_scene([proto], [InstanceGroup(np.zeros(1, np.uint32), eye)]) as top:
                o, d = np.array([[0, 0, 5]], np.float32), np.array([[0, 0, -1]], np.float32)
                t, ids = np.empty(1, np.float32), np.empty((1, 4), np.uint32)
                z = np.zeros(1, np.float32)
                embree_loops.trace_rays(top.handle, o, d, z, z + np.inf, z, t, ids)
        assert abs(t[0] - 4) < 1e-6, t
        print(sum(embree_loops.trace_rays.stats.cache_hits.values()))
    """)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), PYTHONPATH=ROOT)
    hits = [int(subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, check=True,
                               capture_output=True, text=True).stdout.strip()) for _ in range(2)]
    assert hits == [0, 1]


def test_kernel_symbols_are_registered_by_the_binding():
    """Every Embree function the kernels declare by name resolves, once the binding is imported, to
    the library's own entry point; the ABI values the kernels hard-code are the binding's."""
    import ctypes

    import llvmlite.binding as llvm

    from rtc.renderer.host import embree
    assert set(trace.EXTERNAL_FUNCTIONS) >= {'rtcIntersect1', 'rtcOccluded1', 'rtcIntersect16', 'rtcOccluded16'}
    for name in trace.EXTERNAL_FUNCTIONS:
        address = llvm.address_of_symbol(trace.SYMBOL_PREFIX + name)
        assert address == ctypes.cast(getattr(embree.LIB, name), ctypes.c_void_p).value, name
    assert trace.INVALID == embree.RTC_INVALID_GEOMETRY_ID
    assert trace._XFM_ROW_MAJOR == embree.RTC_FORMAT_FLOAT3X4_ROW_MAJOR
