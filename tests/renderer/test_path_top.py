"""The path integrator's top level (`host/build.path_top`): geometry placed once and the light shapes sit in
the top level itself, and a hit on them reads, after `kernel/path.placed_hit`, exactly as the same hit
in the instanced scene the cook integrator traces (`BuiltScene.top`): same placement row, gprim,
primitive, distance."""
import math

import numba
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host import light_selection
from rtc.renderer.host.light_selection import FACING_GROUPS, facing_groups
from rtc.renderer.host.render import Renderer, RenderOptions
from rtc.renderer.kernel.light_sampling import shape_mask
from rtc.renderer.kernel.path import placed_hit
from rtc.renderer.kernel.tables import GP_SPHERE
from rtc.renderer.kernel.trace import (GEOM_ID, INST_ID, INST_PRIM_ID, INVALID, MASK_ALL, PRIM_ID, TFAR, intersect1,
                                       intersect1_masked, intersect1_surfaces, new_ray_buffer)
from tests.renderer.handmade import look_at, quad, rect_light, scene, translate


@numba.njit(cache=False)
def _trace(scene_handle, L, origins, dirs, fix, out_ids, out_t):
    """Closest hits of rays (all masks) in `scene_handle`: ids (inst, inst prim, geom, prim) and t;
    with `fix`, hits on top-level geometry are given their placement's ids by `placed_hit`."""
    f, u = new_ray_buffer()
    for r in range(origins.shape[0]):
        hit = intersect1(scene_handle, f, u, (origins[r, 0], origins[r, 1], origins[r, 2]),
                         (dirs[r, 0], dirs[r, 1], dirs[r, 2]), 0.0, np.inf, 0.0)
        if fix:
            placed_hit(L, u)
        out_ids[r, 0] = u[INST_ID] if hit else INVALID
        out_ids[r, 1] = u[INST_PRIM_ID]
        out_ids[r, 2] = u[GEOM_ID]
        out_ids[r, 3] = u[PRIM_ID]
        out_t[r] = f[TFAR] if hit else np.inf


