"""Spheres as Embree user geometry (`rtc.renderer.host.user_geometry`, the path integrator's top level) against
the exact ray-sphere roots in float64 and against Embree's own SPHERE_POINT: the same hits, ids, normals,
masks and occlusion, single rays and packets, in instances, far from the origin and from inside."""
import gc

import numpy as np
import pytest

from benchmarks import embree_loops
from rtc.renderer.host.embree import Device, InstanceGroup
from rtc.renderer.kernel import trace
from tests.renderer.test_embree import probe, translation, _occluded

INVALID = 0xFFFFFFFF


@pytest.fixture(scope="module")
def dev():
    with Device(threads=2) as device:
        yield device


def _exact_t(o, d, c, r):
    """Nearest root t >= 0 of |o + t d - c| = r per ray (float64; inf where the ray misses), with the
    discriminant from the centre's distance to the line (no cancellation)."""
    o, d, c = (np.asarray(x, np.float64) for x in (o, d, c))
    oc = o - c
    a = np.sum(d * d, 1)
    b = np.sum(oc * d, 1)
    cc = np.sum(oc * oc, 1) - r * r
    l = oc - (b / a)[:, None] * d
    disc = a * (r * r - np.sum(l * l, 1))
    sq = np.sqrt(np.maximum(disc, 0.0))
    q = -(b + np.copysign(sq, b))
    t0, t1 = np.minimum(q / a, cc / q), np.maximum(q / a, cc / q)
    t = np.where(t0 >= 0, t0, t1)
    return np.where((disc >= 0) & (t >= 0), t, np.inf)


