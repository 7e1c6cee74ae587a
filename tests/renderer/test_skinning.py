"""UsdSkel: skinned gprims are drawn posed at the frame's time (`usd/skinning.py`): joints (linear and dual-quaternion
skinning, rigid influences), blend shapes with in-betweens, placed by the skeleton's space and the gprim's own;
against closed forms and against UsdSkel's own baking (`UsdSkel.BakeSkinning`)."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt

from rtc.renderer.usd.geometry_cache import GeometryCache
from rtc.renderer.usd.stage import read_stage

# a two-joint arm: the elbow 2 above the shoulder; the animation turns the elbow 90 degrees about x at t = 10
LOWER = [(-0.5, -0.5, 0.0), (0.5, -0.5, 0.0), (0.5, 0.5, 0.0), (-0.5, 0.5, 0.0)]
UPPER = [(-0.5, -0.5, 3.0), (0.5, -0.5, 3.0), (0.5, 0.5, 3.0), (-0.5, 0.5, 3.0)]
ROOT_AT = (5.0, 0.0, 0.0)
MESH_AT = (0.0, 1.0, 0.0)


def _stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    return st


def _arm(st, root='/Model', method=None, rigid=False, normals=False, mesh_name='Arm'):
    """A SkelRoot at ROOT_AT; its Skeleton; a mesh at MESH_AT whose geomBindTransform is MESH_AT too (so its bind
    pose is where it stands), the lower square bound to the shoulder, the upper one to the elbow (or, `rigid`, the
    whole mesh to the elbow)."""
    model = UsdSkel.Root.Define(st, root)
    model.AddTranslateOp().Set(Gf.Vec3d(*ROOT_AT))
    skel = UsdSkel.Skeleton.Define(st, f'{root}/Skel')
    skel.CreateJointsAttr(['Shoulder', 'Shoulder/Elbow'])
    skel.CreateBindTransformsAttr([Gf.Matrix4d(1), Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 0, 2))])
    skel.CreateRestTransformsAttr([Gf.Matrix4d(1), Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 0, 2))])
    anim = UsdSkel.Animation.Define(st, f'{root}/Skel/Anim')
    anim.CreateJointsAttr(['Shoulder/Elbow'])
    anim.CreateTranslationsAttr([Gf.Vec3f(0, 0, 2)])
    anim.CreateScalesAttr([Gf.Vec3h(1, 1, 1)])
    rotations = anim.CreateRotationsAttr()
    rotations.Set([Gf.Quatf(1, 0, 0, 0)], 0.0)
    rotations.Set([Gf.Quatf(math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0)], 10.0)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(model.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])
    mesh = UsdGeom.Mesh.Define(st, f'{root}/{mesh_name}')
    mesh.AddTranslateOp().Set(Gf.Vec3d(*MESH_AT))
    local = np.array(LOWER + UPPER) - MESH_AT
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in local])
    mesh.CreateFaceVertexCountsAttr([4, 4, 4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    if normals:
        mesh.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 8)
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    if rigid:
        binding.CreateJointIndicesPrimvar(True, 1).Set([1])
        binding.CreateJointWeightsPrimvar(True, 1).Set([1.0])
    else:
        binding.CreateJointIndicesPrimvar(False, 1).Set([0] * 4 + [1] * 4)
        binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * 8)
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d().SetTranslate(Gf.Vec3d(*MESH_AT)))
    if method:
        binding.CreateSkinningMethodAttr(method)
    return mesh


def _bent(points):
    """The elbow's points turned 90 degrees about x around the elbow (0, 0, 2), in the skeleton's space."""
    p = np.asarray(points, np.float64) - (0.0, 0.0, 2.0)
    return np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1) + (0.0, 0.0, 2.0)


def _meshes(st, time, **kw):
    desc = read_stage(st, time=time, **kw)
    return desc, {m.path: m for c in desc.containers for m in c.meshes}


@pytest.mark.parametrize('method', [None, 'classicLinear', 'dualQuaternion'])
def test_an_arm_bends_at_its_elbow(method):
    """Bind pose at t = 0; at t = 10 the upper square turned 90 degrees about the elbow, the lower one where it was;
    world points: the skeleton's space moved by the SkelRoot (the mesh's own transform is undone and redone)."""
    st = _stage()
    _arm(st, method=method)
    _, at0 = _meshes(st, 0.0)
    np.testing.assert_allclose(at0['/Model/Arm'].points, np.array(LOWER + UPPER) + ROOT_AT, atol=1e-6)
    desc, at10 = _meshes(st, 10.0)
    want = np.concatenate([np.array(LOWER), _bent(UPPER)]) + ROOT_AT
    np.testing.assert_allclose(at10['/Model/Arm'].points, want, atol=1e-6)
    assert not [w for w in desc.warnings if 'Arm' in w]


def test_rigid_influences_move_the_whole_gprim():
    st = _stage()
    _arm(st, rigid=True)
    _, at10 = _meshes(st, 10.0)
    np.testing.assert_allclose(at10['/Model/Arm'].points, _bent(LOWER + UPPER) + ROOT_AT, atol=1e-6)


def test_a_skinned_mesh_ignores_its_authored_normals():
    """Its normals are the posed faces' (flat: subdivisionScheme none), not the authored +z."""
    st = _stage()
    _arm(st, normals=True)
    _, at10 = _meshes(st, 10.0)
    mesh = at10['/Model/Arm']
    assert mesh.normals is None                     # flat faces: the integrator uses the geometric normal
    _, unposed = _meshes(_static_copy(st), 10.0)
    assert unposed['/Model/Arm'].normals is not None  # (without a skeleton the authored normals are read)