def _box(size=1.0, path='/box') -> D.Mesh:
    h = size / 2
    pts = np.array([[x, y, z] for x in (-h, h) for y in (0.0, size) for z in (-h, h)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return D.Mesh(path=path, points=pts, triangles=np.array(tris, np.int32), material=0)


def _rotation_y(deg, scale=1.0):
    a = math.radians(deg)
    m = np.eye(4)
    m[:3, :3] = scale * np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    return m


def _scene(once_matrix, box_matrices, moving=False, lights=True):
    """Container 0 (a floor and a sphere) placed once by `once_matrix`; container 1 (a box) placed at
    each of `box_matrices` (the first one moving if `moving`), row 0 and rows 2, 3, ...; a rect light
    above (a light shape)."""
    floor = D.Container('/', meshes=[quad(12.0)],
                        spheres=[D.Sphere(path='/ball', radius=0.7, matrix=translate(-2.0, 0.7, 1.0), material=0)])
    boxes = D.Container('/Box', meshes=[_box()])
    mats = [box_matrices[0], once_matrix] + list(box_matrices[1:])
    k = 2 if moving else 1
    m = np.repeat(np.asarray(mats, np.float64)[:, None], k, axis=1)
    if moving:
        m[0, 1] = m[0, 1] @ translate(0.3, 0.0, 0.0)
    inst = D.Instances(container=np.array([1, 0] + [1] * (len(box_matrices) - 1), np.int32), matrices=m,
                       material_set=np.zeros(len(mats), np.int32), material_sets=[()])
    lamps = [rect_light((0.0, 4.0, 0.0), 1.5, 1.0, (5.0, 5.0, 5.0))] if lights else []
    cam = D.Camera(path='/cam', matrix=look_at((0.5, 5.0, 9.0), (0.0, 0.5, 0.0)))
    return scene([floor, boxes], [D.Material('/m')], lamps, cam, instances=inst)


def _rays(n=40):
    """A fan of rays from the camera over the floor, the ball, the boxes and the light (camera-relative)."""
    eye = np.array([0.5, 5.0, 9.0])
    xs, ys = np.meshgrid(np.linspace(-4.5, 4.5, n), np.linspace(-1.0, 4.5, n))
    lx, lz = np.meshgrid(np.linspace(-0.6, 0.6, 8), np.linspace(-0.4, 0.4, 8))
    targets = np.concatenate([np.stack([xs.ravel(), ys.ravel(), np.zeros(n * n)], 1),
                              np.stack([lx.ravel(), np.full(64, 4.0), lz.ravel()], 1)])
    d = targets - eye
    return np.zeros((len(d), 3), np.float32), (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)


def _compare(desc):
    """Trace the same rays in the cook top level and the path top level: -> (cook ids, path ids fixed,
    path ids raw, cook t, path t, the path top's table)."""
    with Renderer(desc) as r:
        L = r.path_lights()
        o, d = _rays()
        out = {}
        for name, handle, fix in (('cook', r.built.handle, False), ('path', r.path_scene(), True),
                                  ('raw', r.path_scene(), False)):
            ids, t = np.zeros((len(o), 4), np.uint32), np.zeros(len(o))
            _trace(handle, L, o, d, fix, ids, t)
            out[name] = ids, t
        return out, L, r.built.data


def test_a_scene_of_prototypes_placed_once_is_traced_flat_and_its_hits_read_as_their_placements():
    once = translate(0.5, 0.0, -0.5) @ _rotation_y(30.0, 1.25)          # a similarity: its sphere stays one
    out, L, S = _compare(_scene(once, [translate(-2.5, 0.0, -2.0) @ _rotation_y(45)]))
    (cook, tc), (path, tp), (raw, _) = out['cook'], out['path'], out['raw']
    assert S.in_proto.tolist() == [1, 0]                                # row 0 the box, row 1 the floor and ball
    # the table: the box of row 0, the floor and the ball of row 1, then the rect light's triangles
    assert L.direct.tolist() == [[0, 0, 0], [0, 1, 0], [0, 1, 1], [L.light_group, 0, 0]]
    hits = cook[:, 0] != INVALID
    assert (cook[hits, 1] == 0).sum() > 20 and (cook[hits, 1] == 1).sum() > 500 and (cook[:, 2] == 1).sum() > 20
    # Embree reports no instance for any of them ...
    assert np.all(raw[hits, 0] == INVALID)
    # ... and after placed_hit every surface hit reads as in the instanced scene, at the same distance
    light = path[:, 0] == L.light_group
    assert light.sum() > 10                                             # cook's top has no light shapes
    surf = ~light
    np.testing.assert_array_equal(path[surf], cook[surf])
    np.testing.assert_allclose(tp[surf], tc[surf], rtol=2e-6)
    # a light-shape hit: instance light_group, index 0, the shapes' geometry 0 (the rects' triangles)
    assert np.all(path[light, 1] == 0) and np.all(path[light, 2] == 0) and np.all(cook[light, 0] != L.light_group)


def test_shadow_rays_do_not_meet_the_light_shapes_in_the_top_level():
    desc = _scene(np.eye(4), [translate(2.5, 0.0, 0.0), translate(-2.5, 0.0, 0.0)])
    with Renderer(desc) as r:
        L = r.path_lights()
        o = np.array([[0.0, -5.0 + 0.01, -9.0]], np.float32)          # on the floor under the light, upwards
        d = np.array([[0.0, 1.0, 0.0]], np.float32)
        ids, t = np.zeros((1, 4), np.uint32), np.zeros(1)
        _trace(r.path_scene(), L, o, d, True, ids, t)
        assert ids[0, 0] == L.light_group and t[0] == pytest.approx(4.0 - 0.01, rel=1e-5)
        f, u = new_ray_buffer()
        hit = _masked(r.path_scene(), f, u, o[0], d[0])
        assert not hit                                                   # surfaces only: nothing above


@numba.njit(cache=False)
def _masked(scene_handle, f, u, o, d):
    return intersect1_surfaces(scene_handle, f, u, (o[0], o[1], o[2]), (d[0], d[1], d[2]), 0.0, np.inf, 0.0)


def test_a_scene_of_geometry_placed_once_has_no_instance_left():
    floor = D.Container('/', meshes=[quad(12.0)])
    desc = scene([floor], [D.Material('/m')], [rect_light((0.0, 4.0, 0.0), 1.0, 1.0, (1.0,) * 3)],
                 D.Camera(path='/cam', matrix=look_at((0.0, 5.0, 9.0), (0.0, 0.0, 0.0))))
    with Renderer(desc) as r:
        r.path_lights()
        assert r._path_top.group_geom_ids == ()                         # a flat scene: no instance array
        o, d = np.zeros((1, 3), np.float32), np.array([[0.0, -5.0, -9.0]], np.float32) / math.hypot(5.0, 9.0)
        ids, t = np.zeros((1, 4), np.uint32), np.zeros(1)
        _trace(r.path_scene(), r.path_lights(), o, d.astype(np.float32), True, ids, t)
        assert ids[0, :3].tolist() == [0, 0, 0] and t[0] == pytest.approx(math.hypot(5.0, 9.0), rel=1e-6)


@pytest.mark.parametrize('case', ['placed twice', 'ellipsoid placement', 'moving scene'])
def test_a_scene_that_keeps_instances_keeps_them_all(case):
    """A prototype placed twice is never flattened; a sphere's container placed by a non-similarity stays
    an instance (its sphere would be an ellipsoid); in a scene where something moves, nothing is taken
    out of the instances.  Then nothing else is either (geometry taken out of instances, beside them,
    adds a BVH that every ray traverses), and the light shapes are one more instance."""
    boxes = [translate(2.5, 0.0, 0.0)] + ([translate(-2.5, 0.0, 0.0)] if case == 'placed twice' else [])
    once = np.diag([1.0, 0.5, 1.0, 1.0]) if case == 'ellipsoid placement' else np.eye(4)
    out, L, S = _compare(_scene(once, boxes, moving=case == 'moving scene'))
    assert L.direct.shape == (0, 3)
    (cook, tc), (path, tp), (raw, _) = out['cook'], out['path'], out['raw']
    light = path[:, 0] == L.light_group
    assert light.sum() > 10 and np.all(path[light, 1:3] == 0)
    np.testing.assert_array_equal(raw, path)                            # nothing for placed_hit to do
    np.testing.assert_array_equal(path[~light], cook[~light])
    # the same instances: the same floats, but on the ball, which the path top level tests in float64
    # (user geometry) where the cook one has Embree's float32 sphere
    ball = _on_spheres(S, cook) & ~light
    assert ball.sum() > 20
    np.testing.assert_array_equal(tp[~light & ~ball], tc[~light & ~ball])
    np.testing.assert_allclose(tp[ball], tc[ball], rtol=1e-6)


def _on_spheres(S, ids):
    """Which hits (ids: inst, inst prim, geom, prim of an instanced top level) are on a sphere gprim."""
    out = np.zeros(len(ids), bool)
    for k, (inst, row, geom, _) in enumerate(ids):
        if inst != INVALID:
            proto = S.in_proto[S.grp_base[inst] + row]
            out[k] = S.gp_kind[S.pr_geom_gp[S.pr_geom_off[proto] + geom]] == GP_SPHERE
    return out


def _planar(center, back_normal, size=0.8, radiance=(4.0, 4.0, 4.0)) -> D.Light:
    """A rect light at `center` emitting along -back_normal (its local +Z)."""
    n = np.asarray(back_normal, np.float64) / np.linalg.norm(back_normal)
    t = np.cross(n, (0.0, 0.0, 1.0) if abs(n[2]) < 0.9 else (1.0, 0.0, 0.0))
    t /= np.linalg.norm(t)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = t, np.cross(n, t), n, center
    return D.Light(path='/rect', type=D.RECT, matrix=m, radiance=tuple(radiance), width=size, height=size)


def _facing_scene(flat: bool):
    """A floor and a box (placed twice unless `flat`), rect lights facing down (two, and one 20 degrees
    off), sideways (one) and tilted by 47 degrees (one), a sphere light."""
    boxes = [translate(2.5, 0.0, 0.0)] + ([] if flat else [translate(-2.5, 0.0, 0.0)])
    desc = _scene(np.eye(4), boxes)
    desc.camera.matrix = look_at((0.5, 9.0, 4.0), (0.0, 0.5, 0.0))              # (steeply down on the lights)
    desc.lights[:] = [_planar((0.0, 3.0, 0.0), (0, 1, 0)), _planar((1.5, 3.5, -1.0), (0, 1, 0)),
                      _planar((-1.5, 3.2, -1.5), (0.36, 1.0, 0.0)),          # 20 degrees off: the same group
                      _planar((-3.6, 1.6, 0.0), (-1, 0, 0)), _planar((2.0, 2.0, 2.0), (1.0, 1.0, 0.4)),
                      D.Light(path='/ball', type=D.SPHERE, matrix=translate(-1.0, 2.5, 1.5), radiance=(2.0,) * 3,
                              radius=0.3)]
    return desc


@numba.njit(cache=False)
def _trace_masked(scene_handle, L, origins, dirs, masked, out_ids, out_t):
    """As `_trace` (hits fixed by `placed_hit`), with every ray's mask `shape_mask(L, d)` if `masked`."""
    f, u = new_ray_buffer()
    for r in range(origins.shape[0]):
        o = (origins[r, 0], origins[r, 1], origins[r, 2])
        d = (dirs[r, 0], dirs[r, 1], dirs[r, 2])
        hit = intersect1_masked(scene_handle, f, u, (o, d), 0.0, np.inf, 0.0, shape_mask(L, d) if masked else MASK_ALL)
        placed_hit(L, u)
        out_ids[r, 0] = u[INST_ID] if hit else INVALID
        out_ids[r, 1] = u[INST_PRIM_ID] if hit else INVALID
        out_ids[r, 2] = u[GEOM_ID]
        out_ids[r, 3] = u[PRIM_ID] if hit else INVALID
        out_t[r] = f[TFAR] if hit else np.inf


@pytest.mark.parametrize('flat', [False, True])
def test_a_ray_skips_exactly_the_light_shapes_it_sees_from_behind(flat):
    """Rays from points all over the scene, most towards a light, traced with the path integrator's ray mask
    (`light_sampling.shape_mask`) and with every geometry's: where the unmasked ray's first hit is a planar
    light's back (the side `hit_shape` gives nothing), the masked ray does not stop there unless the
    ray is within the bound of that light's group (a cone of normals: there the kernel continues it past
    the back as before); every other first hit (surfaces, the sphere light, planar lights from the emitting side) is the same hit at the
    same distance.  The planar lights are grouped by facing (down, sideways, tilted: three groups)."""
    desc = _facing_scene(flat)
    with Renderer(desc) as r:
        L = r.path_lights()
        assert len(L.facing) == 3 and (L.direct.shape[0] > 0) == flat
        rng = np.random.default_rng(5)
        n = 40000
        p = rng.uniform([-5, 0.05, -5], [5, 4.5, 5], (n, 3))
        aim = np.array([l.matrix[:3, 3] for l in desc.lights])[rng.integers(0, 6, n)] + rng.uniform(-0.5, 0.5, (n, 3))
        d = np.where(rng.random(n)[:, None] < 0.7, aim - p, rng.normal(size=(n, 3)))   # (most towards a light)
        o = (p - r.built.origin).astype(np.float32)
        d = (d / np.linalg.norm(d, axis=1)[:, None]).astype(np.float32)
        out = {}
        for masked in (False, True):
            ids, t = np.zeros((n, 4), np.uint32), np.zeros(n)
            _trace_masked(r.path_scene(), L, o, d, masked, ids, t)
            out[masked] = ids, t
        (ids0, t0), (ids1, t1) = out[False], out[True]
        light = (ids0[:, 0] >= L.light_group) & (ids0[:, 0] != INVALID)
        k = np.full(n, -1)
        k[light] = L.prim_light[L.geom_off[ids0[light, 2]] + ids0[light, 3]]
        planar = light & (k < 5)
        backs = np.array([_back(desc.lights[j].matrix) for j in range(5)])
        behind = planar & (np.einsum('ij,ij->i', d.astype(np.float64), backs[np.clip(k, 0, 4)]) <= 0.0)
        assert behind.sum() > 1000 and (planar & ~behind).sum() > 300 and (light & ~planar).sum() > 100
        keep = ~behind
        np.testing.assert_array_equal(ids1[keep], ids0[keep])
        np.testing.assert_array_equal(t1[keep], t0[keep])
        skipped = t1[behind] > t0[behind]                           # past the back it was stopped at ...
        same = (t1[behind] == t0[behind]) & np.all(ids1[behind] == ids0[behind], axis=1)
        assert np.all(skipped | same) and skipped.mean() > 0.6      # ... or, within a group's cone, not
        # every member of the group leaves the ray out, so a ray within a group's bound meets its backs


def _back(m):
    n = np.cross(m[:3, 0], m[:3, 1])
    n /= np.linalg.norm(n)
    return -n if np.dot(n, m[:3, 2]) < 0 else n


def test_facing_groups_bound_every_member_and_the_rest_meet_every_ray():
    """`facing_groups`: each normal within the angle of its group's axis; a direction that can meet a
    member's emitting side (d . n > 0) is never left out of its group (d . axis > the row's bound);
    beyond the number of groups the rest are in none (-1: the group every ray meets)."""
    rng = np.random.default_rng(2)
    normals = rng.normal(size=(300, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    of, facing = facing_groups(list(normals), groups=8, angle=math.radians(30.0))
    assert facing.shape == (8, 4) and (of == -1).sum() > 50 and np.all(of < 8)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    for g in range(8):
        members = normals[of == g]
        assert len(members) > 0 and np.all(members @ facing[g, :3] >= math.cos(math.radians(30.0)) - 1e-12)
        sees = (d @ members.T > 0.0).any(axis=1)
        kept = d @ facing[g, :3] > facing[g, 3]
        assert np.all(kept[sees]) and (~kept).sum() > 1000            # (and it does leave rays out)
    same, facing1 = facing_groups([np.array([0.0, 1.0, 0.0])] * 3)
    assert same.tolist() == [0, 0, 0] and facing1[0, 3] == pytest.approx(-1e-7, abs=1e-12)


def test_a_camera_above_ceiling_lights_renders_them_unchanged_without_meeting_them(monkeypatch):
    """The whole render: path images with and without facing groups are identical, and with them the
    camera and BSDF rays that look at the rect lights' backs are not continued past them (fewer
    secondary queries)."""
    desc = _facing_scene(False)
    res = {}
    for groups in (FACING_GROUPS, 0):
        monkeypatch.setattr(light_selection, 'FACING_GROUPS', groups)
        with Renderer(desc) as r:
            assert len(r.path_lights().facing) == (3 if groups else 0)
            res[groups] = r.render(RenderOptions(width=48, height=36, spp=4, integrator='path', max_depth=3))
    a, b = res[FACING_GROUPS], res[0]
    np.testing.assert_array_equal(a.image, b.image)
    assert a.stats.rays_secondary < 0.97 * b.stats.rays_secondary and a.image.mean() > 0.01


@pytest.mark.parametrize('tube', [False, True])
def test_spheres_and_cylinder_lights_are_user_geometry(tube):
    """The path top level tests spheres in float64 (user geometry): the ball's rows are kept for Embree's
    callbacks, and its hits are at the exact root of the sphere, nearer it than the cook top level's
    (Embree's float32 spheres).  A cylinder light's shape is user geometry too (the open cylinder: no
    Embree curve beside the user geometry, which together Embree traverses 1.6x slower)."""
    desc = _scene(np.eye(4), [translate(2.5, 0.0, 0.0)])           # placed once each: traced flat
    if tube:
        desc.lights.append(D.Light(path='/tube', type=D.CYLINDER, matrix=translate(2.0, 3.0, -2.0),
                                   radiance=(3.0,) * 3, radius=0.1, length=1.0))
    with Renderer(desc) as r:
        r.path_lights()
        assert r._path_top.group_geom_ids == ()
        assert len(r._path_top.keep) == 1 + tube                         # the ball's rows, the tube's
    out, L, S = _compare(desc)
    (cook, tc), (path, tp) = out['cook'], out['path']
    ball = (path[:, 0] == 0) & (path[:, 1] == 1) & (path[:, 2] == 1)     # row 1 (floor and ball), geometry 1
    assert ball.sum() > 20
    np.testing.assert_array_equal(path[ball], cook[ball])
    o, d = _rays()
    eye = np.array([0.5, 5.0, 9.0])                                     # the rays are camera-relative
    exact = _exact_ball_t(o[ball] + eye, d[ball], (-2.0, 0.7, 1.0), 0.7)
    np.testing.assert_allclose(tp[ball], exact, rtol=3e-7)
    assert np.abs(tp[ball] - exact).max() <= np.abs(tc[ball] - exact).max()


def _exact_ball_t(o, d, c, r):
    oc = o.astype(np.float64) - c
    d = d.astype(np.float64)
    b = np.sum(oc * d, 1)
    disc = b * b - np.sum(d * d, 1) * (np.sum(oc * oc, 1) - r * r)
    return (-b - np.sqrt(disc)) / np.sum(d * d, 1)


def test_a_shots_next_frame_takes_the_path_prototypes_over():
    """The prototypes built again for the path integrator (a container with a sphere) are built once: the
    next frame of a shot (`Renderer(reuse=)`, the same containers, placements moved) takes them over with
    the others, and its hits are those of its own cook top level (the ids; the ball's distance to float32)."""
    first = _scene(np.eye(4), [translate(2.5, 0.0, 0.0), translate(-2.5, 0.0, 0.0)])
    second = _scene(translate(0.2, 0.0, 0.0), [translate(2.0, 0.0, 0.0), translate(-3.0, 0.0, 0.0)])
    r1 = Renderer(first)
    r1.path_scene()
    own = dict(r1.built.path_prototypes)
    assert list(own) == [0]                                              # the floor-and-ball container
    with Renderer(second, reuse=r1) as r2:
        L = r2.path_lights()
        assert r2.built.path_prototypes == own                          # the same Embree scenes, not rebuilt
        o, d = _rays()
        out = {}
        for name, handle in (('cook', r2.built.handle), ('path', r2.path_scene())):
            ids, t = np.zeros((len(o), 4), np.uint32), np.zeros(len(o))
            _trace(handle, L, o, d, True, ids, t)
            out[name] = ids, t
        (cook, tc), (path, tp) = out['cook'], out['path']
        light = path[:, 0] == L.light_group
        np.testing.assert_array_equal(path[~light], cook[~light])
        np.testing.assert_allclose(tp[~light], tc[~light], rtol=1e-6)
        assert (_on_spheres(r2.built.data, cook) & ~light).sum() > 20
