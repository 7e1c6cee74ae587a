"""The instance graph of a composed stage, walked once per container and flattened to one level.

Containers (what gets one BVH) are the stage root, each native prototype (``/__Prototype_N``),
each PointInstancer prototype root, and -- when a gprim's own transform moves during the
shutter -- that gprim alone (so that moving plain gprims keep their motion instead of being
baked into the root's static geometry).  `InstanceGraph.build` visits each container's prims
once and records

* its gprims (with their purpose as seen inside the container; like visibility, purpose only
  counts where it is authored on an Imageable prim, -1 = inherited from wherever the
  container is placed),
* its references to other containers: native instance prims, PointInstancers (one row per
  instance, from `ComputeInstanceTransformsAtTimes` converted with numpy), moving gprims,
* its lights, and on the root walk the cameras and render-settings prims it passes.

`InstanceGraph.evaluate` then computes every container-relative transform at the K motion
times in one pass per time (one `UsdGeom.XformCache` each), and `InstanceGraph.flatten` expands
the reference graph into placements: (container, world matrices (N, K, 4, 4), purpose, namespace
map).  The namespace map records how a path inside the container reads on the composed stage
(``/__Prototype_3/Geom`` -> ``/World/Tree_7/Geom``), which is what per-instance material binding
resolution needs; it is only marked as needing resolution when some binding or primvar is
authored on the way (an instance prim or its ancestors), so that 10^5 plain instances cost
nothing extra.

Load cost (usd-core has no batch API for composed per-prim values): a native instance costs one
`GetAuthoredPropertyNames`, one `GetTypeName`, one dict lookup for its prototype and one
`XformCache.GetLocalToWorldTransform` (its children, names and instance flags come in
per-parent batches), ~15-25 us in all; everything after that is numpy over all placements.
An instance that authors a material binding also reads that binding (`_binding_key`) so that
siblings overriding it the same way share one `ComputeBoundMaterials` query.

Rules implemented (see /work/shared/usd-mapping.md): invisible prims prune their subtree;
purpose is the prim's own authored value, else the nearest ancestor's, else `default`; only
`default` and `render` are rendered; a PointInstancer's purpose does not propagate into its
prototypes, whose roots are walked with usdImaging's prototype predicate (active, defining
specifier, not abstract, loaded); an instance prim that is itself a gprim is rendered as a gprim
of its parent container as well as placing its prototype.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdSkel, Vt

from ..errors import SceneError
from .geometry import converter_for
from .instance_primvars import instance_primvars, reader_varnames
from .lights import LIGHT_TYPES

Warn = Callable[[str], None]
PURPOSES = {'default': 0, 'render': 1, 'proxy': 2, 'guide': 3}
INHERIT = -1
RENDERED = (0, 1)
PI = UsdGeom.PointInstancer
PI_PROTOTYPE_PREDICATE = (Usd.PrimIsActive & Usd.PrimHasDefiningSpecifier & ~Usd.PrimIsAbstract
                          & Usd.PrimIsLoaded)
MAX_DEPTH = 64
MAX_PLACEMENTS = 10_000_000     # flattened instances; a few KB of nested instancing can ask for 10^9


def _kind(prim: Usd.Prim, cache: dict) -> str:
    """Category of a prim, cached per type name: gprim / unsupported / pi / light / camera /
    settings / other."""
    name = prim.GetTypeName()
    if name not in cache:
        if converter_for(name):
            cache[name] = 'gprim'
        elif prim.IsA(PI):
            cache[name] = 'pi'
        elif name in LIGHT_TYPES or prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase):
            cache[name] = 'light'
        elif prim.IsA(UsdGeom.Gprim):
            cache[name] = 'unsupported'
        elif prim.IsA(UsdSkel.Root):
            cache[name] = 'skelroot'
        elif prim.IsA(UsdGeom.Camera):
            cache[name] = 'camera'
        elif prim.IsA(UsdRender.Settings):
            cache[name] = 'settings'
        else:
            cache[name] = 'other'
    return cache[name]


@dataclass(slots=True)
class Ref:
    """A placement of another container inside this one."""
    child: int                     # node index
    prim: Optional[Usd.Prim]       # whose transform places it (None: identity)
    purpose: int
    label: str                     # instance / gprim path in this container's namespace
    prototype: Optional[str]       # native prototype path: the child's paths map under `label`
    needs_binding: bool            # bindings/displayColor authored at or above the placing prim
    binding_key: Optional[tuple] = None   # instances with equal keys resolve materials alike


@dataclass
class Instancer:
    prim: Usd.Prim
    children: list                 # node index per prototype, or None for unusable targets


@dataclass
class Node:
    key: str
    root: Usd.Prim
    base: Optional[Usd.Prim]       # transforms are relative to it (None: local-to-world)
    gprims: list = field(default_factory=list)        # (prim, purpose)
    refs: list = field(default_factory=list)          # Ref
    instancers: list = field(default_factory=list)    # Instancer
    lights: list = field(default_factory=list)        # prim
    # filled by evaluate(): (n, K, 4, 4) column-vector matrices
    gprim_xf: np.ndarray = None
    ref_xf: np.ndarray = None
    light_xf: np.ndarray = None
    pi_rows: list = field(default_factory=list)       # per instancer: (children (n,), matrices (n, K, 4, 4),
    #                                                   primvars per instance or None: `instance_primvars`)


@dataclass
class Placements:
    """Flattened placements of one container."""
    matrices: list = field(default_factory=list)      # arrays (m, K, 4, 4)
    purpose: list = field(default_factory=list)       # arrays (m,)
    maps: list = field(default_factory=list)          # arrays (m,) into InstanceGraph.maps
    labels: list = field(default_factory=list)        # lists of str


def _to_numpy(matrices: list) -> np.ndarray:
    """Gf.Matrix4d list (row vectors) -> float64 (n, 4, 4) column-vector matrices."""
    if not matrices:
        return np.zeros((0, 4, 4))
    return np.array(Vt.Matrix4dArray(matrices)).transpose(0, 2, 1)


class InstanceGraph:
    def __init__(self, stage: Usd.Stage, time: Usd.TimeCode, warn: Warn, expand: frozenset = frozenset()):
        self.stage, self.time, self.warn = stage, time, warn
        self.expand = expand                    # instance prim paths walked as their own geometry (`_children`)
        self.nodes: list[Node] = []
        self.index: dict[str, int] = {}
        self.skipped: list[str] = []
        self.skel_roots: list[Usd.Prim] = []    # SkelRoots met (on the stage or in prototypes): skinning.py poses
        self.cameras: list[Usd.Prim] = []
        self.settings: list[Usd.Prim] = []
        self.animated = any(layer.ListAllTimeSamples() for layer in stage.GetUsedLayers())
        self.xform_prims: list[Usd.Prim] = []   # prims with authored xformOps (animated stages only)
        # namespace maps: (prefix in the container, prefix on the composed stage, needs material
        # resolution, Ref.binding_key for instances placed directly on the stage)
        self.maps: list[tuple[str, str, bool, Optional[tuple]]] = [('/', '/', False, None)]
        self.map_primvars: dict[int, dict] = {}   # map id -> {name: values} PointInstancers give its placements
        self._primvar_maps: dict[tuple, int] = {}
        self._varnames: Optional[frozenset] = None
        self.collection_bindings = False     # some walked prim authors a collection-based binding
        self._kinds: dict = {}
        self._prototypes: dict[Usd.Prim, tuple[int, str]] = {}
        self._prototype_paths: dict[str, int] = {}
        self._instance_table: Optional[dict] = None    # instance prim -> index into _table_protos
        self._table_protos: list = []

    # ------------------------------------------------------------------ walk
    def build(self) -> None:
        self._node('/', self.stage.GetPseudoRoot(), None, include_root=False)

    def _node(self, key: str, root: Usd.Prim, base, include_root: bool) -> int:
        if key in self.index:
            return self.index[key]
        self.index[key] = len(self.nodes)
        node = Node(key, root, base)
        self.nodes.append(node)
        self._walk(node, include_root)
        return self.index[key]

    def _prototype_of(self, instance: Usd.Prim) -> tuple[int, str]:
        """(node index, prototype path) of an instance prim.  The instance -> prototype table is
        built once from `GetPrototypes()`/`GetInstances()` (batch calls): one prim hash per
        instance instead of a `GetPrototype()` call and a second hash of its result."""
        if self._instance_table is None:
            protos = self.stage.GetPrototypes()
            self._instance_table = {i: k for k, proto in enumerate(protos) for i in proto.GetInstances()}
            self._table_protos = [(proto, None) for proto in protos]
        k = self._instance_table.get(instance)
        if k is None:                                  # not expected; ask the prim itself
            return self._prototype_node(instance.GetPrototype())
        proto, found = self._table_protos[k]
        if found is None:
            found = self._prototype_node(proto)
            self._table_protos[k] = (proto, found)
        return found

    def _prototype_node(self, proto: Usd.Prim) -> tuple[int, str]:
        """(node index, prototype path) of a native prototype, cached by prim."""
        found = self._prototypes.get(proto)
        if found is None:
            path = str(proto.GetPath())
            n = self._prototype_paths.get(path)
            if n is None:
                n = self._prototype_paths[path] = self._node(path, proto, None, include_root=False)
            found = self._prototypes[proto] = (n, path)
        return found

    def _walk(self, node: Node, include_root: bool) -> None:
        """Visit the container's prims in `Usd.PrimRange(root, predicate)` order (depth first, pruned at instances,
        PointInstancers and invisible prims) with as few pxr calls per prim as usd-core allows: the children of a
        prim come in one batch (`GetFilteredChildren`, their names and the names of those that are instances: three
        calls per parent, none per child), paths are strings built from the names, and a prim costs one
        `GetAuthoredPropertyNames` and one `GetTypeName`; an instance's prototype comes from a table built with
        `GetPrototypes`/`GetInstances` (one dict lookup).  No per-prim state dict, no `Sdf.Path` objects.
        SkelRoots met, instances or not, are listed for `skinning.py`."""
        t, root, is_root = self.time, node.root, node.key == '/'
        pred = PI_PROTOTYPE_PREDICATE if include_root else Usd.PrimDefaultPredicate
        if not pred(root):                       # what Usd.PrimRange(root, pred) yields: nothing
            return
        inst_pred = pred & Usd.PrimIsInstance
        kinds, animated, refs, gprims = self._kinds, self.animated, node.refs, node.gprims
        frames = []            # (children iterator, path prefix, instance names, purpose, binding authored)

        def push(parent: Usd.Prim, path: str, p: int, b: bool) -> bool:
            kids, names, instances = self._children(parent, path, pred, inst_pred)
            if not kids:
                return False
            frames.append((iter(zip(kids, names)), '/' if path == '/' else path + '/', instances, p, b))
            return True

        if include_root:
            parent = str(root.GetPath().GetParentPath())
            frames.append((iter([(root, root.GetName())]), '/' if parent == '/' else parent + '/',
                           {root.GetName()} if root.IsInstance() else set(), INHERIT, False))
        else:
            push(root, str(root.GetPath()), INHERIT, False)
        while frames:
            it, prefix, instances, pp, pb = frames[-1]
            for prim, name in it:
                p, b = pp, pb
                names = prim.GetAuthoredPropertyNames()
                if names:
                    imageable = ('visibility' in names or 'purpose' in names) and prim.IsA(UsdGeom.Imageable)
                    if imageable and 'visibility' in names and \
                            prim.GetAttribute('visibility').Get(t) == UsdGeom.Tokens.invisible:
                        continue
                    if imageable and 'purpose' in names:
                        p = PURPOSES.get(prim.GetAttribute('purpose').Get(t), p)
                    joined = ' '.join(names)
                    if 'material:binding' in joined:
                        b = True
                        if 'material:binding:collection' in joined:
                            self.collection_bindings = True
                    elif 'primvars:' in joined:      # (displayColor, or one a material's primvar reader reads)
                        b = True
                    if animated and 'xformOp' in joined:
                        self.xform_prims.append(prim)
                kind = kinds.get(prim.GetTypeName()) or _kind(prim, kinds)
                if kind == 'skelroot':
                    self.skel_roots.append(prim)
                if name in instances:
                    if kind == 'gprim' and p not in (2, 3):
                        gprims.append((prim, p))
                    child, proto_path = self._prototype_of(prim)
                    refs.append(Ref(child, prim, p, prefix + name, proto_path, b,
                                    self._binding_key(prim, names, prefix) if b and is_root else None))
                    continue
                if kind == 'pi':
                    node.instancers.append(self._instancer(prim))
                    continue
                if kind == 'gprim':
                    if p not in (2, 3):
                        gprims.append((prim, p))
                elif kind == 'light':
                    node.lights.append(prim)
                elif kind == 'unsupported':
                    self.skipped.append(f'{prefix}{name}: {prim.GetTypeName()} is not supported')
                elif kind == 'camera' and is_root:
                    self.cameras.append(prim)
                elif kind == 'settings' and is_root:
                    self.settings.append(prim)
                if push(prim, prefix + name, p, b):
                    break                        # depth first: the children before the next sibling
            else:
                frames.pop()

    def _children(self, parent: Usd.Prim, path: str, pred, inst_pred) -> tuple:
        """(children, their names, the names of those that are instances) of a walked prim.  An instance of
        `self.expand` (its own geometry: a skeletal model posed otherwise than its prototype's other instances) and
        everything below it are walked through their instance proxies, none of them an instance."""
        if self.expand and (path in self.expand or parent.IsInstanceProxy()):
            proxies = Usd.TraverseInstanceProxies(pred)
            return parent.GetFilteredChildren(proxies), parent.GetFilteredChildrenNames(proxies), set()
        kids = parent.GetFilteredChildren(pred)
        if not kids:
            return kids, (), set()
        instances = set(parent.GetFilteredChildrenNames(inst_pred))
        if self.expand:
            prefix = '/' if path == '/' else path + '/'
            instances = {n for n in instances if prefix + n not in self.expand}
        return kids, parent.GetFilteredChildrenNames(pred), instances

    @staticmethod
    def _binding_key(prim: Usd.Prim, names: list, parent: str) -> Optional[tuple]:
        """For an instance on the stage (not inside a prototype) whose materials need resolving:
        a key such that instances of the same prototype with equal keys bind the same materials
        in every gprim -- the parent path (siblings share all ancestor bindings) and the
        instance's own direct bindings (targets, strength) and MaterialBindingAPI.  None
        (resolve it on its own) when it authors displayColor or a collection-based binding,
        whose effect depends on the instance's path.  Only used when no walked prim authors a
        collection-based binding."""
        own = []
        for name in names:
            if name.startswith('material:binding'):
                if name.startswith('material:binding:collection'):
                    return None
                rel = prim.GetRelationship(name)
                own.append((name, tuple(rel.GetTargets()), UsdShade.MaterialBindingAPI.GetMaterialBindingStrength(rel)))
            elif name == 'primvars:displayColor' or name.startswith('primvars:displayColor:'):
                return None
        return parent, tuple(own), prim.HasAPI(UsdShade.MaterialBindingAPI)

    def _instancer(self, prim: Usd.Prim) -> Instancer:
        children = []
        for target in PI(prim).GetPrototypesRel().GetForwardedTargets():
            r = self.stage.GetPrimAtPath(target)
            if not r or not r.IsActive() or not r.HasDefiningSpecifier() or r.IsAbstract():
                self.warn(f'{prim.GetPath()}: prototype {target} is missing or not defined; '
                          'its instances are dropped')
                children.append(None)
            elif r.IsInstance():
                children.append(self._instance_root(r))
            else:
                children.append(self._node(f'PI:{target}', r, r, include_root=True))
        if self.animated:
            self.xform_prims.append(prim)
        return Instancer(prim, children)

    def _instance_root(self, r: Usd.Prim) -> int:
        """A PointInstancer prototype root that is itself a native instance: its own gprim (if
        any) plus its prototype, both at identity (the root's transform is part of each PI
        instance transform)."""
        key = f'PIinst:{r.GetPath()}'
        if key in self.index:
            return self.index[key]
        self.index[key] = len(self.nodes)
        node = Node(key, r, r)
        self.nodes.append(node)
        own = PURPOSES.get(UsdGeom.Imageable(r).GetPurposeAttr().Get(self.time), 0) \
            if UsdGeom.Imageable(r).GetPurposeAttr().HasAuthoredValue() else INHERIT
        if _kind(r, self._kinds) == 'gprim' and own not in (2, 3):
            node.gprims.append((r, own))
        proto = r.GetPrototype()
        child, proto_path = self._prototype_node(proto)
        node.refs.append(Ref(child, None, own, str(r.GetPath()), proto_path, True))
        return self.index[key]

    # ------------------------------------------------------------------ motion
    def sample_times(self, time: float, shutter: tuple[float, float], extra: list) -> list[float]:
        """Authored transform sample times strictly inside the shutter of everything that moves
        (`extra`: more xformable prims, e.g. the camera), plus both ends; [time] if nothing in
        the scene is time-varying or the shutter is closed."""
        lo, hi = time + shutter[0], time + shutter[1]
        if not self.animated or hi <= lo:
            return [time]
        interval, times, moving = Gf.Interval(lo, hi), {lo, hi}, False
        for prim in self.xform_prims + extra:
            if prim.IsA(PI) and self._instancer_moves(PI(prim)):
                moving = True
                pi = PI(prim)
                for attr in (pi.GetPositionsAttr(), pi.GetOrientationsAttr(), pi.GetOrientationsfAttr(),
                             pi.GetScalesAttr()):
                    times.update(attr.GetTimeSamplesInInterval(interval))
            xf = UsdGeom.Xformable(prim)
            if xf and xf.TransformMightBeTimeVarying():
                moving = True
                times.update(xf.GetTimeSamplesInInterval(interval))
        return sorted(times) if moving else [time]

    @staticmethod
    def _instancer_moves(pi: UsdGeom.PointInstancer) -> bool:
        """Instance transforms vary with time: several samples of positions/orientations/scales,
        or (angular) velocities extrapolating a time-sampled position/orientation."""
        sampled = [a.GetNumTimeSamples() for a in (pi.GetPositionsAttr(), pi.GetOrientationsAttr(),
                                                   pi.GetOrientationsfAttr(), pi.GetScalesAttr())]
        velocity = pi.GetVelocitiesAttr().HasAuthoredValue() or pi.GetAngularVelocitiesAttr().HasAuthoredValue()
        return max(sampled) > 1 or (velocity and max(sampled[:3]) > 0)

    # ------------------------------------------------------------------ transforms
    def evaluate(self, times: list[float]) -> None:
        """Container-relative transforms of every gprim, reference, light and PointInstancer
        instance at the motion `times` (a list of K time codes)."""
        caches = [UsdGeom.XformCache(Usd.TimeCode(t)) for t in times]

        def relative(node: Node, prims: list) -> np.ndarray:
            per_time = []
            for xc in caches:
                if node.base is None:
                    mats = [xc.GetLocalToWorldTransform(p) if p is not None else Gf.Matrix4d(1) for p in prims]
                else:
                    mats = [Gf.Matrix4d(1) if p is None or p == node.base else
                            xc.ComputeRelativeTransform(p, node.base)[0] for p in prims]
                per_time.append(_to_numpy(mats))
            return np.stack(per_time, axis=1) if prims else np.zeros((0, len(times), 4, 4))

        for node in self.nodes:
            node.gprim_xf = relative(node, [g for g, _ in node.gprims])
            node.ref_xf = relative(node, [r.prim for r in node.refs])
            node.light_xf = relative(node, node.lights)
            node.pi_rows = [self._pi_rows(node, inst, times, relative) for inst in node.instancers]

    def _pi_rows(self, node: Node, inst: Instancer, times: list[float], relative):
        """(child node per instance (n,), matrices (n, K, 4, 4)) of one PointInstancer, masked
        instances and bad prototype indices removed, all in numpy."""
        pi, path, t = PI(inst.prim), inst.prim.GetPath(), self.time
        indices = np.asarray(pi.GetProtoIndicesAttr().Get(t) or [], np.int64)
        empty = (np.zeros(0, np.int64), np.zeros((0, len(times), 4, 4)), None)
        if len(indices) == 0 or not inst.children:
            return empty
        samples = pi.ComputeInstanceTransformsAtTimes([Usd.TimeCode(x) for x in times], t,
                                                      PI.IncludeProtoXform, PI.IgnoreMask)
        if not samples or any(len(s) != len(indices) for s in samples):
            self.warn(f'{path}: instance attributes do not match protoIndices ({len(indices)}); '
                      'PointInstancer dropped')
            return empty
        xf = np.stack([np.array(s) for s in samples], axis=1).transpose(0, 1, 3, 2)   # (n, K, 4, 4)
        keep = np.ones(len(indices), bool)
        mask = pi.ComputeMaskAtTime(t)
        if len(mask):
            keep &= np.asarray(mask, bool)
        table = np.array([-1 if c is None else c for c in inst.children], np.int64)
        bad = (indices < 0) | (indices >= len(table))
        if bad.any():
            self.warn(f'{path}: {int(bad.sum())} protoIndices out of range; those instances dropped')
        keep &= ~bad
        child = np.where(bad, -1, table[np.clip(indices, 0, len(table) - 1)])
        keep &= child >= 0
        to_node = relative(node, [inst.prim])[0]                                      # (K, 4, 4)
        given = instance_primvars(inst.prim, len(indices), t, self.warn, self._reader_varnames)
        kept = None if given is None else [given[j] for j in np.flatnonzero(keep)]
        return child[keep], to_node[None] @ xf[keep], kept

    def _reader_varnames(self) -> frozenset:
        if self._varnames is None:
            self._varnames = reader_varnames(self.stage)
        return self._varnames

    def _primvar_map(self, mi: int, given: tuple, owner: str) -> int:
        """The namespace map of a PointInstancer's instance placed under map mi, given the primvars `given`
        (`instance_primvars`): map mi's paths, resolved on their own, with those primvars (`map_primvars`;
        instances given the same values share one)."""
        key = (mi, given, owner)
        if key not in self._primvar_maps:
            src, dst, _, _ = self.maps[mi]
            self.maps.append((src, dst, True, None))
            self.map_primvars[len(self.maps) - 1] = {**self.map_primvars.get(mi, {}),
                                                     **{name: (v, owner) for name, v in given}}
            self._primvar_maps[key] = len(self.maps) - 1
        return self._primvar_maps[key]

    def split_moving_gprims(self) -> None:
        """Give every gprim whose container-relative transform changes over the shutter its own
        container, placed by that transform, so its motion is not lost by baking."""
        for node in list(self.nodes):
            if len(node.gprims) == 0 or node.gprim_xf.shape[1] < 2:
                continue
            moving = np.any(node.gprim_xf != node.gprim_xf[:, :1], axis=(1, 2, 3))
            if not moving.any():
                continue
            keep = []
            for i, (prim, purpose) in enumerate(node.gprims):
                if not moving[i]:
                    keep.append(i)
                    continue
                key = f'rigid:{node.key}:{prim.GetPath()}'
                self.index[key] = len(self.nodes)
                rigid = Node(key, prim, prim, gprims=[(prim, INHERIT)])
                rigid.gprim_xf = np.broadcast_to(np.eye(4), (1, *node.gprim_xf.shape[1:])).copy()
                rigid.ref_xf = rigid.light_xf = np.zeros((0, *node.gprim_xf.shape[1:]))
                self.nodes.append(rigid)
                node.refs.append(Ref(self.index[key], prim, purpose, str(prim.GetPath()), None, False))
                node.ref_xf = np.concatenate([node.ref_xf, node.gprim_xf[i:i + 1]])
            node.gprims = [node.gprims[i] for i in keep]
            node.gprim_xf = node.gprim_xf[keep]

    # ------------------------------------------------------------------ flatten
    def flatten(self, root_matrix: np.ndarray) -> dict[int, Placements]:
        """Expand the reference graph from the root, placed at `root_matrix` (K, 4, 4).
        Returns placements per node index (nodes never placed are absent)."""
        total = self._count(0, 1, 0)
        if total > MAX_PLACEMENTS:
            raise SceneError(f'{self.stage.GetRootLayer().identifier}: nested instancing expands to more than '
                             f'{MAX_PLACEMENTS:,} placements; refusing to flatten it')
        out: dict[int, Placements] = {}
        self._visit(0, root_matrix[None], np.zeros(1, np.int8), np.zeros(1, np.int64), ['/'], out, 0)
        return out

    def _count(self, n: int, m: int, depth: int) -> int:
        """Placements `_visit` would create below (and including) `m` placements of node `n`,
        without allocating them; stops early past MAX_PLACEMENTS (deep cycles are left to _visit)."""
        if depth > MAX_DEPTH:
            return m
        node = self.nodes[n]
        children = [r.child for r in node.refs] + [int(c) for child, *_ in node.pi_rows for c in child]
        total = m
        if children:
            ids, k = np.unique(np.asarray(children, np.int64), return_counts=True)
            for c, kc in zip(ids.tolist(), k.tolist()):
                total += self._count(c, m * kc, depth + 1)
                if total > MAX_PLACEMENTS:
                    break
        return total

    def _visit(self, n: int, world, purpose, maps, labels, out, depth) -> None:
        if depth > MAX_DEPTH:
            raise SceneError(f'{self.stage.GetRootLayer().identifier}: instancing nested deeper than '
                             f'{MAX_DEPTH} levels at {self.nodes[n].key} (cycle?)')
        node = self.nodes[n]
        acc = out.setdefault(n, Placements())
        acc.matrices.append(world); acc.purpose.append(purpose); acc.maps.append(maps); acc.labels.append(labels)
        m, groups = len(world), []
        if node.refs:                       # all refs x all placements at once, row = parent * n + ref
            own = np.array([r.purpose for r in node.refs], np.int8)
            groups.append((np.tile([r.child for r in node.refs], m),
                           (world[:, None] @ node.ref_xf[None]).reshape(-1, *world.shape[1:]),
                           np.where(own[None] == INHERIT, purpose[:, None], own[None]).ravel(),
                           *self._descend(maps, node.refs)))
        for inst, (child, rel, given) in zip(node.instancers, node.pi_rows):
            if len(child):                  # PI instances inherit the parent's namespace map
                k = len(child)
                own_path = str(inst.prim.GetPath())
                lab = [self._map_path(mi, own_path) for mi in maps.tolist()]
                sub = np.repeat(maps, k) if given is None else np.array(   # (or one with the primvars it gives)
                    [self._primvar_map(mi, g, lab[r]) for r, mi in enumerate(maps.tolist()) for g in given], np.int64)
                groups.append((np.tile(child, m), (world[:, None] @ rel[None]).reshape(-1, *rel.shape[1:]),
                               np.zeros(m * k, np.int8), sub, [x for x in lab for _ in range(k)]))
        if not groups:
            return
        child = np.concatenate([g[0] for g in groups])
        mats, pur, mps = (np.concatenate([g[i] for g in groups]) for i in (1, 2, 3))
        labs = [x for g in groups for x in g[4]]
        for c in np.unique(child):
            sel = np.flatnonzero(child == c)
            self._visit(int(c), mats[sel], pur[sel], mps[sel], [labs[i] for i in sel], out, depth + 1)

    def _map_path(self, map_id: int, path: str) -> str:
        """`path` (a prim path string in a container's namespace) as it reads on the composed
        stage under namespace map `map_id` (Sdf.Path.ReplacePrefix on strings)."""
        src, dst, _, _ = self.maps[map_id]
        if src == dst:
            return path
        if path == src:
            return dst
        return dst + path[len(src):] if path.startswith(src + '/') else path

    def needs_resolution(self) -> np.ndarray:
        """Per namespace map: bindings or primvars authored on the way (bool array)."""
        return np.fromiter((m[2] for m in self.maps), bool, len(self.maps))

    def _descend(self, maps: np.ndarray, refs: list[Ref]) -> tuple[np.ndarray, list[str]]:
        """Namespace maps and labels for every (parent placement, reference) pair, row =
        parent * len(refs) + ref: a native instance starts a new map (its prototype read under
        the instance's composed path); other references keep the parent's."""
        labels0 = [r.label for r in refs]
        native = [r for r in refs if r.prototype is not None]
        is_native = np.array([r.prototype is not None for r in refs], bool)
        new, labels = np.empty((len(maps), len(refs)), np.int64), []
        for row, mi in enumerate(maps.tolist()):
            src, dst, needs, _ = self.maps[mi]
            top = mi == 0                             # placed directly on the stage
            labs = labels0 if src == dst else [self._map_path(mi, x) for x in labels0]
            labels += labs
            new[row] = mi
            if native:
                start = len(self.maps)
                if len(native) == len(refs):
                    self.maps += [(r.prototype, lab, needs or r.needs_binding, r.binding_key if top else None)
                                  for r, lab in zip(refs, labs)]
                else:
                    self.maps += [(r.prototype, lab, needs or r.needs_binding, r.binding_key if top else None)
                                  for r, lab in zip(refs, labs) if r.prototype is not None]
                new[row, is_native] = np.arange(start, len(self.maps))
                if mi in self.map_primvars:           # (what an instancer gave is inherited by what it places)
                    self.map_primvars.update({j: self.map_primvars[mi] for j in range(start, len(self.maps))})
        return new.ravel(), labels
