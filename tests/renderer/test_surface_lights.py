"""Emissive surfaces as lights of the path integrator (host/surface_lights.py): a mesh with UsdLux
MeshLightAPI emits; one light per static placement of an emissive mesh or sphere (PointInstancer
instances included), with its area, triangle CDF and the map from a hit to its light; a sphere placed by
a matrix that is no similarity is an ellipsoid light, sampled with the density of its area element; a
see-through material is a light of its average emission; a moving placement is a light placed at a ray's
time."""
from contextlib import contextmanager

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.light_selection import path_lights
from rtc.renderer.host.light_tree import leaf_record
from rtc.renderer.kernel.light_tree import SPLIT_BELOW, light_pmf
from rtc.renderer.kernel.tables import (CURVE_CAP, CURVE_LINEAR, SLF_AREA, SLF_AXES, SLF_CENTER, SLF_INV, SLF_RAD,
                                        SLF_RADIUS, SLI_COUNT, SLI_CURVE, SLI_EMISSION_TEX, SLI_ELLIPSOID, SLI_FIRST,
                                        SLI_INST, SLI_INST_PRIM, SLI_MOVING, SURFACE_LIGHT_F, T_C)
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import look_at, quad, scene, translate


def _stage():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, 'Y')
    UsdGeom.Xform.Define(stage, '/World')
    return stage


def _quad_mesh(stage, path, size=(2.0, 1.0)):
    mesh = UsdGeom.Mesh.Define(stage, path)
    a, b = size[0] / 2, size[1] / 2
    mesh.CreatePointsAttr([(-a, 0, -b), (a, 0, -b), (a, 0, b), (-a, 0, b)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    return mesh


def test_mesh_light_api_makes_the_mesh_emit():
    stage = _stage()
    mesh = _quad_mesh(stage, '/World/Panel')
    mesh.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))          # world area 4 x 1
    UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
    api = UsdLux.LightAPI(mesh.GetPrim())
    api.CreateIntensityAttr(4.0); api.CreateExposureAttr(1.0); api.CreateColorAttr((1.0, 0.5, 0.5))
    api.CreateNormalizeAttr(True)
    _quad_mesh(stage, '/World/Plain')
    desc = read_stage(stage)
    meshes = {m.path: m for c in desc.containers for m in c.meshes}
    assert desc.materials[meshes['/World/Panel'].material].emission == pytest.approx((2.0, 1.0, 1.0))  # 8 / 4
    assert desc.materials[meshes['/World/Plain'].material].emission == (0.0, 0.0, 0.0)
    assert not desc.lights                              # lit by the mesh: no default lights


def _emissive_material(stage, path, colour=(1.0, 2.0, 3.0)):
    mat = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + '/Surface')
    shader.CreateIdAttr('UsdPreviewSurface')
    shader.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*colour))
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), 'surface')
    return mat


@contextmanager
def _path_lights(desc):
    """(built scene, PathLights) of desc, closed on leaving."""
    built = build(desc)
    try:
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups), data=built.data)
        yield built, L
    finally:
        built.close()


def test_every_point_instancer_instance_of_an_emissive_prototype_is_a_light():
    stage = _stage()
    pi = UsdGeom.PointInstancer.Define(stage, '/World/PI')
    proto = _quad_mesh(stage, '/World/PI/Protos/Panel')
    UsdShade.MaterialBindingAPI.Apply(proto.GetPrim()).Bind(_emissive_material(stage, '/World/Glow'))
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (3, 0, 0), (0, 2, 0)])
    UsdLux.SphereLight.Define(stage, '/World/Bulb').CreateRadiusAttr(0.1)
    desc = read_stage(stage)
    with _path_lights(desc) as (built, L):
        assert L.n_surface == 3 and L.surface_first == 1
        np.testing.assert_allclose(L.sl_f[:, SLF_AREA], 2.0)
        np.testing.assert_allclose(L.sl_f[:, SLF_RAD:SLF_RAD + 3], [(1.0, 2.0, 3.0)] * 3)
        assert np.all(L.depth[1:4] >= 0)                                  # in the light tree
        p, n = (0.0, 5.0, -20.0), (0.0, -1.0, 0.0)
        expected = sum(light_pmf(L, p, n, k) for k in range(4))       # samples per vertex: one, and up
        assert 1.0 - 1e-9 <= expected < 3.0                            # to two more where the tree splits


def _scene(meshes, materials, instances=None, lights=()):
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0)))
    return scene([D.Container('/', meshes=meshes)], materials, list(lights), cam, instances=instances)


