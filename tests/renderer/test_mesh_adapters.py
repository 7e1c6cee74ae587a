"""Gprims Hydra draws as meshes of their own points (`usd/mesh_adapters.py`): a TetMesh as its surface faces, a
NurbsPatch as its control hull; and a Cube's displayColor varying over it, read in the order of Hydra's cube
(`usd/geometry._cube_colours`)."""
import re

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.geometry import GeometryError, convert_gprim
from rtc.renderer.usd.stage import read_stage

T = Usd.TimeCode.Default()
TET_POINTS = [(0, 0, 0), (2, 0, 0), (0, 2, 0), (0, 0, 2), (0, 0, -2)]
TETS = [(0, 1, 2, 3), (0, 2, 1, 4)]                 # two tetrahedra sharing the face (0, 1, 2)
SURFACE = [(0, 1, 3), (0, 2, 4), (0, 3, 2), (0, 4, 1), (1, 2, 3), (2, 1, 4)]   # as in OpenUSD's tetMesh.usda


def _stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    return st


def _convert(prim, m=None):
    warnings = []
    records = convert_gprim(prim, np.eye(4) if m is None else m, T, warnings.append)
    return records, warnings


def _tet_mesh(st, path='/Tet', surface=True, left=False):
    tet = UsdGeom.TetMesh.Define(st, path)
    tet.CreatePointsAttr(TET_POINTS)
    tet.CreateTetVertexIndicesAttr([Gf.Vec4i(*t) for t in TETS])
    if surface:
        tet.CreateSurfaceFaceVertexIndicesAttr([Gf.Vec3i(*f) for f in SURFACE])
    if left:
        tet.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    return tet


def _enclosed_volume(points, triangles):
    """Divergence theorem: the volume a closed triangle surface encloses, positive when its faces wind
    counter-clockwise seen from outside."""
    p = np.asarray(points, np.float64)[triangles]
    return float(np.einsum('ij,ij->i', p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def _tet_volume(points, tets):
    p = np.asarray(points, np.float64)[np.asarray(tets)]
    return float(np.abs(np.linalg.det(p[:, 1:] - p[:, :1])).sum() / 6.0)


@pytest.mark.parametrize('left', [False, True])
def test_tet_mesh_draws_its_authored_surface_faces(left):
    """The authored surface faces, wound outwards (a leftHanded TetMesh's reversed), smooth normals (the
    catmullClark mesh usdImaging makes of it), nothing warned."""
    st = _stage()
    tet = _tet_mesh(st, left=left)
    if left:                                         # the same solid, mirrored faces' indices
        tet.GetSurfaceFaceVertexIndicesAttr().Set([Gf.Vec3i(f[0], f[2], f[1]) for f in SURFACE])
    (mesh,), warnings = _convert(tet.GetPrim())
    assert warnings == []
    assert len(mesh.triangles) == 6
    np.testing.assert_allclose(mesh.points, TET_POINTS)
    assert _enclosed_volume(mesh.points, mesh.triangles) == pytest.approx(_tet_volume(TET_POINTS, TETS), rel=1e-12)
    assert mesh.normals is not None and mesh.normals.shape == (6, 3, 3)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=2), 1.0, rtol=1e-6)


def test_tet_mesh_without_surface_faces_gets_them_computed_and_warned():
    """Without surfaceFaceVertexIndices the faces that no two tetrahedra share are computed; they enclose the
    tetrahedra's volume, wound outwards."""
    st = _stage()
    tet = _tet_mesh(st, surface=False)
    tet.AddTranslateOp().Set(Gf.Vec3d(1.0, 2.0, 3.0))
    m = np.eye(4)
    m[:3, 3] = (1.0, 2.0, 3.0)
    (mesh,), warnings = _convert(tet.GetPrim(), m)
    assert len(mesh.triangles) == 6
    assert sorted(tuple(sorted(t)) for t in mesh.triangles) == sorted(tuple(sorted(f)) for f in SURFACE)
    shifted = mesh.points - (1.0, 2.0, 3.0)
    assert _enclosed_volume(shifted, mesh.triangles) == pytest.approx(_tet_volume(TET_POINTS, TETS), rel=1e-12)
    assert len(warnings) == 1 and 'surfaceFaceVertexIndices not authored; the 6 surface faces of its 2 ' \
        'tetrahedra computed' in warnings[0]


