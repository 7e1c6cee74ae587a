"""rtc.renderer.usd.stage against independent computations.

The central check expands every corpus file by brute force -- `Usd.PrimRange` through instance
proxies, one Python iteration per PointInstancer instance, `XformCache.GetLocalToWorldTransform`
-- and compares the world-space placement of every gprim with what the flattened description
gives (container geometry x placement matrix).
"""
from __future__ import annotations

import math
import os
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

from rtc.renderer.description import DISTANT, POINT, RECT, SPHERE, Curves, Mesh, linear_pixels
from rtc.renderer.errors import SceneError
from rtc.renderer.host.info import describe
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage, rotate_x
from rtc.renderer.usd.geometry import GeometryError, convert_gprim, converter_for
from rtc.renderer.usd.instancing import InstanceGraph

CORPUS = Path(os.environ.get('RTC_SHARED', Path(__file__).resolve().parents[2].parent / 'shared')) / 'corpus' / 'usd'
IMAGING = CORPUS / 'openusd' / 'pxr' / 'usdImaging' / 'usdImagingGL' / 'testenv'
PI = UsdGeom.PointInstancer


def corpus_files() -> list[Path]:
    if not CORPUS.is_dir():
        return []
    return sorted(p for ext in ('usd', 'usda', 'usdc', 'usdz') for p in CORPUS.rglob(f'*.{ext}'))


needs_corpus = pytest.mark.skipif(not CORPUS.is_dir(), reason=f'USD corpus not found at {CORPUS}')


# --------------------------------------------------------------------------- brute force
def _np(m: Gf.Matrix4d) -> np.ndarray:
    return np.array(m).T


def _purpose_below(prim: Usd.Prim, root: Usd.Prim) -> str:
    """Purpose counting only opinions from `root` down (PointInstancer prototype rule)."""
    p = prim
    while True:
        attr = UsdGeom.Imageable(p).GetPurposeAttr()
        if p.IsA(UsdGeom.Imageable) and attr.HasAuthoredValue():
            return attr.Get()
        if p == root:
            return 'default'
        p = p.GetParent()


def _invisible_below(prim: Usd.Prim, root: Usd.Prim, t) -> bool:
    p = prim
    while True:
        attr = UsdGeom.Imageable(p).GetVisibilityAttr()
        if p.IsA(UsdGeom.Imageable) and attr.Get(t) == 'invisible':
            return True
        if p == root:
            return False
        p = p.GetParent()