def test_surface_light_tables():
    glow = D.Material('/glow', model=D.LAMBERTIAN, emission=(2.0, 2.0, 2.0))
    panel = D.Mesh(path='/panel', points=np.array([[0, 1, 0], [3, 1, 0], [0, 1, 1], [3, 1, 1]], np.float64),
                   triangles=np.array([[0, 1, 2], [1, 3, 2]], np.int32), material=1)
    small = D.Mesh(path='/small', points=np.array([[0, 2, 0], [1, 2, 0], [0, 2, 1]], np.float64),
                   triangles=np.array([[0, 1, 2]], np.int32), material=1)
    desc = _scene([quad(10.0), panel, small], [D.Material('/floor'), glow])
    with _path_lights(desc) as (built, L):
        assert L.n_surface == 2 and L.surface_first == 0
        areas = sorted(L.sl_f[:, SLF_AREA])
        assert areas == pytest.approx([0.5, 3.0])
        big = int(np.argmax(L.sl_f[:, SLF_AREA]))
        first, count = L.sl_i[big, SLI_FIRST], L.sl_i[big, SLI_COUNT]
        assert count == 2
        np.testing.assert_allclose(L.sl_cdf[first:first + 2], [0.5, 1.0])
        origin = desc.camera.matrix[:3, 3]                                 # tables are camera-relative
        np.testing.assert_allclose(L.sl_tri[first:first + 2] + origin, panel.points[panel.triangles], atol=1e-6)
        # the hit map: row 0 (the only placement), gprim slots 1 and 2 are the lights, the floor none
        base = L.sl_row[0]
        assert base >= 0 and L.sl_idx[base] == -1 and sorted(L.sl_idx[base + 1:base + 3]) == [0, 1]
        assert L.sl_idx[base + 1] == big
        # the tree: a receiver below sees both; the big one outshines the small one, so it is in every light
        # sample and the small one in a side sample with its share (`light_tree.choose_lights`)
        p = tuple(np.array([0.5, 0.0, 0.5]) - origin)
        pm = sorted(light_pmf(L, p, (0.0, 1.0, 0.0), k) for k in (0, 1))
        assert pm[1] == 1.0 and 0.0 < pm[0] <= SPLIT_BELOW


def test_emissive_spheres_and_ellipsoids_are_lights_with_their_placement():
    glow = D.Material('/glow', model=D.LAMBERTIAN, emission=(1.0, 1.0, 1.0))
    ball = D.Sphere(path='/ball', radius=0.5, matrix=translate(0, 1, 0), material=1)
    egg = D.Sphere(path='/egg', radius=0.5, matrix=translate(0, 3, 0) @ np.diag([1.0, 2.0, 1.0, 1.0]), material=1)
    m = np.eye(4)
    m[:3, :3] *= 2.0
    m[:3, 3] = (1.0, 0.0, 0.0)
    desc = scene([D.Container('/', meshes=[quad(4.0)]), D.Container('/balls', spheres=[ball, egg])],
                 [D.Material('/floor'), glow], [],
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))),
                 instances=D.Instances(container=np.array([0, 1], np.int32), matrices=np.array([np.eye(4), m])[:, None],
                                       material_set=np.zeros(2, np.int32), material_sets=[()]))
    origin = desc.camera.matrix[:3, 3]
    with _path_lights(desc) as (built, L):
        assert L.n_surface == 2 and np.all(L.sl_i[:2, SLI_COUNT] == 0) and np.all(L.depth[:2] >= 0)
        b, e = (0, 1) if L.sl_i[0, SLI_ELLIPSOID] == 0 else (1, 0)
        assert L.sl_i[b, SLI_ELLIPSOID] == 0 and L.sl_i[e, SLI_ELLIPSOID] == 1
        assert L.sl_f[b, SLF_RADIUS] == pytest.approx(1.0) and L.sl_f[b, SLF_AREA] == pytest.approx(4 * np.pi)
        np.testing.assert_allclose(L.sl_f[b, SLF_CENTER:SLF_CENTER + 3] + origin, (1.0, 2.0, 0.0), atol=1e-9)
        # the egg: semi-axes 0.5 x (1, 2, 1) x the placement's 2, centred at 2 (0, 3, 0) + (1, 0, 0)
        np.testing.assert_allclose(L.sl_f[e, SLF_CENTER:SLF_CENTER + 3] + origin, (1.0, 6.0, 0.0), atol=1e-9)
        np.testing.assert_allclose(L.sl_f[e, SLF_AXES:SLF_AXES + 9], np.diag([1.0, 2.0, 1.0]).ravel(), atol=1e-12)
        np.testing.assert_allclose(L.sl_f[e, SLF_INV:SLF_INV + 9], np.diag([1.0, 0.5, 1.0]).ravel(), atol=1e-12)
        assert L.sl_f[e, SLF_AREA] == pytest.approx(4 * np.pi * 2.0)        # 4 pi |det A|