@pytest.mark.parametrize('edit, message', [
    (lambda t: (t.GetSurfaceFaceVertexIndicesAttr().Block(), t.GetTetVertexIndicesAttr().Block()),
     'a TetMesh with neither surfaceFaceVertexIndices nor tetVertexIndices'),
    (lambda t: (t.GetSurfaceFaceVertexIndicesAttr().Block(), t.GetTetVertexIndicesAttr().Set([Gf.Vec4i(0, 1, 2, 9)])),
     'tetVertexIndices out of range (5 points)'),
    (lambda t: t.GetSurfaceFaceVertexIndicesAttr().Set([Gf.Vec3i(0, 1, 7)]), 'faceVertexIndices out of range'),
    (lambda t: t.GetPointsAttr().Set([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, float('nan')), (0, 0, -1)]),
     'non-finite points'),
])
def test_bad_tet_meshes_are_refused_by_name(edit, message):
    st = _stage()
    tet = _tet_mesh(st)
    edit(tet)
    with pytest.raises(GeometryError, match=re.escape(f"/Tet: {message}")):
        _convert(tet.GetPrim())


def test_tet_mesh_colours_and_topology_at_the_frame_time():
    """Uniform displayColor is one colour a surface face; surface faces sampled in time are read at the frame's
    time (OpenUSD's tetMesh.usda animates them)."""
    st = _stage()
    tet = _tet_mesh(st)
    tet.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set([(k / 5.0, 1.0 - k / 5.0, 0.5) for k in range(6)])
    faces = tet.GetSurfaceFaceVertexIndicesAttr()          # (time samples win over the default value)
    faces.Set([Gf.Vec3i(*f) for f in SURFACE], 0.0)
    faces.Set([Gf.Vec3i(*f) for f in SURFACE[:4]], 10.0)
    warnings = []
    (mesh,) = convert_gprim(tet.GetPrim(), np.eye(4), Usd.TimeCode(0.0), warnings.append)
    np.testing.assert_allclose(mesh.colors[:, 0, 0], [k / 5.0 for k in range(6)], rtol=1e-6)
    np.testing.assert_allclose(mesh.colors[:, 2], mesh.colors[:, 0])
    (later,) = convert_gprim(tet.GetPrim(), np.eye(4), Usd.TimeCode(10.0), warnings.append)
    assert len(later.triangles) == 4


def _patch(st, nu, nv, points, path='/Patch'):
    patch = UsdGeom.NurbsPatch.Define(st, path)
    patch.CreateUVertexCountAttr(nu)
    patch.CreateVVertexCountAttr(nv)
    patch.CreatePointsAttr(points)
    patch.CreateUOrderAttr(2)
    patch.CreateVOrderAttr(2)
    return patch


def test_nurbs_patch_draws_its_control_hull():
    """A quad a cell of the u-fastest control grid, split (i, i+1, i+nu+1), (i, i+nu+1, i+nu), as usdImaging's
    adapter lays them out; a flat grid's hull has the grid's area; warned."""
    nu, nv = 4, 3
    xs, zs = np.array([0.0, 0.5, 1.5, 3.0]), np.array([0.0, 1.0, 2.5])
    points = [(float(x), 0.0, float(z)) for z in zs for x in xs]
    st = _stage()
    patch = _patch(st, nu, nv, points)
    (mesh,), warnings = _convert(patch.GetPrim())
    assert len(mesh.triangles) == 2 * (nu - 1) * (nv - 1)
    cells = [(j * nu + i) for j in range(nv - 1) for i in range(nu - 1)]
    want = []
    for c in cells:
        want += [(c, c + 1, c + nu + 1), (c, c + nu + 1, c + nu)]
    assert [tuple(t) for t in mesh.triangles] == want
    p = mesh.points[mesh.triangles]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    assert area == pytest.approx(3.0 * 2.5, rel=1e-12)
    assert warnings == ['/Patch: NurbsPatch drawn as its control hull (4 x 3 points), as usdImaging draws it; its '
                        'knots, weights and trim curves are not used']


@pytest.mark.parametrize('nu, nv, npoints, message', [
    (1, 3, 3, 'uVertexCount 1 and vVertexCount 3 make no control hull'),
    (3, 3, 8, '8 points for a 3 x 3 control grid'),
])
def test_bad_nurbs_patches_are_refused_by_name(nu, nv, npoints, message):
    st = _stage()
    patch = _patch(st, nu, nv, [(float(k), 0.0, 0.0) for k in range(npoints)])
    with pytest.raises(GeometryError, match='^/Patch: ' + message):
        _convert(patch.GetPrim())


def test_tet_mesh_and_nurbs_patch_are_read_from_a_stage_not_skipped():
    st = _stage()
    _tet_mesh(st)
    _patch(st, 2, 2, [(0, 0, 0), (1, 0, 0), (0, 0, 1), (1, 0, 1)])
    desc = read_stage(st)
    paths = {m.path: len(m.triangles) for c in desc.containers for m in c.meshes}
    assert paths == {'/Tet': 6, '/Patch': 2}
    assert desc.skipped == []