def _static_copy(st):
    """The stage without its skeleton binding."""
    layer = _exported(st)
    copy = Usd.Stage.Open(layer)
    UsdSkel.BindingAPI(copy.GetPrimAtPath('/Model')).GetSkeletonRel().ClearTargets(True)
    return copy


def _exported(st):
    layer = Sdf.Layer.CreateAnonymous('.usda')
    layer.TransferContent(st.GetRootLayer())
    return layer


def test_blend_shapes_with_an_inbetween():
    """Weight w of a shape with offset o and an in-between at 0.5 with offset h: w h / 0.5 below 0.5,
    h + (w - 0.5) / 0.5 (o - h) above; points the shape does not list stay."""
    st = _stage()
    model = UsdSkel.Root.Define(st, '/Model')
    skel = UsdSkel.Skeleton.Define(st, '/Model/Skel')
    anim = UsdSkel.Animation.Define(st, '/Model/Skel/Anim')
    anim.CreateBlendShapesAttr(['smile'])
    weights = anim.CreateBlendShapeWeightsAttr()
    for t, w in ((0.0, 0.25), (1.0, 0.75), (2.0, 1.0)):
        weights.Set(Vt.FloatArray([w]), t)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(model.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])
    mesh = UsdGeom.Mesh.Define(st, '/Model/Face')
    base = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], np.float64)
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in base])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    shape = UsdSkel.BlendShape.Define(st, '/Model/Face/smile')
    o, h = np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 0.4])
    shape.CreateOffsetsAttr([Gf.Vec3f(*o)])
    shape.CreatePointIndicesAttr([2])
    shape.CreateInbetween('half').SetWeight(0.5)
    shape.GetInbetween('half').SetOffsets(Vt.Vec3fArray([Gf.Vec3f(*h)]))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateBlendShapesAttr(['smile'])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    for t, w in ((0.0, 0.25), (1.0, 0.75), (2.0, 1.0)):
        want = base.copy()
        want[2] += w / 0.5 * h if w <= 0.5 else h + (w - 0.5) / 0.5 * (o - h)
        _, meshes = _meshes(st, t)
        np.testing.assert_allclose(meshes['/Model/Face'].points, want, atol=1e-6)


@pytest.mark.parametrize('method', ['classicLinear', 'dualQuaternion'])
def test_two_influences_a_point_as_usdskel_bakes_them(method):
    """Points weighted between the two joints, posed as `UsdSkel.BakeSkinning` writes them (then placed by the
    mesh's own transform)."""
    st = _stage()
    mesh = _arm(st, method=method)
    binding = UsdSkel.BindingAPI(mesh.GetPrim())
    binding.CreateJointIndicesPrimvar(False, 2).Set([0, 1] * 8)
    w = np.linspace(0.1, 0.9, 8)
    binding.CreateJointWeightsPrimvar(False, 2).Set(Vt.FloatArray(list(np.stack([1 - w, w], 1).reshape(-1))))
    UsdSkel.Animation(st.GetPrimAtPath('/Model/Skel/Anim')).GetRotationsAttr().Set(
        [Gf.Quatf(math.cos(0.3), 0, math.sin(0.3), 0)], 5.0)   # (BakeSkinning writes at the animation's samples)
    for t in (5.0, 10.0):
        _, meshes = _meshes(st, t)
        layer = _exported(st)
        baked = Usd.Stage.Open(layer)
        assert UsdSkel.BakeSkinning(UsdSkel.Root(baked.GetPrimAtPath('/Model')), Gf.Interval(t, t))
        local = np.asarray(UsdGeom.Mesh(baked.GetPrimAtPath('/Model/Arm')).GetPointsAttr().Get(t), np.float64)
        xf = np.asarray(UsdGeom.Xformable(baked.GetPrimAtPath('/Model/Arm')).ComputeLocalToWorldTransform(t))
        np.testing.assert_allclose(meshes['/Model/Arm'].points, local @ xf[:3, :3] + xf[3, :3], atol=1e-5)