def _rays(rng, n, centre, spread):
    o = (np.asarray(centre) + rng.uniform(-spread, spread, (n, 3))).astype(np.float32)
    target = np.asarray(centre) + rng.uniform(-1.5, 1.5, (n, 3))
    d = target - o
    return o, (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


@pytest.mark.parametrize("centre", [(0.0, 0.0, 0.0), (1e4, -2e4, 3e4)])
def test_hits_are_the_exact_roots_and_agree_with_embrees_spheres(dev, centre):
    rng = np.random.default_rng(1)
    rows = np.array([[*centre, 1.0]])
    user = dev.prototype_scene([], [rows], user_shapes=True)
    point = dev.prototype_scene([], [rows.astype(np.float32)])
    o, d = _rays(rng, 4000, centre, 6.0)
    tu, ngu, uvu, idu = probe(user, o, d)
    tp, ngp, _, idp = probe(point, o, d)
    exact = _exact_t(o, d, rows[0, :3], 1.0)
    hit = np.isfinite(exact)
    assert 0.2 < hit.mean() < 0.9 and (np.linalg.norm(o - rows[0, :3], axis=1) < 1).sum() > 5   # some from inside
    # where the exact answer is not a grazing ray, both representations find it; the user sphere to float32
    grazing = np.abs(np.linalg.norm(np.cross(o - rows[0, :3], d), axis=1) - 1.0) < 1e-3
    np.testing.assert_array_equal(np.isfinite(tu)[~grazing], hit[~grazing])
    np.testing.assert_allclose(tu[hit & ~grazing], exact[hit & ~grazing], rtol=1e-6, atol=1e-6)
    assert (idu[hit & ~grazing] == [0, 0, INVALID, INVALID]).all()
    assert (idu[~np.isfinite(tu)] == INVALID).all()
    same = np.isfinite(tu) & np.isfinite(tp)
    assert (idu[same] == idp[same]).all()
    # Ng = p - c (object space, unnormalised) and u = v = 0, as SPHERE_POINT reports them
    p = o[same].astype(np.float64) + tu[same, None] * d[same] - rows[0, :3]
    np.testing.assert_allclose(ngu[same], p, atol=2e-6 * max(1.0, np.abs(centre).max()))
    np.testing.assert_allclose(ngu[same], ngp[same], atol=1e-3 * max(1.0, np.abs(centre).max() * 1e-2))
    assert (uvu[same] == 0).all()
    for s in (user, point):
        s.close()


def test_instanced_user_spheres_report_their_instance_and_object_space(dev):
    rows = np.array([[0.0, 0.0, 0.0, 1.0], [3.0, 0.0, 0.0, 0.5]])
    proto = dev.prototype_scene([], [rows[:1], rows[1:]], user_shapes=True)
    M = np.array([[0.5, 0, 0, 0], [0, 1.5, 0, 1.5], [0, 0, 1, -4]], np.float32)   # an ellipsoid, row 1
    top = dev.top_scene([proto], [InstanceGroup(np.zeros(2, np.uint32), np.stack([translation(100.0), M])[None])])
    origin = np.array([0, 1.5, 0.0])
    dirs = np.array([[0, 0, -4], [0.2, 0.5, -4], [-0.3, -0.5, -4.2]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, ng, _, ids = probe(top, np.tile(origin, (3, 1)), dirs)
    L_inv = np.linalg.inv(M[:, :3].astype(np.float64))
    o_obj, d_obj = L_inv @ (origin - M[:, 3]), dirs @ L_inv.T
    np.testing.assert_allclose(t, _exact_t(np.tile(o_obj, (3, 1)), d_obj, (0, 0, 0), 1.0), rtol=1e-6)
    assert (ids == [0, 0, 0, 1]).all()              # primID 0, geomID 0, instID = group 0, instPrimID = row 1
    np.testing.assert_allclose(ng, o_obj + t[:, None] * d_obj, atol=2e-6)
    # the second geometry, 0.5 in radius at x = 3 of row 0 (translated to x = 103)
    t2, _, _, ids2 = probe(top, [103.0, 0.0, 5.0], [0, 0, -1])
    assert t2[0] == pytest.approx(4.5, rel=1e-7) and ids2[0].tolist() == [0, 1, 0, 0]
    # occlusion stops at tfar, and a ray starting inside meets the far side
    assert _occluded(top.handle, origin, np.array([0, 0, -1.0]), 3.5)
    assert not _occluded(top.handle, origin, np.array([0, 0, -1.0]), 2.5)
    t3, _, _, _ = probe(top, [100.0, 0.0, 0.0], [0, 0, 1])
    assert t3[0] == pytest.approx(1.0, rel=1e-7)
    top.close()
    proto.close()


def test_masks_packets_and_single_rays_agree(dev):
    """A light-shape sphere (mask MASK_LIGHT_SHAPES) is passed by shadow rays (mask MASK_SURFACES) and met
    by the rest; packets and single rays give the same hits as the exact roots."""
    rng = np.random.default_rng(7)
    rows = np.concatenate([rng.uniform(-3, 3, (30, 3)), rng.uniform(0.3, 0.9, (30, 1))], 1)
    surf = dev.prototype_scene([], [rows], user_shapes=True)
    lamp = dev.prototype_scene([], [np.array([[0.0, 4.0, 0.0, 0.8]])], user_shapes=True)
    eye = np.eye(4, dtype=np.float32)[None, None, :3]
    top = dev.top_scene([surf, lamp], [InstanceGroup(np.zeros(1, np.uint32), eye),
                                       InstanceGroup(np.ones(1, np.uint32), eye)],
                        masks=[trace.MASK_SURFACES, trace.MASK_LIGHT_SHAPES])
    n = 20_000
    o = rng.uniform(-5, 5, (n, 3)).astype(np.float32)
    d = rng.normal(size=(n, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rays = (o, d, np.zeros(n, np.float32), rng.uniform(1, 12, n).astype(np.float32), np.zeros(n, np.float32))
    results = []
    kernels = [embree_loops.trace_rays] + [lambda h, *a, k=k, w=w: k(h, a[:5], a[5], a[6], w) for w in (16, 8)
                                           for k in (embree_loops.trace_packets, embree_loops.trace_packets_coherent)]
    for kernel in kernels:
        t, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
        kernel(top.handle, *rays, t, ids)
        results.append((t, ids))
    (t1, ids1), *packets = results
    for t16, ids16 in packets:
        assert (ids16 == ids1).all()
        np.testing.assert_array_equal(t16, t1)
    hit = ids1[:, 1] != INVALID
    assert 0.1 < hit.mean() < 0.9 and (ids1[hit, 2] == 1).sum() > 50      # the lamp is met
    for surfaces in (False, True):
        for k, loop in enumerate((embree_loops.occlude_rays,
                                  lambda h, *a: embree_loops.occlude_packets(h, a[:5], a[5], a[6], 16),
                                  lambda h, *a: embree_loops.occlude_packets(h, a[:5], a[5], a[6], 8))):
            out = np.empty(n, bool)
            loop(top.handle, *rays, out, surfaces)
            expected = hit if not surfaces else _any_surface(o, d, rays[3], rows)
            assert (out == expected).mean() > 0.9999, (k, surfaces)
    top.close()
    surf.close()
    lamp.close()


def _any_surface(o, d, tfar, rows):
    """Whether each segment [0, tfar] meets any of the spheres (exact, float64)."""
    out = np.zeros(len(o), bool)
    for c in rows:
        oc = o.astype(np.float64) - c[:3]
        b = np.sum(oc * d, 1)
        cc = np.sum(oc * oc, 1) - c[3] ** 2
        disc = b * b - cc
        sq = np.sqrt(np.maximum(disc, 0))
        t0, t1 = -b - sq, -b + sq
        out |= (disc >= 0) & (((t0 >= 0) & (t0 <= tfar)) | ((t1 >= 0) & (t1 <= tfar)))
    return out


def test_the_rows_outlive_every_python_handle():
    """Embree reads the user spheres' rows through a raw pointer: the top scene keeps them alive after its
    prototype's and the device's Python objects are closed and collected."""
    device = Device()
    proto = device.prototype_scene([], [np.array([[0.0, 0.0, -3.0, 1.0]])], user_shapes=True)
    top = device.top_scene([proto], [InstanceGroup(np.zeros(1, np.uint32), translation()[None, None])])
    proto.close()
    device.close()
    del proto, device
    gc.collect()
    np.zeros(1 << 20)                           # reuse freed memory, if any were freed
    t, _, _, ids = probe(top, [0.0, 0.0, 0.0], [0, 0, -1])
    assert t[0] == pytest.approx(2.0, rel=1e-7) and ids[0, 1] == 0
    top.close()


def _exact_cylinder_t(o, d, p0, p1, r):
    """Nearest t >= 0 where the ray crosses the side of the open cylinder (float64; inf if none)."""
    o, d = np.asarray(o, np.float64), np.asarray(d, np.float64)
    ax = np.asarray(p1, np.float64) - p0
    L2 = ax @ ax
    oc = o - p0
    sa, da = oc @ ax / L2, d @ ax / L2
    op, dp = oc - sa[:, None] * ax, d - da[:, None] * ax
    a, b, c = np.sum(dp * dp, 1), np.sum(op * dp, 1), np.sum(op * op, 1) - r * r
    disc = b * b - a * c
    sq = np.sqrt(np.maximum(disc, 0))
    out = np.full(len(o), np.inf)
    for t in ((-b + sq) / a, (-b - sq) / a):
        ok = (disc >= 0) & (t >= 0) & (sa + t * da >= 0) & (sa + t * da <= 1)
        out = np.where(ok, np.minimum(out, t), out)
    return out


def test_cylinders_are_the_exact_open_cylinder(dev):
    """A segment of `curves` as user geometry is the open cylinder (Embree's round linear curve is the
    capsule around it): its hits are the exact crossings of the side between the two ends, rays through the
    open ends meet the inside of the wall, and nothing meets the round caps a capsule would have."""
    rng = np.random.default_rng(4)
    p0, p1, r = np.array([0.3, -1.0, 0.2]), np.array([-0.2, 1.5, 0.4]), 0.4
    seg = np.array([[[*p0, r], [*p1, r]]])
    user = dev.prototype_scene([], [], curves=[seg], user_shapes=True)
    capsule = dev.prototype_scene([], [], curves=[seg.astype(np.float32)])
    o = rng.uniform(-4, 4, (5000, 3)).astype(np.float32)
    target = p0 + rng.uniform(-0.3, 1.3, (5000, 1)) * (p1 - p0) + rng.uniform(-0.6, 0.6, (5000, 3))
    d = (target - o).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, ng, _, ids = probe(user, o, d)
    exact = _exact_cylinder_t(o, d, p0, p1, r)
    hit = np.isfinite(exact)
    assert 0.2 < hit.mean() < 0.9
    np.testing.assert_array_equal(np.isfinite(t), hit)
    np.testing.assert_allclose(t[hit], exact[hit], rtol=1e-6, atol=1e-6)
    assert (ids[hit] == [0, 0, INVALID, INVALID]).all()
    # Ng: the radial vector, of length r, perpendicular to the axis
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    np.testing.assert_allclose(np.linalg.norm(ng[hit], axis=1), r, rtol=1e-5)
    np.testing.assert_allclose(ng[hit] @ u, 0.0, atol=1e-5)
    # the capsule also meets the round caps: more hits, never fewer
    tc, _, _, _ = probe(capsule, o, d)
    assert np.isfinite(tc)[hit].all() and np.isfinite(tc).sum() > hit.sum()
    # down the axis from outside the end: through the open end, then the far end is open too: no hit
    t_axis, _, _, _ = probe(user, p1 + 2 * u, -u)
    assert t_axis[0] == np.inf
    # from inside, across: the wall at distance r
    t_in, _, _, _ = probe(user, (p0 + p1) / 2, np.cross(u, [1.0, 0.0, 0.0]) / np.linalg.norm(np.cross(u, [1.0, 0.0, 0.0])))
    assert t_in[0] == pytest.approx(r, rel=1e-6)
    assert _occluded(user.handle, (p0 + p1) / 2, np.cross(u, [0.0, 0.0, 1.0]) / np.linalg.norm(np.cross(u, [0, 0, 1.0])), r * 1.01)
    assert not _occluded(user.handle, (p0 + p1) / 2, np.cross(u, [0.0, 0.0, 1.0]) / np.linalg.norm(np.cross(u, [0, 0, 1.0])), r * 0.99)
    for s in (user, capsule):
        s.close()