# Hydra's cube, written out from GeomUtilCuboidMeshGenerator: the corners in order and each face's outward normal
HYDRA_CORNERS = [(1, 1, 1), (-1, 1, 1), (-1, -1, 1), (1, -1, 1), (-1, -1, -1), (-1, 1, -1), (1, 1, -1), (1, -1, -1)]
HYDRA_FACES = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 6, 5, 1), (4, 7, 3, 2), (0, 3, 7, 6), (4, 2, 1, 5)]
HYDRA_NORMALS = [(0, 0, 1), (0, 0, -1), (0, 1, 0), (0, -1, 0), (1, 0, 0), (-1, 0, 0)]


def _cube(st, interpolation, values, size=2.0):
    cube = UsdGeom.Cube.Define(st, '/Cube')
    cube.CreateSizeAttr(size)
    cube.CreateDisplayColorPrimvar(interpolation).Set(values)
    return cube


def _face_of(mesh):
    p = mesh.points[mesh.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    return np.array([HYDRA_NORMALS.index(tuple(np.rint(v).astype(int))) for v in n])


@pytest.mark.parametrize('mirror', [False, True])
def test_cube_uniform_colours_are_hydras_faces(mirror):
    values = [(k / 6.0, 0.5, 1.0 - k / 6.0) for k in range(6)]
    st = _stage()
    m = np.diag([-1.0 if mirror else 1.0, 1.0, 1.0, 1.0])
    (mesh,), warnings = _convert(_cube(st, 'uniform', values, size=3.0).GetPrim(), m)
    face = _face_of(mesh)
    if mirror:                                       # the mirrored cube's +x face is the cube's own -x face
        face = np.array([{4: 5, 5: 4}.get(f, f) for f in face])
    assert warnings == [] and len(mesh.triangles) == 12
    np.testing.assert_allclose(mesh.colors, np.repeat(np.array(values)[face][:, None], 3, axis=1), rtol=1e-6)


def test_cube_vertex_and_face_varying_colours_follow_hydras_corners():
    st = _stage()
    vertex = [(k / 8.0, 1.0 - k / 8.0, 0.25) for k in range(8)]
    (mesh,), _ = _convert(_cube(st, 'vertex', vertex).GetPrim())
    corner = [HYDRA_CORNERS.index(tuple(np.sign(p).astype(int))) for p in mesh.points[mesh.triangles].reshape(-1, 3)]
    np.testing.assert_allclose(mesh.colors.reshape(-1, 3), np.array(vertex)[corner], rtol=1e-6)
    varying = [(k / 24.0, 0.5, 0.5) for k in range(24)]
    (mesh,), _ = _convert(_cube(st, 'faceVarying', varying).GetPrim())
    face = _face_of(mesh)
    for t, f in enumerate(face):
        for c in range(3):
            v = HYDRA_CORNERS.index(tuple(np.sign(mesh.points[mesh.triangles[t, c]]).astype(int)))
            assert mesh.colors[t, c, 0] == pytest.approx(varying[4 * f + HYDRA_FACES[f].index(v)][0], rel=1e-6)


def test_cube_colours_that_fit_no_interpolation_are_averaged_and_warned():
    st = _stage()
    values = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0)]
    (mesh,), warnings = _convert(_cube(st, 'uniform', values).GetPrim())
    np.testing.assert_allclose(mesh.colors, np.full((12, 3, 3), 0.5) * [1.0, 1.0, 0.5], rtol=1e-6)
    assert warnings == ['/Cube: primvars:displayColor: 4 values do not match interpolation "uniform" on a cube '
                        '(6 faces, 8 points, 24 face corners); their mean colour used']


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_cube_seen_face_on_shows_its_faces_colour(integrator):
    """Seen along -z under the default lights, the cube shows its +z face: Hydra's first face's colour."""
    st = _stage()
    values = [(0.2, 0.7, 0.1), (1, 0, 0), (1, 0, 0), (1, 0, 0), (1, 0, 0), (1, 0, 0)]
    _cube(st, 'uniform', values)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 6.0))
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(10.0)
    cam.CreateVerticalApertureAttr(10.0)
    with Renderer(read_stage(st), threads=1) as r:
        image = r.render(RenderOptions(width=16, height=16, spp=4, integrator=integrator, max_depth=1,
                                       threads=1)).image.astype(np.float64)
    centre = image[6:10, 6:10].reshape(-1, 3)
    assert centre[:, 1].min() > 0.05
    # the colour scales the diffuse part; the material's specular layer adds the same to every channel
    np.testing.assert_allclose((centre[:, 0] - centre[:, 2]) / (centre[:, 1] - centre[:, 2]), 0.1 / 0.6, rtol=1e-4)
