"""UsdSkel: skinned gprims drawn posed at the frame's time, as usdview, Karma and RenderMan draw them (the points
as authored are the bind pose).

For every SkelRoot the stage walk met (`InstanceGraph.skel_roots`; none, nothing is computed), UsdSkel's own
queries (`UsdSkel.Cache`) give each skeleton its skinning transforms at the time and each bound point-based gprim
(Mesh, Points, BasisCurves, NurbsCurves, TetMesh, NurbsPatch) its deformed points:

1. blend shapes first, in the gprim's space (the skeleton's animation's weights, in-betweens included:
   `UsdSkel.BlendShapeQuery`);
2. then the joints: linear or dual-quaternion skinning by `skel:skinningMethod` (`SkinningQuery.ComputeSkinnedPoints`),
   or, for influences of constant interpolation, the one rigid transform (`ComputeSkinnedTransform`); the result is
   in the skeleton's space, and is carried back to the gprim's (the inverse of its local-to-world after the
   skeleton's), so that the reader places it with the gprim's own transform as any other gprim
   (`UsdSkel.BakeSkinning` writes them so too).

Instances of one skeletal model posed alike share their prototype's posed gprims; instances posed each their own
way (an animation bound on each instance prim) are drawn each as its own geometry: the reader walks them again
through their instance proxies (`Poses.expand`, `InstanceGraph.expand`).

A skinned mesh's authored normals are not used (UsdSkelImaging does not skin them either: Storm computes them from
the posed points). The Skeleton prims themselves are not drawn (usdview draws their bones as a guide; renderers do
not). A gprim that cannot be posed (a query fails, a non-finite transform) keeps its bind pose, warned.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from pxr import Gf, Tf, Usd, UsdGeom, UsdSkel, Vt

Warn = Callable[[str], None]
PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


class Poses:
    """The posed points of a stage's skinned gprims (`posed_points`); `expand`: the instance prims whose
    prototype's instances are posed differently (an animation bound per instance), which the reader walks through
    their instance proxies, each its own geometry."""

    def __init__(self):
        self.points: dict = {}          # gprim path (a prototype's, an instance proxy's when posed otherwise) -> points
        self.instances: dict = {}       # prototype gprim path -> the instance prims whose proxies of it are posed
        self.differ: set = set()        # prototype gprim paths whose instances are not all posed alike

    def get(self, prim: Usd.Prim):
        """The posed points of a gprim as walked (on the stage, in a prototype, or an instance proxy), or None."""
        path = str(prim.GetPath())
        if path in self.points:
            return self.points[path]
        return self.points.get(str(prim.GetPrimInPrototype().GetPath())) if prim.IsInstanceProxy() else None

    @property
    def expand(self) -> frozenset:
        return frozenset(p for key in self.differ for p in self.instances[key])

    def add(self, gprim: Usd.Prim, points: np.ndarray) -> None:
        if not gprim.IsInstanceProxy():
            self.points[str(gprim.GetPath())] = points
            return
        key = str(gprim.GetPrimInPrototype().GetPath())
        root = gprim
        while not root.IsInstance():
            root = root.GetParent()
        self.instances.setdefault(key, []).append(str(root.GetPath()))
        first = self.points.setdefault(key, points)
        if first is not points and not np.array_equal(first, points):
            self.differ.add(key)
            self.points[str(gprim.GetPath())] = points     # (the first instance's proxy: the prototype's entry)


def posed_points(roots: list, time: Usd.TimeCode, warn: Warn) -> Poses:
    """The posed points (n, 3) float64, each in its gprim's own space, of the skinned point-based gprims under
    `roots` (SkelRoot prims).  Under an instance (a SkelRoot that is an instance prim), a gprim is its prototype's:
    instances posed alike share it; instances posed each their own way are drawn each as its own geometry
    (`Poses.expand`)."""
    cache, out = UsdSkel.Cache(), Poses()
    for prim in roots:
        root = UsdSkel.Root(prim)
        if not cache.Populate(root, PREDICATE):
            warn(f'{prim.GetPath()}: SkelRoot could not be read by UsdSkel; its gprims keep their bind pose')
            continue
        for binding in cache.ComputeSkelBindings(root, PREDICATE):
            skel_query = cache.GetSkelQuery(binding.GetSkeleton())
            if not skel_query:
                continue
            xforms = skel_query.ComputeSkinningTransforms(time) if skel_query.GetTopology().GetNumJoints() else None
            skel_to_world = UsdGeom.Xformable(skel_query.GetPrim()).ComputeLocalToWorldTransform(time)
            for query in binding.GetSkinningTargets():
                gprim = query.GetPrim()
                if not gprim.IsA(UsdGeom.PointBased):
                    if query.HasJointInfluences():
                        warn(f'{gprim.GetPath()}: a {gprim.GetTypeName()} bound to a skeleton is drawn unposed '
                             '(rtc poses point-based gprims only)')
                    continue
                points = _posed(query, skel_query, xforms, skel_to_world, gprim, time, warn)
                if points is not None:
                    out.add(gprim, points)
    return out


def _posed(query, skel_query, xforms, skel_to_world: Gf.Matrix4d, gprim: Usd.Prim, time, warn: Warn):
    """A gprim's posed points in its own space, or None (no deformation, or it failed: warned)."""
    points = UsdGeom.PointBased(gprim).GetPointsAttr().Get(time)
    if points is None or len(points) == 0:
        return None
    points = Vt.Vec3fArray(points)
    try:
        shaped = query.HasBlendShapes() and _blend(query, skel_query, gprim, time, points)
        if not (query.HasJointInfluences() and xforms is not None):
            return np.asarray(points, np.float64) if shaped else None
        if query.IsRigidlyDeformed():
            to_skel = query.ComputeSkinnedTransform(xforms, time)
            if to_skel is None:
                raise Tf.ErrorException('no rigid transform')
            row = np.asarray(to_skel, np.float64)
            skinned = np.asarray(points, np.float64) @ row[:3, :3] + row[3, :3]
        else:
            if not query.ComputeSkinnedPoints(xforms, points, time):
                raise Tf.ErrorException('skinning failed')
            skinned = np.asarray(points, np.float64)
    except Tf.ErrorException as exc:
        warn(f'{gprim.GetPath()}: cannot be posed by its skeleton {skel_query.GetPrim().GetPath()} '
             f'({str(exc).strip().splitlines()[-1].strip()}); drawn in its bind pose')
        return None
    if gprim.IsInstanceProxy() and skel_query.GetPrim().IsInPrototype():
        gprim = gprim.GetPrimInPrototype()          # (UsdSkel gives an instance's skeleton as its prototype's)
    back = np.asarray(skel_to_world * UsdGeom.Xformable(gprim).ComputeLocalToWorldTransform(time).GetInverse(),
                      np.float64)                                  # (Gf: row vectors, the skeleton's space first)
    posed = skinned @ back[:3, :3] + back[3, :3]
    if not np.all(np.isfinite(posed)):
        warn(f'{gprim.GetPath()}: its posed points are not finite; drawn in its bind pose')
        return None
    return posed


def _blend(query, skel_query, gprim: Usd.Prim, time, points) -> bool:
    """Apply the gprim's blend shapes, weighted by its skeleton's animation at `time`, to `points` (in place).
    False when no weight applies."""
    anim = skel_query.GetAnimQuery()
    if not anim:
        return False
    weights = anim.ComputeBlendShapeWeights(time)
    mapper = query.GetBlendShapeMapper()
    if mapper and not mapper.IsIdentity():
        weights = mapper.Remap(weights)
    if weights is None or len(weights) == 0 or not any(weights):
        return False
    shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(gprim))
    sub_weights, shape_indices, sub_indices = shapes.ComputeSubShapeWeights(weights)
    return bool(shapes.ComputeDeformedPoints(sub_weights, shape_indices, sub_indices,
                                             shapes.ComputeBlendShapePointIndices(),
                                             shapes.ComputeSubShapePointOffsets(), points))