def _spheroid_area(a, c):
    """Surface area of the spheroid of equatorial semi-axis a and polar semi-axis c (closed forms)."""
    if c > a:
        e = np.sqrt(1 - a * a / (c * c))
        return 2 * np.pi * a * a * (1 + c / (a * e) * np.arcsin(e))
    e = np.sqrt(1 - c * c / (a * a))
    return 2 * np.pi * a * a + np.pi * c * c / e * np.log((1 + e) / (1 - e))


@pytest.mark.parametrize('a, c', [(1.0, 2.0), (2.0, 0.5)])
def test_ellipsoid_light_samples_have_the_density_of_their_area(a, c):
    """Points of an ellipsoid light drawn uniformly in n (centre + A n), each with 1 / its density per unit
    area: their mean is the ellipsoid's area (the closed forms of a prolate and an oblate spheroid, turned
    by a rotation so that A is no diagonal), and a hit at a drawn point gets the density it was drawn with
    (the MIS weight of a BSDF-sampled ray that finds it)."""
    from collections import namedtuple
    from rtc.renderer.kernel.surface_lights import _ellipsoid_area_at, _ellipsoid_point
    t = np.radians(35.0)
    rot = np.array([[np.cos(t), -np.sin(t), 0.0], [np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
    A = rot @ np.diag([a, c, a])
    f = np.zeros((1, SURFACE_LIGHT_F.width))
    SURFACE_LIGHT_F.write(f[0], AREA=4 * np.pi * abs(np.linalg.det(A)), CENTER=(0.3, -1.0, 2.0), AXES=A.ravel(),
                          INV=np.linalg.inv(A).ravel())
    L = namedtuple('L', ['sl_f'])(f)
    n = 400
    g = (np.arange(n) + 0.5) / n                                          # a midpoint grid in (u1, u2)
    inv_density = []
    for u1 in g:
        for u2 in g[::8]:
            q, nrm, area = _ellipsoid_point(L, 0, u1, u2)
            local = np.linalg.solve(A, np.array(q) - f[0, SLF_CENTER:SLF_CENTER + 3])
            assert np.linalg.norm(local) == pytest.approx(1.0, abs=1e-12)           # on the ellipsoid
            grad = np.linalg.solve(A.T, local)                                      # normal: A^-T n
            np.testing.assert_allclose(nrm, grad / np.linalg.norm(grad), atol=1e-12)
            assert _ellipsoid_area_at(L, 0, q) == pytest.approx(area, rel=1e-9)
            inv_density.append(area)
    assert np.mean(inv_density) == pytest.approx(_spheroid_area(a, c), rel=2e-4)


def test_moving_placements_and_see_through_materials_are_lights():
    glow = D.Material('/glow', model=D.LAMBERTIAN, emission=(1.0, 1.0, 1.0))
    veil = D.Material('/veil', model=D.PREVIEW_SURFACE, emission=(1.0, 2.0, 4.0), opacity=0.25)
    gone = D.Material('/gone', model=D.PREVIEW_SURFACE, emission=(1.0, 2.0, 4.0), opacity=0.0)
    ball = D.Sphere(path='/ball', radius=0.5, matrix=translate(0, 1, 0), material=2)
    moved = translate(1, 0, 0) @ np.diag([2.0, 1.0, 1.0, 1.0])
    desc = scene([D.Container('/', meshes=[quad(4.0, material=2), quad(1.0, y=3.0, material=3)], spheres=[ball]),
                  D.Container('/moving', meshes=[quad(1.0, y=2.0, material=1)])],
                 [D.Material('/floor'), glow, veil, gone], [],
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))),
                 instances=D.Instances(container=np.array([0, 1], np.int32),
                                       matrices=np.array([[np.eye(4), np.eye(4)], [np.eye(4), moved]]),
                                       material_set=np.zeros(2, np.int32), material_sets=[()]))
    origin = desc.camera.matrix[:3, 3]
    with _path_lights(desc) as (built, L):
        # the see-through quad and ball (opacity 0.25: a quarter of their emission), not the quad that is
        # never there (opacity 0); the moving quad
        assert L.n_surface == 3
        see = np.flatnonzero(L.sl_i[:3, SLI_MOVING] == 0)
        np.testing.assert_allclose(L.sl_f[see, SLF_RAD:SLF_RAD + 3], [(0.25, 0.5, 1.0)] * 2)
        assert sorted(L.sl_i[see, SLI_COUNT]) == [0, 2]
        mv = int(np.flatnonzero(L.sl_i[:3, SLI_MOVING] == 1)[0])
        # object-space triangles (the placement is applied at a ray's time), their object area
        first, count = L.sl_i[mv, SLI_FIRST], L.sl_i[mv, SLI_COUNT]
        assert count == 2 and L.sl_f[mv, SLF_AREA] == pytest.approx(1.0)
        off = built.data.gp_off[built.data.pr_gp_start[1]]             # the moving container's quad, as Embree has it
        np.testing.assert_array_equal(L.sl_tri[first:first + 2], built.data.tri_v[off:off + 2])
        # its top-level instance: the row of the moving placement
        row = built.data.grp_base[L.sl_i[mv, SLI_INST]] + L.sl_i[mv, SLI_INST_PRIM]
        assert built.data.in_proto[row] == 1 and not np.all(built.data.in_xf[row] == built.data.in_xf[row, :1])
        assert L.sl_idx[L.sl_row[row]] == L.surface_first + mv
        # its tree bounds hold it over the shutter: x from -0.5 (open) to 1 + 2 (0.5) = 2 (close)
        assert leaf_record(L.tree_f, L.tree_i, L.surface_first + mv)[T_C] + origin[0] == pytest.approx(0.75, abs=1e-5)