def test_instanced_skeletal_models_are_each_posed():
    """A SkelRoot inside an instanceable prim, placed twice: its prototype is posed once, both instances show it."""
    st = _stage()
    _arm(st, root='/Proto')
    st.GetPrimAtPath('/Proto').SetSpecifier(Sdf.SpecifierClass)
    for k, x in enumerate((0.0, 20.0)):
        inst = st.DefinePrim(f'/I{k}')                  # (a SkelRoot, by its reference)
        inst.GetReferences().AddInternalReference('/Proto')
        UsdGeom.Xformable(inst).AddTranslateOp(opSuffix='place').Set(Gf.Vec3d(x, 0, 0))
        inst.SetInstanceable(True)
    desc = read_stage(st, time=10.0)
    (k,) = [k for k, c in enumerate(desc.containers) if c.meshes]
    want = np.concatenate([np.array(LOWER), _bent(UPPER)])
    np.testing.assert_allclose(desc.containers[k].meshes[0].points, want, atol=1e-6)
    placed = desc.instances.matrices[desc.instances.container == k, 0]
    assert sorted(placed[:, 0, 3]) == [ROOT_AT[0], ROOT_AT[0] + 20.0]   # (column vectors: the translations' x)


def test_a_shot_poses_a_static_mesh_at_each_frame():
    """The mesh's own attributes never change, its skeleton's animation does: the shot's geometry cache must not
    hand out the last frame's pose."""
    st = _stage()
    _arm(st)
    cache = GeometryCache()
    _, at0 = _meshes(st, 0.0, geometry=cache)
    _, at10 = _meshes(st, 10.0, geometry=cache)
    np.testing.assert_allclose(at0['/Model/Arm'].points[4:], np.array(UPPER) + ROOT_AT, atol=1e-6)
    np.testing.assert_allclose(at10['/Model/Arm'].points[4:], _bent(UPPER) + ROOT_AT, atol=1e-6)


def test_a_pose_that_is_not_finite_keeps_the_bind_pose_and_says_so():
    st = _stage()
    _arm(st)
    UsdSkel.Animation(st.GetPrimAtPath('/Model/Skel/Anim')).GetTranslationsAttr().Set([Gf.Vec3f(0, float('nan'), 2)])
    desc, at10 = _meshes(st, 10.0)
    np.testing.assert_allclose(at10['/Model/Arm'].points, np.array(LOWER + UPPER) + ROOT_AT, atol=1e-6)
    assert ['/Model/Arm: its posed points are not finite; drawn in its bind pose'] == \
        [w for w in desc.warnings if 'Arm' in w]


def test_instances_animated_each_their_own_way_are_each_drawn_in_their_own_pose():
    """An animation bound on each instance prim (UsdSkel's per-instance animation): the instances of one prototype
    posed differently are drawn each as its own geometry (walked through their instance proxies), each in its pose,
    with its own material and placement; the rest of the stage stays instanced."""
    st = _stage()
    _arm(st, root='/Proto')
    st.GetPrimAtPath('/Proto').SetSpecifier(Sdf.SpecifierClass)
    UsdSkel.BindingAPI(st.GetPrimAtPath('/Proto/Skel')).GetAnimationSourceRel().ClearTargets(True)
    still = UsdSkel.Animation.Define(st, '/Still')
    still.CreateJointsAttr(['Shoulder/Elbow'])
    still.CreateTranslationsAttr([Gf.Vec3f(0, 0, 2)])
    still.CreateRotationsAttr([Gf.Quatf(1, 0, 0, 0)])
    still.CreateScalesAttr([Gf.Vec3h(1, 1, 1)])
    for k, anim in enumerate(('/Proto/Skel/Anim', '/Still')):
        inst = st.DefinePrim(f'/I{k}')
        inst.GetReferences().AddInternalReference('/Proto')
        UsdSkel.BindingAPI.Apply(inst).CreateAnimationSourceRel().SetTargets([anim])
        UsdGeom.Xformable(inst).AddTranslateOp(opSuffix='place').Set(Gf.Vec3d(10.0 * k, 0, 0))
        inst.SetInstanceable(True)
    UsdGeom.Cube.Define(st, '/Box/Cube')
    st.GetPrimAtPath('/Box').SetSpecifier(Sdf.SpecifierClass)
    for k in range(2):
        crate = st.DefinePrim(f'/Crate{k}')
        crate.GetReferences().AddInternalReference('/Box')
        crate.SetInstanceable(True)
    desc = read_stage(st, time=10.0)
    meshes = {m.path: m for c in desc.containers for m in c.meshes}
    np.testing.assert_allclose(meshes['/I0/Arm'].points, np.concatenate([np.array(LOWER), _bent(UPPER)]) + ROOT_AT,
                               atol=1e-6)
    np.testing.assert_allclose(meshes['/I1/Arm'].points, np.array(LOWER + UPPER) + ROOT_AT + (10.0, 0.0, 0.0),
                               atol=1e-6)
    (crates,) = [c.key for c in desc.containers for m in c.meshes if m.path.endswith('/Cube')]
    assert crates != '/'                            # (the crates are still instances of their prototype)
    assert len([m for m in meshes if m.endswith('/Arm')]) == 2
    assert not [w for w in desc.warnings if 'Arm' in w]
