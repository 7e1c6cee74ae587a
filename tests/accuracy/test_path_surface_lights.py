"""Emissive surfaces are lights of the path integrator (host/surface_lights.py): an emissive quad mesh
lights a Lambert floor as a RectLight of the same size, placement and radiance does (Lambert's polygon
formula), by light sampling alone, BSDF sampling alone and MIS; MIS beats BSDF sampling alone when an
emissive mesh is the only light; every placement of an instanced emissive prototype is a light of its
own; an emissive ellipsoid and a see-through emissive quad (of one opacity, or of an opacity per corner) light the
floor as closed forms say."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer import test_integrator as ti
from tests.renderer.handmade import ortho_down, quad, rect_light, scene, translate

N, WIDTH, H, A, B, LR = 24, 4.0, 1.0, 1.2, 0.8, 2.0
FLOOR = D.Material('/floor', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))


def emitter(a=A, b=B, y=H, material=1, path='/emitter', x=0.0):
    """An a x b quad mesh in the plane y, facing down (its winding's normal is -Y)."""
    pts = np.array([[x - a / 2, y, -b / 2], [x + a / 2, y, -b / 2], [x + a / 2, y, b / 2], [x - a / 2, y, b / 2]])
    return D.Mesh(path=path, points=pts, triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=material)


def glow(radiance=LR):
    """Emits `radiance`, reflects nothing."""
    return D.Material('/glow', model=D.LAMBERTIAN, diffuse=(0.0, 0.0, 0.0), emission=(radiance,) * 3)


def mesh_scene(a=A, b=B):
    return scene([D.Container('/', meshes=[quad(40.0), emitter(a, b)])], [FLOOR, glow()], [],
                 ortho_down(width=WIDTH), width=N, height=N)


def rect_scene():
    return scene([D.Container('/', meshes=[quad(40.0)])], [FLOOR], [rect_light((0.0, H, 0.0), A, B, (LR,) * 3)],
                 ortho_down(width=WIDTH), width=N, height=N)


def polygon_reference(a=A, b=B):
    corners = [(-a / 2, H, -b / 2), (a / 2, H, -b / 2), (a / 2, H, b / 2), (-a / 2, H, b / 2)]
    return ti.pixel_average(lambda x, z: 0.5 / np.pi * ti.polygon_irradiance(x, z, corners, LR), N, WIDTH, sub=8)


def _beside(a=A, b=B):
    """Pixels the emitter (seen from above, where the mesh emits too and hides the floor) does not cover."""
    c = ti.pixel_centers(N, WIDTH)
    half = 0.5 * WIDTH / N
    X, Z = np.meshgrid(c, c)
    return (np.abs(X) > a / 2 + half) | (np.abs(Z) > b / 2 + half)


def _render(desc, spp, strategy='mis', seed=0, sampler='sobol'):
    with Renderer(desc) as r:
        return r.render(RenderOptions(spp=spp, integrator='path', strategy=strategy, filter='box', seed=seed,
                                      sampler=sampler)).image[..., 0].astype(np.float64)


def _check_strategies(desc, ref, keep, mis_beats_bsdf=True):
    """Light sampling alone, BSDF sampling alone and MIS each converge to `ref` on the pixels `keep`
    (mean within 1 %, RMSE under 3 % of its peak); with `mis_beats_bsdf`, MIS's error at 16 samples is
    under half of BSDF sampling's."""
    for strategy, spp in (('mis', 512), ('nee', 512), ('bsdf', 4096)):
        img = _render(desc, spp, strategy)
        assert img[keep].mean() == pytest.approx(ref[keep].mean(), rel=0.01), (strategy, img[keep].mean(), ref[keep].mean())
        assert np.sqrt(np.mean((img[keep] - ref[keep]) ** 2)) < 0.03 * ref.max(), strategy
    if mis_beats_bsdf:
        rmse = {s: np.sqrt(np.mean((_render(desc, 16, s, sampler='independent')[keep] - ref[keep]) ** 2))
                for s in ('mis', 'bsdf')}
        assert rmse['mis'] < 0.5 * rmse['bsdf'], rmse


@pytest.mark.parametrize('strategy', ['mis', 'nee', 'bsdf'])
def test_an_emissive_quad_lights_the_floor_as_a_rect_light(strategy):
    ref = polygon_reference()
    keep = _beside()
    mesh = _render(mesh_scene(), 2048 if strategy == 'bsdf' else 256, strategy)
    rect = _render(rect_scene(), 256)
    assert rect[keep].mean() == pytest.approx(ref[keep].mean(), rel=0.005)
    assert mesh[keep].mean() == pytest.approx(ref[keep].mean(), rel=0.01), (mesh[keep].mean(), ref[keep].mean())
    err = mesh[keep] - ref[keep]
    assert np.sqrt(np.mean(err ** 2)) < 0.02 * ref.max(), np.sqrt(np.mean(err ** 2))


def test_mis_beats_bsdf_sampling_when_an_emissive_mesh_is_the_only_light():
    a, b = 0.3, 0.3
    ref = polygon_reference(a, b)
    keep = _beside(a, b)
    desc = mesh_scene(a, b)
    rmse = {s: np.sqrt(np.mean((_render(desc, 16, s, sampler='independent')[keep] - ref[keep]) ** 2))
            for s in ('mis', 'bsdf')}
    assert rmse['mis'] < 0.5 * rmse['bsdf'], rmse


def test_each_placement_of_an_instanced_emissive_prototype_is_a_light():
    """Two placements mirrored about x = 0 light the floor as one placement and its mirror image do."""
    proto = D.Container('/proto', meshes=[emitter(0.6, 0.6, x=0.0, material=1)])
    floor = D.Container('/', meshes=[quad(40.0)])

    def placed(xs):
        inst = D.Instances(container=np.array([0] + [1] * len(xs), np.int32),
                           matrices=np.array([np.eye(4)] + [translate(x, 0.0, 0.0) for x in xs])[:, None],
                           material_set=np.zeros(1 + len(xs), np.int32), material_sets=[()])
        return scene([floor, proto], [FLOOR, glow()], [], ortho_down(width=WIDTH), instances=inst, width=N, height=N)

    one = _render(placed([0.8]), 512)
    two = _render(placed([0.8, -0.8]), 512)
    nee = _render(placed([0.8, -0.8]), 512, 'nee')
    X, Z = np.meshgrid(ti.pixel_centers(N, WIDTH), ti.pixel_centers(N, WIDTH))
    px = WIDTH / N
    keep = ~((np.abs(Z) < 0.3 + px) & (np.abs(np.abs(X) - 0.8) < 0.3 + px))   # what the emitters hide from the camera
    expected = one + one[:, ::-1]
    for img in (two, nee):
        assert img[keep].mean() == pytest.approx(expected[keep].mean(), rel=0.01)
        assert np.sqrt(np.mean((img[keep] - expected[keep]) ** 2)) < 0.03 * expected.max()
    mid = slice(N // 2 - 1, N // 2 + 1)                                  # the two columns either side of x = 0
    assert two[:, mid].mean() == pytest.approx(2 * one[:, mid].mean(), rel=0.01)


def test_an_emissive_sphere_lights_the_floor_as_a_sphere_light():
    """A black emissive sphere (a light by area sampling of its surface) against a SphereLight of the same
    radius and radiance (sampled in the cone it subtends): the floor beside the sphere agrees."""
    r, c, le = 0.3, (0.4, 0.9, -0.2), 3.0
    ball = D.Sphere(path='/ball', radius=r, matrix=translate(*c), material=1)
    lit = scene([D.Container('/', meshes=[quad(40.0)], spheres=[ball])], [FLOOR, glow(le)], [],
                ortho_down(width=WIDTH), width=N, height=N)
    bulb = scene([D.Container('/', meshes=[quad(40.0)])], [FLOOR],
                 [D.Light(path='/bulb', type=D.SPHERE, matrix=translate(*c), radiance=(le,) * 3, radius=r)],
                 ortho_down(width=WIDTH), width=N, height=N)
    X, Z = np.meshgrid(ti.pixel_centers(N, WIDTH), ti.pixel_centers(N, WIDTH))
    keep = (X - c[0]) ** 2 + (Z - c[2]) ** 2 > (r + WIDTH / N) ** 2              # the camera sees the floor
    _check_strategies(lit, _render(bulb, 512), keep, mis_beats_bsdf=False)


def ellipsoid_irradiance(x, z, centre, axes, radiance, k=512):
    """Irradiance at the floor points (x, 0, z) (normal +Y) from an ellipsoid centre + axes n (n unit) of
    uniform radiance, by Lambert's polygon formula over its silhouette: the points where the ellipsoid's
    tangent plane holds the receiver - in the unit sphere's frame (q = axes^-1 (p - centre)) the circle
    n . q = 1, of centre q / |q|^2 and radius sqrt(1 - 1 / |q|^2), mapped back by the axes (k vertices)."""
    p = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], 1)
    q = np.linalg.solve(axes, (p - centre).T).T
    s = (q * q).sum(1)
    e = np.where(np.abs(q[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(q, e)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(q / np.sqrt(s)[:, None], u)
    t = 2 * np.pi * np.arange(k) / k
    circle = (q / s[:, None])[:, None] + np.sqrt(1 - 1 / s)[:, None, None] * (
        np.cos(t)[None, :, None] * u[:, None] + np.sin(t)[None, :, None] * v[:, None])
    r = circle @ axes.T + centre - p[:, None]                                     # (points, k, 3)
    a, b = r, np.roll(r, -1, axis=1)
    cr = np.cross(a, b)
    ang = np.arccos(np.clip((a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1), -1, 1))
    E = (ang * cr[..., 1] / np.linalg.norm(cr, axis=-1)).sum(1)
    return (radiance * np.abs(E) / 2).reshape(x.shape)


def test_an_emissive_ellipsoid_lights_the_floor_as_lamberts_formula_says():
    """A black emissive sphere placed by a rotation and a non-uniform scale (an ellipsoid light, drawn
    uniformly in its unit sphere with the density of its area element) lights the Lambert floor with the
    irradiance of its silhouette (Lambert's formula): light sampling alone, BSDF sampling alone and MIS;
    MIS with less error than BSDF sampling alone at equal samples."""
    le, c = 3.0, np.array([0.3, 0.9, -0.2])
    t = np.radians(30.0)
    rot = np.array([[np.cos(t), 0.0, np.sin(t)], [0.0, 1.0, 0.0], [-np.sin(t), 0.0, np.cos(t)]])
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag([0.6, 0.25, 0.3])                               # semi-axes of the unit sphere
    m[:3, 3] = c
    egg = D.Sphere(path='/egg', radius=1.0, matrix=m, material=1)
    desc = scene([D.Container('/', meshes=[quad(40.0)], spheres=[egg])], [FLOOR, glow(le)], [],
                 ortho_down(width=WIDTH), width=N, height=N)
    ref = ti.pixel_average(lambda x, z: 0.5 / np.pi * ellipsoid_irradiance(x, z, c, m[:3, :3], le), N, WIDTH, sub=4)
    X, Z = np.meshgrid(ti.pixel_centers(N, WIDTH), ti.pixel_centers(N, WIDTH))
    extent = np.sqrt((m[:3, :3] ** 2).sum(1)) + WIDTH / N                    # the ellipsoid's box, a pixel more
    keep = (np.abs(X - c[0]) > extent[0]) | (np.abs(Z - c[2]) > extent[2])  # the camera sees the floor
    _check_strategies(desc, ref, keep)


@pytest.mark.parametrize('opacity', [0.5, 0.2])
def test_a_see_through_emissive_quad_lights_the_floor_with_its_opacity_times_its_emission(opacity):
    """An emissive UsdPreviewSurface quad of opacity a (found by rays with probability a; reflecting
    nothing: no diffuse, a specular workflow of colour 0) lights the floor like a rect light of a times its
    emission (Lambert's polygon formula), by light sampling alone, BSDF sampling alone and MIS; MIS with
    less error than BSDF sampling alone."""
    veil = D.Material('/veil', model=D.PREVIEW_SURFACE, diffuse=(0.0, 0.0, 0.0), use_specular_workflow=True,
                      emission=(LR,) * 3, opacity=opacity)
    desc = scene([D.Container('/', meshes=[quad(40.0), emitter()])], [FLOOR, veil], [], ortho_down(width=WIDTH),
                 width=N, height=N)
    ref = opacity * polygon_reference()
    keep = _beside()
    _check_strategies(desc, ref, keep)


def test_an_emissive_quad_of_per_corner_opacities_lights_the_floor_as_two_triangles_of_those_opacities():
    """The see-through quad with its opacity kept per corner instead (a varying displayOpacity that its material
    reads: `Material.vertex_opacity`, the A of `Mesh.colors`), 0.3 on one triangle and 0.8 on the other: it lights
    the floor as two triangle lights of those opacities times its emission, by light sampling alone (which weighs
    each point by its opacity there), BSDF sampling alone and MIS."""
    veil = D.Material('/veil', model=D.PREVIEW_SURFACE, diffuse=(0.0, 0.0, 0.0), use_specular_workflow=True,
                      emission=(LR,) * 3, vertex_opacity=True)
    card = emitter()
    alpha = np.array([0.3, 0.8])
    card.colors = np.concatenate([np.ones((2, 3, 3)), np.repeat(alpha[:, None, None], 3, 1)], 2).astype(np.float32)
    desc = scene([D.Container('/', meshes=[quad(40.0), card])], [FLOOR, veil], [], ortho_down(width=WIDTH),
                 width=N, height=N)
    ref = sum(a * ti.pixel_average(lambda x, z, t=tri: 0.5 / np.pi * ti.polygon_irradiance(
        x, z, [tuple(card.points[i]) for i in t], LR), N, WIDTH, sub=8) for a, tri in zip(alpha, card.triangles))
    _check_strategies(desc, ref, _beside())


def test_a_moving_emissive_quad_lights_the_floor_as_its_shutter_average():
    """An emissive quad placed by a matrix that moves and grows over the shutter (two motion samples,
    lerped: its corners move linearly, its area grows 1.8x) lights the floor with the time average of
    Lambert's polygon formula over its positions, by light sampling alone (each sample placed by Embree's
    matrix at the path's time, its density divided by that matrix's area scale), BSDF sampling alone and
    MIS; MIS with less error than BSDF sampling alone."""
    m1 = translate(0.5, 0.0, 0.0) @ np.diag([1.5, 1.0, 1.2, 1.0])
    mats = np.stack([np.stack([np.eye(4), np.eye(4)]), np.stack([translate(-0.4, 0.0, 0.0), m1])])
    inst = D.Instances(container=np.array([0, 1], np.int32), matrices=mats, material_set=np.zeros(2, np.int32),
                       material_sets=[()])
    desc = scene([D.Container('/', meshes=[quad(40.0)]), D.Container('/panel', meshes=[emitter(material=1)])],
                 [FLOOR, glow()], [], ortho_down(width=WIDTH), instances=inst, width=N, height=N)
    corners = np.array([(-A / 2, H, -B / 2, 1.0), (A / 2, H, -B / 2, 1.0), (A / 2, H, B / 2, 1.0), (-A / 2, H, B / 2, 1.0)])
    times = (np.arange(48) + 0.5) / 48
    placed = [((1 - t) * mats[1, 0] + t * mats[1, 1]) @ corners.T for t in times]
    ref = np.mean([ti.pixel_average(lambda x, z: 0.5 / np.pi * ti.polygon_irradiance(x, z, list(c[:3].T), LR), N, WIDTH,
                                    sub=2) for c in placed], 0)
    X, Z = np.meshgrid(ti.pixel_centers(N, WIDTH), ti.pixel_centers(N, WIDTH))
    lo = np.min([c[:3].min(1) for c in placed], 0) - WIDTH / N
    hi = np.max([c[:3].max(1) for c in placed], 0) + WIDTH / N
    keep = (X < lo[0]) | (X > hi[0]) | (Z < lo[2]) | (Z > hi[2])            # the camera never sees the quad
    _check_strategies(desc, ref, keep)


def test_a_moving_emissive_sphere_lights_the_floor_as_its_shutter_average():
    """A black emissive sphere whose placement moves and stretches over the shutter (an ellipsoid at each
    time) lights the floor with the time average of Lambert's formula over its silhouettes, by light
    sampling alone, BSDF sampling alone and MIS."""
    r, le = 0.3, 3.0
    m1 = translate(0.6, 1.0, -0.2) @ np.diag([1.4, 1.0, 1.0, 1.0])
    mats = np.stack([np.stack([np.eye(4), np.eye(4)]), np.stack([translate(-0.3, 0.8, -0.2), m1])])
    inst = D.Instances(container=np.array([0, 1], np.int32), matrices=mats, material_set=np.zeros(2, np.int32),
                       material_sets=[()])
    ball = D.Sphere(path='/ball', radius=r, matrix=np.eye(4), material=1)
    desc = scene([D.Container('/', meshes=[quad(40.0)]), D.Container('/ball', spheres=[ball])],
                 [FLOOR, glow(le)], [], ortho_down(width=WIDTH), instances=inst, width=N, height=N)
    times = (np.arange(32) + 0.5) / 32
    placed = [(1 - t) * mats[1, 0] + t * mats[1, 1] for t in times]
    ref = np.mean([ti.pixel_average(lambda x, z: 0.5 / np.pi * ellipsoid_irradiance(x, z, m[:3, 3], r * m[:3, :3], le),
                                    N, WIDTH, sub=2) for m in placed], 0)
    X, Z = np.meshgrid(ti.pixel_centers(N, WIDTH), ti.pixel_centers(N, WIDTH))
    keep = (X < -0.3 - r - WIDTH / N) | (X > 0.6 + 1.4 * r + WIDTH / N) | (np.abs(Z + 0.2) > r + WIDTH / N)
    _check_strategies(desc, ref, keep, mis_beats_bsdf=False)