def test_more_than_max_triangles_of_emissive_surfaces_are_warned():
    from rtc.renderer.host.surface_lights import MAX_TRIANGLES
    n = 160                                              # a 160 x 160 grid: 51200 triangles, placed twice
    g = np.linspace(0.0, 1.0, n + 1)
    X, Z = np.meshgrid(g, g)
    pts = np.stack([X.ravel(), np.ones(X.size), Z.ravel()], 1)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    tris = np.concatenate([np.stack([i, i + 1, i + n + 2], 1), np.stack([i, i + n + 2, i + n + 1], 1)]).astype(np.int32)
    glow = D.Material('/glow', model=D.LAMBERTIAN, emission=(1.0, 1.0, 1.0))
    sheet = D.Container('/sheet', meshes=[D.Mesh(path='/sheet', points=pts, triangles=tris, material=0)])
    inst = D.Instances(container=np.zeros(2, np.int32), matrices=np.array([np.eye(4), translate(2, 0, 0)])[:, None],
                       material_set=np.zeros(2, np.int32), material_sets=[()])
    desc = scene([sheet], [glow], [], D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))),
                 instances=inst)
    assert 2 * len(tris) > MAX_TRIANGLES
    with pytest.warns(RuntimeWarning, match='emissive triangles'), _path_lights(desc) as (built, L):
        assert L.n_surface == 2 and L.sl_tri.shape[0] == 2 * len(tris)
        assert any('emissive triangles' in w for w in desc.warnings)


def test_the_lights_example_scene_samples_every_kind_of_light():
    """scenes/lights.usda (the path gallery's USD example): a RectLight, a lit sign (a RectLight with an image), a
    CylinderLight, a spotlight (shaped SphereLight) and a sconce (a SphereLight with an IES profile, normalised) read
    as lights, the MeshLightAPI panel and the emissive sphere as the two emissive-surface lights, all in the tree; no
    warning (the sconce has the 90-degree cone ShapingAPI applies where no angle is authored);
    a small path render of it is finite and lit."""
    from pathlib import Path
    from rtc.renderer.host.render import RenderOptions, Renderer
    desc = read_stage(str(Path(__file__).resolve().parents[2] / 'scenes' / 'lights.usda'))
    assert sorted(l.type for l in desc.lights) == sorted([D.RECT, D.RECT, D.CYLINDER, D.SPHERE, D.SPHERE])
    assert not desc.warnings
    spot, sconce = (next(l for l in desc.lights if l.path == p) for p in ('/World/Spot', '/World/Sconce'))
    assert spot.shaping == (20.0, pytest.approx(0.35), 0.0, (0.0, 0.0, 0.0)) and spot.ies is None
    assert sconce.shaping == (90.0, 0.0, 0.0, (0.0, 0.0, 0.0)) and sconce.ies.candela.max() == 1000.0
    assert sconce.ies_gain == 1.0 / sconce.ies.mean
    sign = next(l for l in desc.lights if l.path == '/World/Sign')
    assert sign.texture >= 0 and desc.textures[sign.texture].path.endswith('sign.png')
    with _path_lights(desc) as (built, L):
        assert L.n_surface == 2 and L.surface_first == 5
        assert (L.depth[:7] >= 0).all()                  # all seven in the tree
    with Renderer(desc) as r:
        img = r.render(RenderOptions(width=48, height=36, spp=4, integrator='path', max_depth=2)).image
    assert np.isfinite(img).all() and img.mean() > 0.01