def brute_force(stage: Usd.Stage, t: float) -> list[tuple[Usd.Prim, np.ndarray]]:
    """Every rendered (gprim, gprim-to-world matrix), one Python step per instance."""
    xc, tc, out = UsdGeom.XformCache(Usd.TimeCode(t)), Usd.TimeCode(t), []

    def point_instancer(prim, world):
        pi = PI(prim)
        targets = pi.GetPrototypesRel().GetForwardedTargets()
        idx = pi.GetProtoIndicesAttr().Get(tc) or []
        xf = pi.ComputeInstanceTransformsAtTime(tc, tc, PI.IncludeProtoXform, PI.IgnoreMask)
        mask = pi.ComputeMaskAtTime(tc)
        if len(xf) != len(idx):
            return
        for i, proto_index in enumerate(idx):
            if (len(mask) and not mask[i]) or not 0 <= proto_index < len(targets):
                continue
            root = stage.GetPrimAtPath(targets[proto_index])
            if not root or not root.IsActive() or not root.HasDefiningSpecifier() or root.IsAbstract():
                continue
            inst_world = _np(xf[i]) if world is None else world @ _np(xf[i])
            pred = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimHasDefiningSpecifier
                                               & ~Usd.PrimIsAbstract & Usd.PrimIsLoaded)
            it = iter(Usd.PrimRange(root, pred))
            for q in it:
                if _invisible_below(q, root, tc):
                    it.PruneChildren()
                    continue
                rel = np.eye(4) if q == root else _np(xc.ComputeRelativeTransform(q, root)[0])
                if q.IsA(PI):
                    point_instancer(q, inst_world @ rel)
                    it.PruneChildren()
                elif converter_for(q.GetTypeName()) and _purpose_below(q, root) in ('default', 'render'):
                    out.append((q, inst_world @ rel))

    it = iter(Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in it:
        if prim.IsPseudoRoot():
            continue
        img = UsdGeom.Imageable(prim)
        if img and img.ComputeVisibility(tc) == 'invisible':
            it.PruneChildren()
            continue
        if prim.IsA(PI):
            point_instancer(prim, _np(xc.GetLocalToWorldTransform(prim)))
            it.PruneChildren()
        elif converter_for(prim.GetTypeName()) and img.ComputePurpose() in ('default', 'render'):
            out.append((prim, _np(xc.GetLocalToWorldTransform(prim))))
    return out


def _identity_key(prim: Usd.Prim) -> str:
    return str((prim.GetPrimInPrototype() if prim.IsInstanceProxy() else prim).GetPath())


def expected_placements(stage, desc) -> dict[str, list[np.ndarray]]:
    """gprim path (in its prototype) -> world points (meshes) / world matrix (spheres), brute force."""
    up = rotate_x(-90) if desc.up_axis == 'Z' else np.eye(4)
    t = float(stage.GetStartTimeCode())
    out = defaultdict(list)
    for prim, world in brute_force(stage, desc.shutter_times[0]):
        try:
            shapes = convert_gprim(prim, np.eye(4), Usd.TimeCode(t), lambda _: None)
        except GeometryError:
            continue
        if not np.all(np.abs(np.linalg.det(world[:3, :3])) > 1e-300):
            continue
        w = up @ world
        shape = shapes[0]
        out[_identity_key(prim)].append(_placed(shape, w))
    return out


def _placed(shape, m: np.ndarray) -> np.ndarray:
    """A gprim record placed by m: a mesh's points, a curves gprim's control points, a sphere's matrix."""
    if isinstance(shape, (Mesh, Curves)):
        points = shape.points if isinstance(shape, Mesh) else shape.vertices[:, :3]
        return points @ m[:3, :3].T + m[:3, 3]
    return m @ shape.matrix


def actual_placements(stage, desc) -> dict[str, list[np.ndarray]]:
    out = defaultdict(list)
    inst = desc.instances
    for row in range(inst.count):
        container = desc.containers[inst.container[row]]
        m = inst.matrices[row, 0]
        seen = set()
        for g in container.gprims:
            path = Sdf.Path(g.path)
            prim = stage.GetPrimAtPath(path)
            if prim and prim.IsA(UsdGeom.Subset):
                path = path.GetParentPath()
            if path in seen:
                continue
            seen.add(path)
            out[str(path)].append(_placed(g, m))
    return out


def assert_same_placements(stage, desc):
    expected, actual = expected_placements(stage, desc), actual_placements(stage, desc)
    assert {k: len(v) for k, v in actual.items()} == {k: len(v) for k, v in expected.items()}
    for key in expected:
        order = lambda arrs: sorted(arrs, key=lambda a: tuple(np.round(np.concatenate(
            [a.mean(axis=0), a[:, -1], a.ravel()]), 6)))
        for a, e in zip(order(actual[key]), order(expected[key])):
            scale = max(1.0, float(np.abs(e).max()))
            np.testing.assert_allclose(a, e, atol=1e-9 * scale, rtol=0, err_msg=key)


# --------------------------------------------------------------------------- corpus
INSTANCING_FILES = [
    'testUsdImagingGLInstancing/nestedInstancedCubes.usda',
    'testUsdImagingGLInstancing/instance2.usda',
    'testUsdImagingGLInstancing/instancedCubes2NoInstancing.usda',
    'testUsdImagingGLInstancing/ni_pi.usda',
    'testUsdImagingGLInstancing/pi_ni_xform.usda',
    'testUsdImagingGLPointInstancer/pi_masking.usda',
    'testUsdImagingGLPointInstancer/pi_pi.usda',
    'testUsdImagingGLPointInstancer/pi_ni_pi.usda',
    'testUsdImagingGLPointInstancer/pi_varying.usda',
    'testUsdImagingGLPointInstancer/pi_root_prototype.usda',
    'testUsdImagingGLPointInstancer/pi_sibling_pi_over.usda',
    'testUsdImagingGLInheritedPurpose/InheritedPurposes_Nested_Instances.usd',
]


@needs_corpus
@pytest.mark.parametrize('name', INSTANCING_FILES)
def test_instancing_files_match_brute_force(name):
    stage = Usd.Stage.Open(str(IMAGING / name))
    assert_same_placements(stage, read_stage(stage))


@needs_corpus
def test_every_corpus_file_matches_brute_force():
    """Each corpus file usd-core opens is read without an exception, and its flattened
    placements equal the brute-force expansion (~5 s for the whole corpus)."""
    files = corpus_files()
    assert len(files) > 100
    for path in files:
        stage = Usd.Stage.Open(str(path))
        desc = read_stage(stage)
        assert desc.camera is not None and desc.lights, path
        assert_same_placements(stage, desc)


@needs_corpus
def test_known_counts():
    nested = read_stage(IMAGING / 'testUsdImagingGLInstancing/nestedInstancedCubes.usda')
    assert (len(nested.containers), nested.instances.count) == (1, 12)
    assert nested.triangle_counts() == (12, 144)
    masked = read_stage(IMAGING / 'testUsdImagingGLPointInstancer/pi_masking.usda')
    stage = Usd.Stage.Open(str(IMAGING / 'testUsdImagingGLPointInstancer/pi_masking.usda'))
    total = sum(len(PI(p).GetProtoIndicesAttr().Get(stage.GetStartTimeCode()) or [])
                for p in stage.Traverse() if p.IsA(PI))
    assert masked.instances.count == 4 < total                # masked instances are excluded
    pi_pi = read_stage(IMAGING / 'testUsdImagingGLPointInstancer/pi_pi.usda')
    assert pi_pi.instances.count == 24 and pi_pi.triangle_counts()[1] == 288


@needs_corpus
def test_earth_nested_instances():
    """Earth.usd: 301 native instances of 61 prototypes (its meshes are empty, so they are
    skipped as geometry but the instance graph must still have them all)."""
    stage = Usd.Stage.Open(str(CORPUS / 'openusd/pxr/usd/usd/testenv/'
                               'testUsdLoadUnloadDeepNestedInstancing.testenv/Earth.usd'))
    graph = InstanceGraph(stage, Usd.TimeCode(0), lambda _: None)
    graph.build()
    graph.evaluate([0.0])
    placed = graph.flatten(np.eye(4)[None])
    prototypes = [n for n, node in enumerate(graph.nodes) if node.key.startswith('/__Prototype')]
    assert len(prototypes) == 61 == len(stage.GetPrototypes())
    assert sum(len(np.concatenate(placed[n].maps)) for n in prototypes) == 301
    assert all('empty mesh' in s for s in read_stage(stage).skipped)


# --------------------------------------------------------------------------- hand-made stages
def _stage(up='Y') -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.Xform.Define(stage, '/World')
    return stage


def _tri_mesh(stage, path, points, counts, indices, **attrs):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(indices)
    mesh.CreateSubdivisionSchemeAttr('none')
    for k, v in attrs.items():
        mesh.GetPrim().GetAttribute(k).Set(v)
    return mesh


def _quat(axis, degrees):
    return Gf.Rotation(Gf.Vec3d(*axis), degrees).GetQuat()


def test_point_instancer_matrices_match_hand_computed_trs():
    stage = _stage()
    pi = PI.Define(stage, '/World/Scatter')
    pi.AddTranslateOp().Set(Gf.Vec3d(0, 10, 0))
    UsdGeom.Sphere.Define(stage, '/World/Scatter/Protos/Ball').CreateRadiusAttr(0.5)
    pi.CreatePrototypesRel().SetTargets(['/World/Scatter/Protos/Ball'])
    rng = np.random.default_rng(7)
    n = 200
    pos = rng.uniform(-5, 5, (n, 3))
    axes = rng.normal(size=(n, 3))
    angles = rng.uniform(0, 360, n)
    scales = rng.uniform(0.5, 2, (n, 3))
    quats = [Gf.Quatf(_quat(a, d)) for a, d in zip(axes, angles)]
    pi.CreateProtoIndicesAttr(Vt.IntArray([0] * n))
    pi.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in pos]))
    pi.CreateOrientationsfAttr(Vt.QuatfArray(quats))
    pi.CreateScalesAttr(Vt.Vec3fArray([Gf.Vec3f(*s) for s in scales]))
    pi.CreateIdsAttr(Vt.Int64Array(range(n)))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array([3, 4]))
    desc = read_stage(stage)
    assert desc.instances.count == n - 2
    got = desc.instances.matrices[:, 0]
    keep = [i for i in range(n) if i not in (3, 4)]
    for row, i in enumerate(keep):
        q = quats[i]
        w, (x, y, z) = q.GetReal(), q.GetImaginary()
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        expected = np.eye(4)
        expected[:3, :3] = r @ np.diag(np.float32(scales[i]).astype(np.float64))
        expected[:3, 3] = np.float32(pos[i]).astype(np.float64) + (0, 10, 0)
        np.testing.assert_allclose(got[row], expected, atol=1e-5)


