"""Stage reads of a shot's frames reuse the static gprims (renderer/usd/geometry_cache.py): a mesh
with time-varying attributes is converted again at every frame, a static one once, and the
descriptions (and so the images) are the same as without the cache."""
import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, Vt

from rtc.renderer.usd import geometry_cache
from rtc.renderer.usd.geometry_cache import GeometryCache, is_static
from rtc.renderer.usd.stage import read_stage


def _quad(stage, path, z=0.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([(-1, -1, z), (1, -1, z), (1, 1, z), (-1, 1, z)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh


@pytest.fixture
def stage():
    """/Static: a quad that never changes; /Moving: a static quad whose xformOp is animated (baked
    into its points in the root container: another matrix each frame); /Waving: a quad whose points
    are animated; /Split: a static quad pair whose materialBind subset is animated."""
    s = Usd.Stage.CreateInMemory()
    s.SetStartTimeCode(1)
    s.SetEndTimeCode(3)
    UsdGeom.Camera.Define(s, '/Cam').AddTranslateOp().Set(Gf.Vec3d(0, 0, 10))
    _quad(s, '/Static')
    op = _quad(s, '/Moving', z=-1).AddTranslateOp()
    for f in (1, 2, 3):
        op.Set(Gf.Vec3d(f, 0, 0), f)
    waving = _quad(s, '/Waving', z=-2)
    for f in (1, 2, 3):
        waving.GetPointsAttr().Set(Vt.Vec3fArray([(-1, -1, -2), (1, -1, -2), (1, 1, -2 + 0.1 * f), (-1, 1, -2)]), f)
    split = UsdGeom.Mesh.Define(s, '/Split')
    split.CreatePointsAttr([(0, 0, -4), (1, 0, -4), (1, 1, -4), (0, 1, -4), (2, 0, -4), (2, 1, -4)])
    split.CreateFaceVertexCountsAttr([4, 4])
    split.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 2])
    split.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    subset = UsdGeom.Subset.CreateGeomSubset(split, 'left', UsdGeom.Tokens.face, Vt.IntArray([0]), 'materialBind')
    for f in (1, 2, 3):
        subset.GetIndicesAttr().Set(Vt.IntArray([0] if f % 2 else [1]), f)
    return s


def _meshes(desc) -> dict:
    return {m.path: m for c in desc.containers for m in c.meshes}


def test_static_and_time_varying_gprims_are_told_apart(stage):
    assert is_static(stage.GetPrimAtPath('/Static'))
    assert is_static(stage.GetPrimAtPath('/Moving'))          # only its transform moves (part of the key)
    assert not is_static(stage.GetPrimAtPath('/Waving'))      # animated points
    assert not is_static(stage.GetPrimAtPath('/Split'))       # an animated GeomSubset


def test_a_static_mesh_is_converted_once_a_time_varying_one_every_frame(stage, monkeypatch):
    converted = []
    real = geometry_cache.convert_gprim
    monkeypatch.setattr(geometry_cache, 'convert_gprim',
                        lambda prim, *a: converted.append(str(prim.GetPath())) or real(prim, *a))
    cache = GeometryCache()
    for f in (1, 2, 3):
        read_stage(stage, time=f, geometry=cache)
    assert converted.count('/Static') == 1
    assert converted.count('/Moving') == 3                    # static, but placed anew in every frame
    assert converted.count('/Waving') == 3 and converted.count('/Split') == 3
    assert (cache.misses, cache.hits, cache.varying) == (4, 2, 6)
    assert sorted(cache.kept) == ['/Moving', '/Static']             # one placement of each kept, not one per frame


def test_reads_with_the_cache_are_the_reads_without_it(stage):
    cache = GeometryCache()
    for f in (1, 2, 3):
        got, want = read_stage(stage, time=f, geometry=cache), read_stage(stage, time=f)
        assert [c.key for c in got.containers] == [c.key for c in want.containers]
        a, b = _meshes(got), _meshes(want)
        assert sorted(a) == sorted(b)
        for path in a:
            for field in ('points', 'triangles', 'normals', 'uvs', 'material', 'double_sided'):
                x, y = getattr(a[path], field), getattr(b[path], field)
                assert (x is None and y is None) or np.array_equal(x, y), (f, path, field)
        assert np.array_equal(got.instances.matrices, want.instances.matrices)
        assert got.camera.matrix.tobytes() == want.camera.matrix.tobytes()
    # what changes does change: the waving quad's corner and the subset's faces
    one, three = _meshes(read_stage(stage, time=1, geometry=cache)), _meshes(read_stage(stage, time=3, geometry=cache))
    assert one['/Waving'].points[2, 2] != three['/Waving'].points[2, 2]
    assert one['/Static'].points is three['/Static'].points                   # kept, not read again


def test_kept_records_are_not_shared_mutably(stage):
    cache = GeometryCache()
    a = _meshes(read_stage(stage, time=1, geometry=cache))['/Static']
    b = _meshes(read_stage(stage, time=2, geometry=cache))['/Static']
    assert a is not b                                   # the reader sets each record's material
    with pytest.raises(ValueError):
        b.points[0, 0] = 7.0                            # shared arrays are read-only


def test_a_conversion_warning_is_given_again_when_kept(stage):
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath('/Static'))
    mesh.CreateNormalsAttr([(0, 0, 1)] * 3)             # 3 normals, 4 points: warned, then ignored
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    cache = GeometryCache()
    said = [[w for w in read_stage(stage, time=f, geometry=cache).warnings if 'normals' in w] for f in (1, 2)]
    assert said[0] and said[0] == said[1] and cache.hits == 1


def test_another_stage_empties_the_cache(stage):
    cache = GeometryCache()
    read_stage(stage, time=1, geometry=cache)
    other = Usd.Stage.CreateInMemory()
    _quad(other, '/Static', z=5.0)                      # the same path, other points
    desc = read_stage(other, time=1, geometry=cache)
    assert _meshes(desc)['/Static'].points[0, 2] == 5.0 and cache.hits == 0