def test_the_emitters_example_scene_makes_every_glowing_surface_a_light():
    """scenes/emitters.usda: the emissive ellipsoid, the see-through pane (opacity 0.5: half its emission),
    the cube that moves over the shutter and the screen whose emissiveColor is an image are four surface
    lights, and the neon sign's seven linear segments seven more and its nine round ends and joints (two curves of
    seven points and two) nine more, all in the tree, beside the DomeLight; no warning; a small path render of it is
    finite and lit."""
    from pathlib import Path
    from rtc.renderer.host.render import RenderOptions, Renderer
    desc = read_stage(str(Path(__file__).resolve().parents[2] / 'scenes' / 'emitters.usda'))
    assert [l.type for l in desc.lights] == [D.DOME] and not desc.warnings
    with _path_lights(desc) as (built, L):
        neon = L.sl_i[:, SLI_CURVE] == CURVE_LINEAR
        caps = L.sl_i[:, SLI_CURVE] == CURVE_CAP
        assert L.n_surface == 20 and neon.sum() == 7 and caps.sum() == 9 and (L.depth[1:21] >= 0).all()
        np.testing.assert_allclose(L.sl_f[neon | caps, SLF_RAD:SLF_RAD + 3], [(6.0, 0.9, 3.6)] * 16, rtol=1e-6)
        neon |= caps
        kinds = {(int(L.sl_i[j, SLI_ELLIPSOID]), int(L.sl_i[j, SLI_MOVING]), int(L.sl_i[j, SLI_COUNT]),
                  int(L.sl_i[j, SLI_EMISSION_TEX]) >= 0): L.sl_f[j, SLF_RAD:SLF_RAD + 3] for j in np.flatnonzero(~neon)}
        assert sorted(kinds) == [(0, 0, 2, False), (0, 0, 2, True), (0, 1, 12, False), (1, 0, 0, False)]
        np.testing.assert_allclose(kinds[(0, 0, 2, False)], (0.4, 1.2, 1.6), rtol=1e-6)   # 0.5 x (0.8, 2.4, 3.2)
        np.testing.assert_allclose(kinds[(0, 0, 2, True)], (1.0, 1.0, 1.0))          # x the image (scale 1.2)
    with Renderer(desc) as r:
        img = r.render(RenderOptions(width=48, height=36, spp=4, integrator='path', max_depth=2)).image
    assert np.isfinite(img).all() and img.mean() > 0.01


@pytest.mark.parametrize('mode, emission, reflects', [
    (None, (8.0, 4.0, 2.0), True),                       # MeshLightAPI's fallback: materialGlowTintsLight
    ('materialGlowTintsLight', (8.0, 4.0, 2.0), True),
    ('independent', (8.0, 8.0, 8.0), True),
    ('noMaterialResponse', (8.0, 8.0, 8.0), False),
    ('somethingElse', (8.0, 4.0, 2.0), True),            # warned, read as the fallback
])
def test_material_sync_mode(mode, emission, reflects):
    """light:materialSyncMode: the material's glow tints the light (fallback), the light alone
    (independent), or the light alone on a surface with no material response."""
    stage = _stage()
    mesh = _quad_mesh(stage, '/World/Panel')
    UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
    api = UsdLux.LightAPI(mesh.GetPrim())
    api.CreateIntensityAttr(8.0)
    if mode is not None:
        api.CreateMaterialSyncModeAttr(mode)
    mat = _emissive_material(stage, '/Looks/Glow', colour=(1.0, 0.5, 0.25))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    desc = read_stage(stage)
    m = desc.materials[desc.containers[0].meshes[0].material]
    assert m.emission == pytest.approx(emission)
    assert (max(m.diffuse) > 0.0 or m.model == D.PREVIEW_SURFACE) == reflects
    assert any('materialSyncMode' in w for w in desc.warnings) == (mode == 'somethingElse')


def test_glow_tints_only_a_material_that_glows():
    """A bound material without emissiveColor (or no material) leaves the light's colour as it is."""
    stage = _stage()
    mesh = _quad_mesh(stage, '/World/Panel')
    UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
    UsdLux.LightAPI(mesh.GetPrim()).CreateColorAttr((0.5, 1.0, 1.0))
    desc = read_stage(stage)
    assert desc.materials[desc.containers[0].meshes[0].material].emission == pytest.approx((0.5, 1.0, 1.0))