def _outward(mesh: Mesh, centre) -> np.ndarray:
    """Dot products of each triangle's CCW normal with the direction from `centre`."""
    p = mesh.points[mesh.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return np.einsum('ij,ij->i', n, p.mean(axis=1) - centre)


CUBE_POINTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
               (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
CUBE_FACES_CCW = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3]


@pytest.mark.parametrize('left, mirror', [(False, False), (True, False), (False, True), (True, True)])
def test_triangles_face_outward(left, mirror):
    stage = _stage()
    indices = CUBE_FACES_CCW
    if left:                                   # leftHanded: the same faces listed clockwise
        indices = [i for k in range(0, 24, 4) for i in reversed(CUBE_FACES_CCW[k:k + 4])]
    mesh = _tri_mesh(stage, '/World/Box', CUBE_POINTS, [4] * 6, indices)
    if left:
        mesh.CreateOrientationAttr('leftHanded')
    mesh.AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    mesh.AddScaleOp().Set(Gf.Vec3f(-1 if mirror else 1, 2, 1))
    desc = read_stage(stage)
    (m,) = desc.containers[0].meshes
    assert len(m.triangles) == 12
    assert np.all(_outward(m, np.array([3.0, 0, 0])) > 0)


def test_quadrics_face_outward_with_smooth_normals():
    stage = _stage()
    for i, kind in enumerate((UsdGeom.Cube, UsdGeom.Cylinder, UsdGeom.Cone, UsdGeom.Capsule)):
        g = kind.Define(stage, f'/World/S{i}')
        g.AddTranslateOp().Set(Gf.Vec3d(4 * i, 0, 0))
        if kind is not UsdGeom.Cube:
            g.GetAxisAttr().Set('X')
    desc = read_stage(stage)
    for m in desc.containers[0].meshes:
        centre = (m.points.min(axis=0) + m.points.max(axis=0)) / 2
        assert np.all(_outward(m, centre) > -1e-12), m.path
        p = m.points[m.triangles]
        assert np.all(np.einsum('ijk,ijk->ij', m.normals, p - centre) > 0), m.path


def test_authored_normals_and_uvs_per_corner():
    stage = _stage()
    mesh = _tri_mesh(stage, '/World/Quad', [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3])
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('normals', Sdf.ValueTypeNames.Normal3fArray, 'faceVarying')
    pv.Set([(0, 0, 1)])
    pv.SetIndices(Vt.IntArray([0, 0, 0, 0]))
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray, 'vertex')
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    mesh.AddScaleOp().Set(Gf.Vec3f(1, 1, -2))            # mirrored: normal must flip to -Z
    (m,) = read_stage(stage).containers[0].meshes
    np.testing.assert_allclose(m.normals.reshape(-1, 3), np.tile([0, 0, -1], (6, 1)), atol=1e-7)
    np.testing.assert_allclose(m.uvs[:, :, 0], m.points[m.triangles][:, :, 0], atol=1e-7)


def test_bad_gprims_are_skipped_not_fatal():
    stage = _stage()
    UsdGeom.Sphere.Define(stage, '/World/Zero').CreateRadiusAttr(0.0)
    _tri_mesh(stage, '/World/NaN', [(0, 0, 0), (1, float('nan'), 0), (0, 1, 0)], [3], [0, 1, 2])
    _tri_mesh(stage, '/World/BadIndex', [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 7])
    UsdGeom.Sphere.Define(stage, '/World/Ok')
    desc = read_stage(stage)
    assert [s.path for c in desc.containers for s in c.spheres] == ['/World/Ok']
    assert sorted(s.split(':')[0] for s in desc.skipped) == ['/World/BadIndex', '/World/NaN', '/World/Zero']


def _preview_material(stage, path, rgb):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, f'{path}/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def test_material_binding_resolves_per_instance():
    stage = _stage()
    grey = _preview_material(stage, '/World/Looks/Grey', (0.5, 0.5, 0.5))
    red = _preview_material(stage, '/World/Looks/Red', (1, 0, 0))
    blue = _preview_material(stage, '/World/Looks/Blue', (0, 0, 1))
    UsdGeom.Xform.Define(stage, '/Protos/Thing')
    ball = UsdGeom.Sphere.Define(stage, '/Protos/Thing/Ball')
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(grey)
    stage.GetPrimAtPath('/Protos').SetSpecifier(Sdf.SpecifierOver)
    for i, (mat, strength) in enumerate([(None, None), (red, UsdShade.Tokens.strongerThanDescendants),
                                         (blue, UsdShade.Tokens.weakerThanDescendants),
                                         (red, UsdShade.Tokens.strongerThanDescendants)]):
        x = UsdGeom.Xform.Define(stage, f'/World/I{i}')
        x.GetPrim().GetReferences().AddInternalReference('/Protos/Thing')
        x.GetPrim().SetInstanceable(True)
        x.AddTranslateOp().Set(Gf.Vec3d(3 * i, 0, 0))
        if mat:
            UsdShade.MaterialBindingAPI.Apply(x.GetPrim()).Bind(mat, strength)
    desc = read_stage(stage)
    inst = desc.instances
    colour = {inst.paths[r]: desc.materials[inst.material_sets[inst.material_set[r]][0]].diffuse
              for r in range(inst.count)}
    assert colour == {'/World/I0': (0.5, 0.5, 0.5), '/World/I1': (1.0, 0.0, 0.0),
                      '/World/I2': (0.5, 0.5, 0.5), '/World/I3': (1.0, 0.0, 0.0)}
    assert len(inst.material_sets) == 2 and len(desc.containers) == 1


def test_z_up_stage_is_rotated_to_y_up():
    stage = _stage('Z')
    ball = UsdGeom.Sphere.Define(stage, '/World/Ball')
    ball.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    UsdLux.DistantLight.Define(stage, '/World/Sun')                    # shines down -Z = down in Z-up
    cam = UsdGeom.Camera.Define(stage, '/World/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, -10, 0))
    cam.AddRotateXOp().Set(90.0)                                       # looks along +Y (Z-up "forward")
    desc = read_stage(stage)
    assert desc.up_axis == 'Z'
    (sphere,) = desc.containers[0].spheres
    world = desc.instances.matrices[0, 0] @ sphere.matrix
    np.testing.assert_allclose(world[:3, 3], (1, 3, -2), atol=1e-12)
    sun = next(l for l in desc.lights if l.type == DISTANT)
    np.testing.assert_allclose(sun.matrix[:3, :3] @ (0, 0, -1), (0, -1, 0), atol=1e-12)
    np.testing.assert_allclose(desc.camera.matrix[:3, :3] @ (0, 0, -1), (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(desc.camera.matrix[:3, 3], (0, 0, 10), atol=1e-12)


def test_light_radiance_normalize_on_and_off():
    stage = _stage()
    rect = UsdLux.RectLight.Define(stage, '/World/Rect')
    rect.CreateWidthAttr(2.0); rect.CreateHeightAttr(0.5)
    rect.CreateIntensityAttr(10.0); rect.CreateExposureAttr(1.0); rect.CreateColorAttr((1, 0.5, 0.25))
    rect.AddScaleOp().Set(Gf.Vec3f(3, 1, 1))
    rect_n = UsdLux.RectLight.Define(stage, '/World/RectN')
    rect_n.CreateWidthAttr(2.0); rect_n.CreateHeightAttr(0.5); rect_n.CreateIntensityAttr(10.0)
    rect_n.CreateNormalizeAttr(True)
    rect_n.AddScaleOp().Set(Gf.Vec3f(3, 1, 1))
    point = UsdLux.SphereLight.Define(stage, '/World/Point')
    point.CreateRadiusAttr(0.0); point.CreateIntensityAttr(8.0)
    ball = UsdLux.SphereLight.Define(stage, '/World/Ball')
    ball.CreateRadiusAttr(2.0); ball.CreateIntensityAttr(8.0); ball.CreateNormalizeAttr(True)
    sun = UsdLux.DistantLight.Define(stage, '/World/Sun')
    sun.CreateAngleAttr(10.0); sun.CreateIntensityAttr(2.0)
    lights = {l.path: l for l in read_stage(stage).lights}
    r = lights['/World/Rect']
    assert r.type == RECT and (r.width, r.height) == pytest.approx((6.0, 0.5))
    assert r.radiance == pytest.approx((20.0, 10.0, 5.0))                    # 10 * 2^1 * colour
    assert lights['/World/RectN'].radiance == pytest.approx((10 / 3.0,) * 3)  # / world area 6 * 0.5
    assert lights['/World/Point'].type == POINT and lights['/World/Point'].radiance == pytest.approx((2.0,) * 3)
    b = lights['/World/Ball']
    assert b.type == SPHERE and b.radiance == pytest.approx((8 / (4 * math.pi * 4),) * 3)
    s = lights['/World/Sun']
    assert s.radiance == pytest.approx((2 * math.pi * math.sin(math.radians(5)) ** 2,) * 3)
    np.testing.assert_allclose(r.matrix[:3, :3] @ r.matrix[:3, :3].T, np.eye(3), atol=1e-12)


def test_render_settings_camera_and_overrides():
    stage = _stage()
    cam = UsdGeom.Camera.Define(stage, '/World/Cam')
    cam.CreateFocalLengthAttr(50.0); cam.CreateFStopAttr(2.0); cam.CreateFocusDistanceAttr(5.0)
    cam.CreateHorizontalApertureAttr(36.0); cam.CreateVerticalApertureAttr(24.0)
    UsdGeom.Cube.Define(stage, '/World/Ground').CreateSizeAttr(100.0)
    from pxr import UsdRender
    rs = UsdRender.Settings.Define(stage, '/Render/Settings')
    rs.CreateResolutionAttr(Gf.Vec2i(300, 200)); rs.CreateCameraRel().SetTargets(['/World/Cam'])
    rs.GetPrim().CreateAttribute('rtc:samplesPerPixel', Sdf.ValueTypeNames.Int, custom=True).Set(9)
    rs.GetPrim().CreateAttribute('rtc:backgroundColor', Sdf.ValueTypeNames.Color3f, custom=True).Set((0.1, 0.2, 0.3))
    stage.SetMetadata('renderSettingsPrimPath', '/Render/Settings')
    desc = read_stage(stage, options=RenderOptions(spp=4))
    c = desc.camera
    assert (desc.settings.width, desc.settings.height, desc.settings.samples_per_pixel) == (300, 200, 9)
    assert (desc.options.width, desc.options.height, desc.options.spp) == (300, 200, 4)
    assert desc.background == pytest.approx((0.1, 0.2, 0.3))
    assert (c.focal_length, c.horizontal_aperture, c.vertical_aperture) == pytest.approx((5.0, 3.6, 2.4))
    assert c.lens_radius == pytest.approx(5.0 / 4) and c.focus_distance == 5.0
    assert read_stage(stage, options=RenderOptions(width=200, height=200)).camera.vertical_aperture == \
        pytest.approx(3.6)


def test_millimetre_lens_on_a_metre_scale_scene_is_rescaled():
    stage = _stage()
    cam = UsdGeom.Camera.Define(stage, '/World/Cam')
    cam.CreateFocalLengthAttr(50.0); cam.CreateFStopAttr(2.0); cam.CreateFocusDistanceAttr(3.0)
    UsdGeom.Cube.Define(stage, '/World/Box').CreateSizeAttr(1.0)      # a 1.7 unit diagonal
    desc = read_stage(stage)
    assert desc.camera.lens_radius == pytest.approx(0.050 / 4)       # 50 mm at f/2
    assert any('millimetres' in w for w in desc.warnings)


def test_default_camera_and_lights_when_missing():
    stage = _stage()
    UsdGeom.Cube.Define(stage, '/World/Box').GetSizeAttr().Set(4.0)
    desc = read_stage(stage)
    assert desc.camera.path == '<default camera>'
    assert {l.type for l in desc.lights} == {DISTANT, 5}
    eye = desc.camera.matrix[:3, 3]
    assert np.linalg.norm(eye) > 2 * math.sqrt(3)                      # outside the box
    assert np.dot(desc.camera.matrix[:3, :3] @ (0, 0, -1), -eye / np.linalg.norm(eye)) > 0.999
    assert any('default camera' in w for w in desc.warnings)


def _bound_material_paths(stage, desc) -> dict[tuple[str, str], str]:
    """(placement label, gprim path in its container) -> path of the material the reader uses,
    a material inside a prototype read at the placement's path (the reader keeps the prototype's
    own binding for instances that bind nothing themselves: the same material)."""
    inst, out = desc.instances, {}
    for r in range(inst.count):
        container = desc.containers[inst.container[r]]
        for g, m in zip(container.gprims, inst.material_sets[inst.material_set[r]]):
            path = desc.materials[m if m >= 0 else g.material].path
            if container.key.startswith('/__Prototype') and path.startswith(container.key + '/'):
                path = inst.paths[r] + path[len(container.key):]
            out[(inst.paths[r], g.path)] = path
    return out


def _brute_material_paths(stage, desc) -> dict[tuple[str, str], str]:
    """The same by `ComputeBoundMaterial` on each instance proxy (materials in these tests are
    all bound, so no displayColor fallback)."""
    inst, out = desc.instances, {}
    for r in range(inst.count):
        container = desc.containers[inst.container[r]]
        for g in container.gprims:
            proxy = inst.paths[r] + g.path[len(container.key):] if container.key.startswith('/__Prototype') \
                else g.path
            mat, _ = UsdShade.MaterialBindingAPI(stage.GetPrimAtPath(proxy)).ComputeBoundMaterial(
                UsdShade.Tokens.full)
            out[(inst.paths[r], g.path)] = str(mat.GetPath())
    return out


def _many_instances_stage(moving: bool = False) -> Usd.Stage:
    """Groups of sibling instances of two prototypes (one holding its own material, one nesting
    instances of the first) with invisible / proxy / render purpose / own and inherited
    bindings of both strengths / inactive instances / an instance that is itself a Cube, and
    optionally instances moving over the camera shutter."""
    stage = _stage()
    looks = {c: _preview_material(stage, f'/World/Looks/{c}', rgb)
             for c, rgb in (('Grey', (.5, .5, .5)), ('Red', (1, 0, 0)), ('Blue', (0, 0, 1)))}
    UsdGeom.Xform.Define(stage, '/Protos/A')
    UsdGeom.Sphere.Define(stage, '/Protos/A/Ball')
    cube = UsdGeom.Cube.Define(stage, '/Protos/A/Box')
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath('/Protos/A/Ball')).Bind(looks['Grey'])
    inner = _preview_material(stage, '/Protos/A/Looks/Inner', (0, 1, 0))    # a material per instance
    UsdShade.MaterialBindingAPI.Apply(cube.GetPrim()).Bind(inner)
    UsdGeom.Xform.Define(stage, '/Protos/Nest')
    for i in range(3):
        x = UsdGeom.Xform.Define(stage, f'/Protos/Nest/N{i}')
        x.GetPrim().GetReferences().AddInternalReference('/Protos/A')
        x.GetPrim().SetInstanceable(True)
        x.AddTranslateOp().Set(Gf.Vec3d(i, 0, 0))
    stage.GetPrimAtPath('/Protos').SetSpecifier(Sdf.SpecifierOver)
    if moving:
        cam = UsdGeom.Camera.Define(stage, '/World/Cam')
        cam.CreateShutterOpenAttr(-0.5)
        cam.CreateShutterCloseAttr(0.5)
    rng = np.random.default_rng(5)
    for g in range(3):
        group = UsdGeom.Xform.Define(stage, f'/World/G{g}')
        group.AddTranslateOp().Set(Gf.Vec3d(0, 5 * g, 0))
        for i in range(30):
            x = UsdGeom.Xform.Define(stage, f'/World/G{g}/I{i}')
            prim = x.GetPrim()
            prim.GetReferences().AddInternalReference('/Protos/A' if i % 4 else '/Protos/Nest')
            prim.SetInstanceable(True)
            op = x.MakeMatrixXform()
            for t in ((-1, 0, 1) if moving and i % 3 == 0 else (0,)):
                op.Set(Gf.Matrix4d().SetTranslate(Gf.Vec3d(*rng.uniform(-9, 9, 3))), Usd.TimeCode(t))
            k = i % 8
            if k == 1:
                x.CreateVisibilityAttr('invisible')
            elif k == 2:
                x.CreatePurposeAttr('proxy')
            elif k == 3:
                x.CreatePurposeAttr('render')
            elif k in (4, 5):
                UsdShade.MaterialBindingAPI.Apply(prim).Bind(
                    looks['Red'], UsdShade.Tokens.strongerThanDescendants if k == 4 else
                    UsdShade.Tokens.weakerThanDescendants)
            elif k == 6:
                UsdShade.MaterialBindingAPI.Apply(prim).Bind(looks['Blue'], UsdShade.Tokens.strongerThanDescendants)
            if i == 29:
                prim.SetActive(False)
        if g == 1:
            group.CreatePurposeAttr('render')
        if g == 2:
            UsdShade.MaterialBindingAPI.Apply(group.GetPrim()).Bind(looks['Blue'],
                                                                  UsdShade.Tokens.strongerThanDescendants)
    box = UsdGeom.Cube.Define(stage, '/World/CubeInstance')         # an instance that is a gprim too
    box.GetPrim().GetReferences().AddInternalReference('/Protos/A')
    box.GetPrim().SetInstanceable(True)
    UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(looks['Red'])
    return stage


@pytest.mark.parametrize('moving', [False, True])
def test_many_sibling_instances_match_brute_force(moving):
    """The batched walk (children in batches, instance -> prototype table) and the shared
    material resolution of instances with equal bindings give what a brute-force expansion and
    per-proxy `ComputeBoundMaterial` give: placements at every motion sample, materials per
    placement, materials inside instances kept per instance."""
    stage = _many_instances_stage(moving)
    desc = read_stage(stage)
    assert_same_placements(stage, desc)
    assert _bound_material_paths(stage, desc) == _brute_material_paths(stage, desc)
    # instances binding Red weaker than the prototype's own Inner: resolved per instance (the
    # material is inside each instance), not shared from the first one
    inner = {m.path for m in desc.materials if m.path.endswith('/Looks/Inner') and not m.path.startswith('/__')}
    assert len(inner) >= 6
    if moving:
        assert desc.shutter_times == (-0.5, 0.0, 0.5)
        for k, t in enumerate(desc.shutter_times):
            xc = UsdGeom.XformCache(Usd.TimeCode(t))
            for r, path in enumerate(desc.instances.paths):
                if path.count('/') == 3 and desc.containers[desc.instances.container[r]].key.startswith('/__'):
                    want = np.array(xc.GetLocalToWorldTransform(stage.GetPrimAtPath(path))).T
                    np.testing.assert_allclose(desc.instances.matrices[r, k], want, atol=1e-12)


def test_motion_samples_and_moving_plain_gprim():
    stage = _stage()
    cam = UsdGeom.Camera.Define(stage, '/World/Cam')
    cam.CreateShutterOpenAttr(0.0); cam.CreateShutterCloseAttr(1.0)
    ball = UsdGeom.Sphere.Define(stage, '/World/Ball')
    op = ball.AddTranslateOp()
    for t, x in ((0, 0.0), (0.5, 1.0), (1, 4.0)):
        op.Set(Gf.Vec3d(x, 0, 0), t)
    UsdGeom.Sphere.Define(stage, '/World/Still')
    desc = read_stage(stage)
    assert desc.shutter_times == (0.0, 0.5, 1.0)
    moving = [r for r in range(desc.instances.count)
              if desc.containers[desc.instances.container[r]].spheres[0].path == '/World/Ball']
    (row,) = moving
    np.testing.assert_allclose(desc.instances.matrices[row, :, 0, 3], (0, 1, 4))


def test_corrupt_and_missing_files_raise_scene_error(tmp_path):
    bad = tmp_path / 'bad.usda'
    bad.write_text('#usda 1.0\ndef Xform "A" {\n  double3 xformOp:translate = (1, 2\n')
    with pytest.raises(SceneError, match='bad.usda'):
        read_stage(bad)
    garbage = tmp_path / 'garbage.usdc'
    garbage.write_bytes(b'PXR-USDC' + bytes(range(256)) * 4)
    with pytest.raises(SceneError, match='garbage.usdc'):
        read_stage(garbage)
    with pytest.raises(SceneError, match='no such file'):
        read_stage(tmp_path / 'missing.usd')
    text = tmp_path / 'scene.txt'
    text.write_text('hello')
    with pytest.raises(SceneError, match='not a USD file'):
        read_stage(text)


def test_info_describes_and_exits_2_on_error(tmp_path):
    from click.testing import CliRunner
    stage = _stage()
    UsdGeom.Sphere.Define(stage, '/World/Ball')
    summary = describe(read_stage(stage))
    assert 'placed 1x' in summary and 'distant 1' in summary
    bad = tmp_path / 'bad.usda'
    bad.write_text('#usda 1.0\ndef "A" {\n')
    from rtc.cli import main
    result = CliRunner().invoke(main, ['info', str(bad)])
    assert result.exit_code == 2 and 'bad.usda' in result.output


def test_course_material_and_texture_loaded_once(tmp_path):
    import OpenImageIO as oiio
    pixels = np.zeros((2, 4, 3), np.uint8)
    pixels[..., 0] = 128                                       # sRGB 128 -> linear 0.2158
    image = tmp_path / 'checker.png'
    out = oiio.ImageOutput.create(str(image))
    out.open(str(image), oiio.ImageSpec(4, 2, 3, 'uint8'))
    out.write_image(pixels)
    out.close()
    stage = _stage()
    for name in ('A', 'B'):
        mat = UsdShade.Material.Define(stage, f'/World/Looks/{name}')
        prim = mat.GetPrim()
        prim.CreateAttribute('rtc:model', Sdf.ValueTypeNames.Token, custom=True).Set('blinnPhong')
        prim.CreateAttribute('rtc:diffuse', Sdf.ValueTypeNames.Color3d, custom=True).Set((0.1, 0.2, 0.3))
        prim.CreateAttribute('rtc:phongExp', Sdf.ValueTypeNames.Double, custom=True).Set(64.0)
        prim.CreateAttribute('rtc:diffuseTexture', Sdf.ValueTypeNames.Asset, custom=True).Set(str(image))
        ball = UsdGeom.Sphere.Define(stage, f'/World/{name}')
        UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(mat)
    _preview_material(stage, '/World/Looks/Unused', (1, 1, 1))
    desc = read_stage(stage)
    assert [m.path for m in desc.materials] == ['/World/Looks/A', '/World/Looks/B']
    a = desc.materials[0]
    assert (a.model, a.diffuse, a.exponent) == (1, (0.1, 0.2, 0.3), 64.0)
    assert len(desc.textures) == 1 and a.diffuse_texture == desc.materials[1].diffuse_texture == 0
    assert linear_pixels(desc.textures[0].pixels)[0, 0, 0] == pytest.approx(((128 / 255 + 0.055) / 1.055) ** 2.4,
                                                                   abs=1e-6)


@needs_corpus
def test_preview_surface_texture_from_corpus():
    desc = read_stage(IMAGING / 'testUsdImagingGLPreviewSurface/testPreviewSurfaceTexture.usda')
    textured = [m for m in desc.materials if m.diffuse_texture >= 0]
    assert textured and textured[0].diffuse == (1.0, 1.0, 1.0)
    tex = desc.textures[textured[0].diffuse_texture]
    assert linear_pixels(tex.pixels).dtype == np.float32 and len(tex.pixels.shape) == 3


def test_malformed_attribute_values_skip_the_prim(tmp_path):
    path = tmp_path / 'typos.usda'
    path.write_text('#usda 1.0\ndef Xform "World" {\n'
                    '    def SphereLight "L" {\n        string inputs:radius = "big"\n    }\n'
                    '    def Sphere "S" {\n        string radius = "r"\n    }\n'
                    '    def Sphere "Ok" {\n    }\n}\n')
    desc = read_stage(path)
    assert [s.path for c in desc.containers for s in c.spheres] == ['/World/Ok']
    assert sorted(desc.skipped) == ['/World/L: unreadable light (inputs:radius is a string, the schema says float)',
                                    '/World/S: unreadable Sphere (radius is a string, the schema says double)']



def test_mistyped_shader_inputs_keep_their_defaults(tmp_path):
    """An input authored with another type than its definition's is ignored (its default used, as Storm, which
    asks for the declared type, does), warned with its name; the well-typed inputs beside it are kept."""
    path = tmp_path / 'inputs.usda'
    path.write_text('#usda 1.0\ndef Xform "World" {\n'
                    '    def Sphere "S" (prepend apiSchemas = ["MaterialBindingAPI"]) {\n'
                    '        rel material:binding = </World/M>\n    }\n'
                    '    def Material "M" {\n        token outputs:surface.connect = </World/M/P.outputs:surface>\n'
                    '        def Shader "P" {\n            uniform token info:id = "UsdPreviewSurface"\n'
                    '            string inputs:roughness = "bogus"\n'
                    '            float2 inputs:diffuseColor = (0.3, 0.4)\n'
                    '            float inputs:metallic = 0.25\n            color3f inputs:emissiveColor = (1, 2, 3)\n'
                    '            token outputs:surface\n        }\n'
                    '        def Shader "T" {\n            uniform token info:id = "UsdUVTexture"\n'
                    '            float inputs:file = 2\n            string inputs:scale = "x"\n'
                    '            float3 inputs:fallback = (0.5, 0.5, 0.5)\n            float3 outputs:rgb\n        }\n'
                    '    }\n'
                    '    def Material "C" {\n        token rtc:model = "blinnPhong"\n'
                    '        string rtc:phongExp = "sixty"\n        color3f rtc:diffuse = (0.1, 0.2, 0.3)\n    }\n'
                    '    def Sphere "K" (prepend apiSchemas = ["MaterialBindingAPI"]) {\n'
                    '        rel material:binding = </World/C>\n    }\n}\n')
    stage = Usd.Stage.Open(str(path))
    shader = UsdShade.Shader(stage.GetPrimAtPath('/World/M/P'))
    shader.CreateInput('specularColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
        UsdShade.Shader(stage.GetPrimAtPath('/World/M/T')).ConnectableAPI(), 'rgb')
    desc = read_stage(stage)
    preview = next(m for m in desc.materials if m.path == '/World/M')
    assert (preview.roughness, preview.diffuse, preview.metallic, preview.emission) == \
        (0.5, (0.18, 0.18, 0.18), 0.25, (1.0, 2.0, 3.0))
    assert preview.specular_texture < 0 and preview.specular == (0.0, 0.0, 0.0)     # no file: the (float4) default
    course = next(m for m in desc.materials if m.path == '/World/C')
    assert course.exponent == 0.0 and course.diffuse == pytest.approx((0.1, 0.2, 0.3))
    for name, kind in (('/World/M/P.inputs:roughness', 'float'), ('/World/M/P.inputs:diffuseColor', 'color3'),
                       ('/World/M/T.inputs:file', 'asset'), ('/World/M/T.inputs:fallback', 'float4'),
                       ('/World/C.rtc:phongExp', 'float')):
        assert any(w.startswith(name) and kind in w for w in desc.warnings), (name, desc.warnings)


@pytest.mark.parametrize('declared', ['string primvars:displayColor = "x"',
                                      'token primvars:displayColor = "red" (interpolation = "vertex")',
                                      'color3f primvars:displayColor = (1, 0, 0)'])
def test_a_display_color_that_is_not_an_array_is_grey(tmp_path, declared):
    """primvars:displayColor declared as something other than an array of colours: the gprim is drawn grey, warned
    (was a ValueError traceback)."""
    path = tmp_path / 'colour.usda'
    path.write_text('#usda 1.0\ndef Mesh "M" {\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    f'[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n    {declared}\n}}\n')
    desc = read_stage(path)
    assert [m.diffuse for m in desc.materials] == [(0.18, 0.18, 0.18)]
    assert any(w.startswith('/M: primvars:displayColor') and 'grey used instead' in w for w in desc.warnings), \
        desc.warnings


def _maya_cube(stage, path):
    """A unit cube as six quads, written the way Arnold's Maya exports write their normals:
    faceVarying, indexed, with an element size of 4 (one element per quad) that usd-core cannot
    flatten against the 24 indices."""
    points = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    quads = [0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3]
    mesh = _tri_mesh(stage, path, points, [4] * 6, quads)
    normals = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('normals', Sdf.ValueTypeNames.Normal3fArray,
                                                      UsdGeom.Tokens.faceVarying)
    normals.Set([(-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1)])
    normals.SetIndices(Vt.IntArray([f for f in range(6) for _ in range(4)]))
    normals.SetElementSize(4)
    return mesh


def test_bad_primvars_cost_the_attribute_not_the_mesh(tmp_path):
    """Meshes written by usd-core with primvars it cannot flatten or whose size does not match: each
    mesh is kept with computed normals (area-weighted, unit length), one warning per attribute
    names the prim and the attribute in words, and no message carries Python's error text."""
    stage = _stage()
    _maya_cube(stage, '/World/Maya')
    wild = _tri_mesh(stage, '/World/Wild', [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
    n = UsdGeom.PrimvarsAPI(wild).CreatePrimvar('normals', Sdf.ValueTypeNames.Normal3fArray, 'faceVarying')
    n.Set([(0, 0, 1)])
    n.SetIndices(Vt.IntArray([0, 0, 9]))
    st = UsdGeom.PrimvarsAPI(wild).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray, 'faceVarying')
    st.Set([(0, 0), (1, 0)])                              # 2 values for 3 corners
    colour = UsdGeom.PrimvarsAPI(wild).CreatePrimvar('displayColor', Sdf.ValueTypeNames.Color3fArray)
    colour.Set([(1, 0, 0)])
    colour.SetIndices(Vt.IntArray([4]))
    path = tmp_path / 'maya.usdc'
    stage.GetRootLayer().Export(str(path))

    desc = read_stage(path)
    assert desc.skipped == []
    meshes = {m.path: m for c in desc.containers for m in c.meshes}
    assert sorted(meshes) == ['/World/Maya', '/World/Wild']
    cube = meshes['/World/Maya']
    assert cube.triangles.shape == (12, 3)
    corners = cube.points[cube.triangles]                  # outward: away from the cube's centre
    assert np.all(np.einsum('tck,tck->tc', cube.normals, corners - 0.5) > 0)
    np.testing.assert_allclose(np.linalg.norm(cube.normals, axis=-1), 1.0, atol=1e-6)
    np.testing.assert_allclose(np.abs(meshes['/World/Wild'].normals.reshape(-1, 3)), [[0, 0, 1]] * 3, atol=1e-7)
    assert meshes['/World/Wild'].uvs is None
    ours = [w for w in desc.warnings if not w.startswith('USD: ')]
    assert ours[:4] == [
        '/World/Maya: primvars:normals cannot be used (its 24 indices of elements of 4 values do not fit its 6 '
        'values); normals computed from the faces instead',
        '/World/Wild: primvars:normals cannot be used (its indices reach 9 but it has 1 value); normals '
        'computed from the faces instead',
        '/World/Wild: primvars:st: 2 values do not match interpolation "faceVarying"; texture coordinates '
        'ignored',
        '/World/Wild: primvars:displayColor cannot be used (its indices reach 4 but it has 1 value); grey '
        'used instead']
    for message in desc.warnings + desc.skipped:
        assert 'object' not in message and 'len()' not in message and 'Error' not in message


def test_mesh_with_rtc_implicit_reads_as_the_exact_shape():
    """A Mesh carrying rtc:implicit (how the compiler writes course spheres, boxes and cylinders,
    with a tessellation for other tools) gives the same records as the UsdGeom shape itself."""
    stage = _stage()
    made = {}
    for kind, sizes in (('Sphere', {'radius': 0.7}), ('Cube', {'size': 1.0}),
                        ('Cylinder', {'radius': 0.3, 'height': 2.5})):
        shape = stage.DefinePrim(f'/World/{kind}', kind)
        mesh = _tri_mesh(stage, f'/World/{kind}Mesh', [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
        mesh.GetPrim().CreateAttribute('rtc:implicit', Sdf.ValueTypeNames.Token, custom=True).Set(kind)
        for name, value in sizes.items():
            shape.GetAttribute(name).Set(value)
            mesh.GetPrim().CreateAttribute(f'rtc:{name}', Sdf.ValueTypeNames.Double, custom=True).Set(value)
        if kind == 'Cylinder':
            shape.GetAttribute('axis').Set('Y')
            mesh.GetPrim().CreateAttribute('rtc:axis', Sdf.ValueTypeNames.Token, custom=True).Set('Y')
        for prim in (shape, mesh.GetPrim()):
            UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
        made[kind] = (shape, mesh.GetPrim())
    desc = read_stage(stage)
    records = {r.path: r for c in desc.containers for r in (*c.meshes, *c.spheres)}
    for kind, (shape, mesh) in made.items():
        a, b = records[str(shape.GetPath())], records[str(mesh.GetPath())]
        assert type(a) is type(b)
        if kind == 'Sphere':
            assert a.radius == b.radius == 0.7 and np.array_equal(a.matrix, b.matrix)
        else:
            assert np.array_equal(a.points, b.points) and np.array_equal(a.triangles, b.triangles)
            assert np.array_equal(a.normals, b.normals)
    assert np.ptp(records['/World/CylinderMesh'].points[:, 1]) == pytest.approx(2.5)   # along Y


def test_course_background_dome_is_the_background_not_a_light():
    """A constant DomeLight marked rtc:background is the colour of escaping rays (radiance
    colour x intensity), not a light; an unmarked DomeLight stays a light."""
    stage = _stage()
    UsdGeom.Sphere.Define(stage, '/World/S')
    UsdLux.SphereLight.Define(stage, '/World/L').CreateIntensityAttr(5.0)
    dome = UsdLux.DomeLight.Define(stage, '/World/Background')
    dome.CreateColorAttr((0.25, 0.5, 0.75))
    dome.CreateIntensityAttr(2.0)
    dome.GetPrim().CreateAttribute('rtc:background', Sdf.ValueTypeNames.Bool, custom=True).Set(True)
    desc = read_stage(stage)
    assert desc.background == (0.5, 1.0, 1.5)
    assert [l.path for l in desc.lights] == ['/World/L']
    dome.GetPrim().GetAttribute('rtc:background').Set(False)
    desc = read_stage(stage)
    assert desc.background == (0.0, 0.0, 0.0)
    assert sorted(l.path for l in desc.lights) == ['/World/Background', '/World/L']


def _exr(path, pixels):
    import OpenImageIO as oiio
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.FLOAT))
    assert out.write_image(np.ascontiguousarray(pixels, np.float32))
    out.close()


def test_non_finite_texels_are_read_as_zero_with_a_warning(tmp_path):
    """A dome texture with a NaN and an infinite texel (a damaged HDR): read as 0 with a warning naming
    the file and the light, and lit exactly as the same image with those texels black.  (Read as they
    were, one NaN texel made the sampling tables NaN and every light sample of the dome dark.)"""
    from rtc.renderer.host.render import Renderer
    sky = np.full((8, 16, 3), 0.5, np.float32)
    sky[2, 5] = (4.0, 3.0, 2.0)
    damaged = sky.copy()
    damaged[1, 3, 0], damaged[6, 9] = np.nan, np.inf
    clean = sky.copy()
    clean[1, 3, 0], clean[6, 9] = 0.0, 0.0
    descs = {}
    for name, px in (('damaged', damaged), ('clean', clean)):
        _exr(tmp_path / f'{name}.exr', px)
        stage = _stage()
        _tri_mesh(stage, '/World/Floor', [(-5, 0, -5), (5, 0, -5), (5, 0, 5), (-5, 0, 5)], [4], [0, 3, 2, 1])
        dome = UsdLux.DomeLight.Define(stage, '/World/Sky')
        dome.CreateTextureFileAttr(Sdf.AssetPath(str(tmp_path / f'{name}.exr')))
        cam = UsdGeom.Camera.Define(stage, '/World/Cam')
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 1, 3))
        descs[name] = read_stage(stage)
    warned = [w for w in descs['damaged'].warnings if 'NaN or infinite' in w]
    assert len(warned) == 1 and '/World/Sky' in warned[0] and 'damaged.exr' in warned[0] and ' 4 ' in warned[0]
    assert not any('NaN' in w for w in descs['clean'].warnings)
    assert np.array_equal(descs['damaged'].textures[0].pixels, descs['clean'].textures[0].pixels)
    images = {}
    for name, desc in descs.items():
        with Renderer(desc) as r:
            images[name] = r.render(RenderOptions(width=16, height=12, spp=8, integrator='path')).image
    assert np.isfinite(images['damaged']).all() and images['damaged'].mean() > 0.1
    assert np.array_equal(images['damaged'], images['clean'])


def test_negative_dome_texels_are_read_as_zero_with_a_warning(tmp_path):
    """A dome texture with a band of negative values (an HDR after a careless subtraction): the light reads
    them as 0 with a warning naming the file, the light and the count, as pbrt-v4 does.  Read as they were,
    light sampling (which draws by luminance, never where it is negative) and BSDF sampling (which meets
    them) disagreed: on a floor and a metal ball, light sampling alone 0.492, BSDF sampling alone 0.485, MIS
    0.482, pixels down to -2.6.  Read as 0, the three agree to 1 % and no pixel is negative."""
    from rtc.renderer.host.render import Renderer
    from tests.accuracy.test_path_lights import _floor_scene, _mean
    sky = np.full((16, 32, 3), 0.5, np.float32)
    sky[3:5, 10:13] = (40.0, 30.0, 20.0)
    sky[1:6, 16:30] = -0.8
    _exr(tmp_path / 'band.exr', sky)
    stage = _stage()
    _tri_mesh(stage, '/World/Floor', [(-5, 0, -5), (5, 0, -5), (5, 0, 5), (-5, 0, 5)], [4], [0, 3, 2, 1])
    UsdLux.DomeLight.Define(stage, '/World/Sky').CreateTextureFileAttr(Sdf.AssetPath(str(tmp_path / 'band.exr')))
    UsdGeom.Camera.Define(stage, '/World/Cam').AddTranslateOp().Set(Gf.Vec3d(0, 1, 3))
    desc = read_stage(stage)
    warned = [w for w in desc.warnings if 'negative' in w]
    assert len(warned) == 1 and '/World/Sky' in warned[0] and 'band.exr' in warned[0] and ' 70 ' in warned[0]
    [dome] = desc.lights
    assert np.array_equal(desc.textures[dome.texture].pixels, np.maximum(sky, 0.0))
    with Renderer(_floor_scene([dome], desc.textures)) as r:
        est = {s: _mean(r, s, spp) for s, spp in (('nee', 256), ('bsdf', 1024), ('mis', 256))}
    for s, img in est.items():
        assert img.min() >= 0.0, s
        assert img.mean() == pytest.approx(est['mis'].mean(), rel=0.01), s


def test_unauthored_preview_surface_inputs_take_the_specs_defaults():
    """A UsdPreviewSurface with no input authored reads as the spec defines it: every default the reader keeps
    against the shader's own definition in Sdr (usd-core's `usdShaders`: roughness 0.5, not 0)."""
    from pxr import Sdr
    st = Usd.Stage.CreateInMemory()
    mesh = UsdGeom.Mesh.Define(st, '/M')
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    mat = UsdShade.Material.Define(st, '/Mat')
    sh = UsdShade.Shader.Define(st, '/Mat/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    desc = read_stage(st)
    m = desc.materials[desc.containers[0].meshes[0].material]
    spec = Sdr.Registry().GetShaderNodeByIdentifier('UsdPreviewSurface')
    default = lambda name: spec.GetShaderInput(name).GetDefaultValue()
    for name, value in (('diffuseColor', m.diffuse), ('specularColor', m.specular), ('emissiveColor', m.emission)):
        assert value == pytest.approx(tuple(default(name)), abs=1e-7), name
    for name, value in (('roughness', m.roughness), ('metallic', m.metallic), ('ior', m.ior), ('opacity', m.opacity),
                        ('clearcoat', m.clearcoat), ('clearcoatRoughness', m.clearcoat_roughness),
                        ('useSpecularWorkflow', m.use_specular_workflow)):
        assert value == pytest.approx(float(default(name)), abs=1e-7), name
