"""Composed USD stage -> `SceneDescription` (the renderer's only contact with pxr).

    desc = read_stage('scene.usda')                      # or an open Usd.Stage
    desc = read_stage(path, time=12, camera_path='/World/Cam', options=RenderOptions(width=320, spp=16))

The work is split the way the description is: `instancing` finds the containers and
flattens the instance graph to one level of placements, `geometry` converts each
container's gprims once, `materials` resolves bindings per placement (vectorised, with
`ComputeBoundMaterials`) and loads only the textures bound materials use, `lights` and
`camera` convert the rest (modules of rtc.renderer.usd).  This module sequences them, applies the Z-up -> Y-up rotation
at the root placement (so it reaches every instance, light and the camera), and turns pxr
diagnostics and unusable input into `SceneError` / `warnings`.

Motion: instance transforms are sampled at K uniform times over ``[t + shutter:open,
t + shutter:close]`` of the render camera, where K is the number of distinct authored transform
samples in that interval including both ends (K = 1 when nothing moves, the shutter is closed
or the settings disable motion blur).  Geometry itself is evaluated at frame time t.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from typing import Optional, Union

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom, UsdShade, UsdUtils

from ..description import (FLOAT32_MAX, BytePixels, Container, Curves, Instances, Light, Mesh, SceneDescription,
                           Sphere)
from ..errors import SceneError
from ..options import RenderOptions, resolve
from .camera import (default_camera, read_camera, read_render_settings, render_settings_prim,
                                 shutter)
from .geometry import GeometryError, convert_gprim, points_box
from .geometry_cache import GeometryCache
from .instancing import INHERIT, RENDERED, InstanceGraph, Placements
from .lights import default_lights, mesh_light_radiance, read_light
from .materials import MaterialTable

MAX_LIGHTS = 10_000
MAX_DIAGNOSTICS = 50


def read_stage(source: Union[str, os.PathLike, Usd.Stage], *, time: Optional[float] = None,
               camera_path: Optional[str] = None, options: Optional[RenderOptions] = None,
               geometry: Optional[GeometryCache] = None) -> SceneDescription:
    """Read a USD file (or an open stage) into a SceneDescription.

    `time` defaults to the stage's startTimeCode; `camera_path` overrides the render settings'
    camera.  `options` (what the render asks for) are resolved against the stage's render settings
    into `desc.options`, and the camera is fitted to that image size.  Raises SceneError for
    unusable input, RenderError for unusable options; problems with single prims become
    `warnings` / `skipped` entries instead.  `geometry`: a `GeometryCache` kept across reads of
    the same stage at other time codes (a shot's frames), which converts static gprims once."""
    delegate = UsdUtils.CoalescingDiagnosticDelegate()
    label = '<memory>'
    try:
        stage, label = _open(source)
        if geometry is not None:
            geometry.use(stage)
        with np.errstate(all='ignore'):        # odd values are found by explicit checks (named, warned or refused)
            desc = _Reader(stage, label, time, camera_path, options, geometry).read()
    except Tf.ErrorException as exc:
        raise SceneError(f'{label}: {_first_line(exc)}') from None
    notes = [d.commentary for d in delegate.TakeUncoalescedDiagnostics()]
    desc.warnings[:0] = [f'USD: {n}' for n in dict.fromkeys(notes)][:MAX_DIAGNOSTICS]
    return desc


def _first_line(exc: Exception) -> str:
    """The commentary of a pxr error (``Error in 'fn' at line N in file F : 'text'``), most
    specific first, without the C++ function and source locations."""
    notes = []
    for line in str(exc).splitlines():
        _, sep, text = line.strip().partition(" : '")
        notes.append((text if sep else line).strip().rstrip("'").strip())
    notes = [n for n in dict.fromkeys(notes) if n]
    return '; '.join(notes[:2]) if notes else type(exc).__name__


def _open(source) -> tuple[Usd.Stage, str]:
    if isinstance(source, Usd.Stage):
        return source, source.GetRootLayer().realPath or '<memory>'
    path = os.fspath(source)
    if not os.path.isfile(path):
        raise SceneError(f'{path}: no such file')
    if Sdf.FileFormat.FindByExtension(os.path.splitext(path)[1].lstrip('.')) is None:
        raise SceneError(f'{path}: not a USD file (unknown extension)')
    try:
        stage = Usd.Stage.Open(path)
    except Tf.ErrorException as exc:
        raise SceneError(f'{path}: cannot open: {_first_line(exc)}') from None
    if stage is None:
        raise SceneError(f'{path}: cannot open')
    return stage, path


def rotate_x(degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], np.float64)


@dataclass
class _Shape:
    """A converted Mesh/Sphere/Curves and what it needs for per-placement material resolution."""
    record: Union[Mesh, Sphere, Curves]
    binding_path: str               # gprim (or GeomSubset) path in the container's namespace
    explicit: bool                  # its purpose is authored inside the container


class _Reader:
    def __init__(self, stage, label, time, camera_path, options, geometry=None):
        self.stage, self.label = stage, label
        self.convert = geometry.convert if geometry is not None else convert_gprim
        self.box = geometry.box if geometry is not None else points_box
        self.t = float(stage.GetStartTimeCode() if time is None else time)
        self.tc = Usd.TimeCode(self.t)
        self.camera_path, self.options = camera_path, options
        self.warnings: list[str] = []
        self.skipped: list[str] = []
        self.materials = MaterialTable(self.tc, self.warn)
        self.backgrounds: set[str] = set()     # DomeLights marked rtc:background (course background colour)
        self.mesh_lights = 0                   # gprims (per binding resolution) with UsdLux MeshLightAPI
        self.posed = None                      # skinning.Poses: points posed by a skeleton, where a SkelRoot is

    def warn(self, message: str) -> None:
        self.warnings.append(message)

    # ------------------------------------------------------------------ top level
    def read(self) -> SceneDescription:
        stage, t = self.stage, self.t
        up = UsdGeom.GetStageUpAxis(stage)
        up_matrix = rotate_x(-90.0) if up == UsdGeom.Tokens.z else np.eye(4)

        graph = InstanceGraph(stage, self.tc, self.warn)
        graph.build()
        if graph.skel_roots:
            from .skinning import posed_points
            self.posed = posed_points(graph.skel_roots, self.tc, self.warn)
            if self.posed.expand:                # instances posed each their own way: each its own geometry
                graph = InstanceGraph(stage, self.tc, lambda message: None, self.posed.expand)
                graph.build()                    # (its walk's warnings were given by the first)
                graph.warn = self.warn
        self.skipped += graph.skipped

        settings_prim = render_settings_prim(stage, graph.settings)
        settings, background, policy = read_render_settings(settings_prim, self.tc)
        if self.camera_path:
            settings.camera_path = self.camera_path
        options = resolve(self.options, settings)
        fit = (options.width / options.height, policy)
        camera_prim = self._camera_prim(settings.camera_path, graph.cameras)
        settings.camera_path = str(camera_prim.GetPath()) if camera_prim else None

        open_close = (0.0, 0.0) if settings.disable_motion_blur else shutter(camera_prim, self.tc)
        times = graph.sample_times(t, open_close, [camera_prim] if camera_prim else [])
        if len(times) > 1:                                     # uniform steps for Embree
            times = list(np.linspace(times[0], times[-1], len(times)))
        graph.evaluate(times)
        graph.split_moving_gprims()
        placed = graph.flatten(np.broadcast_to(up_matrix, (len(times), 4, 4)))

        containers, instances = self._instances(graph, placed)
        frame = int(np.argmin(np.abs(np.asarray(times) - t)))
        lights = self._lights(graph, placed, frame, up)
        backgrounds = [light for light in lights if light.path in self.backgrounds]
        if backgrounds:                  # a course background: the colour of escaping rays, not a light
            background = backgrounds[0].radiance
            lights = [light for light in lights if light.path not in self.backgrounds]

        desc = SceneDescription(source=self.label, containers=containers, instances=instances,
                                materials=self.materials.materials, textures=self.materials.textures,
                                lights=lights, camera=None, settings=settings, options=options,
                                background=background,
                                shutter_times=tuple(float(x) for x in times),
                                meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(stage)),
                                up_axis='Z' if up == UsdGeom.Tokens.z else 'Y',
                                warnings=self.warnings, skipped=self.skipped)
        lo, hi = scene_bounds(desc, self.box)
        if camera_prim is not None:
            world = [up_matrix @ _camera_world(camera_prim, x) for x in times]
            motion = np.stack(world) if len(times) > 1 and any(np.any(w != world[0]) for w in world) else None
            desc.camera = read_camera(camera_prim, up_matrix @ _camera_world(camera_prim, t), motion, self.tc,
                                      settings, fit, float(np.linalg.norm(hi - lo)),
                                      desc.meters_per_unit, self.warn)
        else:
            desc.camera = default_camera(lo, hi, fit)
            self.warn('no camera in the stage: using a default camera framing the scene bounds')
        if not lights and not self.mesh_lights:
            desc.lights = default_lights(desc.camera.matrix)
            self.warn('no lights in the stage: added a default DistantLight headlight along the view '
                      'direction (irradiance 3) and a dim constant DomeLight (radiance 0.1)')
        _collapse_static_motion(desc)
        return desc

    def _camera_prim(self, requested: Optional[str], found: list) -> Optional[Usd.Prim]:
        if requested:
            prim = self.stage.GetPrimAtPath(requested) if Sdf.Path.IsValidPathString(requested) else None
            if prim and prim.IsA(UsdGeom.Camera):
                return prim
            if self.camera_path:                         # asked for explicitly by the caller
                raise SceneError(f'{self.label}: {requested} is not a camera')
            self.warn(f'render settings camera {requested} is not a camera; ignored')
        return found[0] if found else None

    # ------------------------------------------------------------------ geometry + instances
    def _shapes(self, graph: InstanceGraph, n: int) -> list[_Shape]:
        node, shapes = graph.nodes[n], []
        for (prim, purpose), rel in zip(node.gprims, node.gprim_xf):
            try:
                records = self.convert(prim, rel[0], self.tc, self.warn, self.posed.get(prim) if self.posed else None)
            except GeometryError as exc:
                self.skipped.append(str(exc))
                continue
            except (Tf.ErrorException, TypeError, ValueError):     # malformed attribute values
                self.skipped.append(f'{prim.GetPath()}: unreadable {prim.GetTypeName()} '
                                    f'({mistyped_attributes(prim)})')
                continue
            shapes += [_Shape(r, str(r.path), purpose != INHERIT) for r in records]
        # Container.gprims order: meshes first, then spheres, then curves
        return sorted(shapes, key=lambda s: 2 if isinstance(s.record, Curves) else isinstance(s.record, Sphere))

    def _instances(self, graph: InstanceGraph, placed: dict[int, Placements]):
        """Containers (one per placed node and purpose variant that has geometry) and the
        flattened Instances, with material sets resolved per namespace map."""
        shapes = {n: self._shapes(graph, n) for n in placed if graph.nodes[n].gprims}
        rows = []                        # (node, variant, matrices, map ids, labels)
        for n, shp in shapes.items():
            if not shp:
                continue
            acc = placed[n]
            matrices = np.concatenate(acc.matrices)
            purpose, maps = np.concatenate(acc.purpose), np.concatenate(acc.maps)
            labels = [x for part in acc.labels for x in part]
            ok = _regular(matrices, max(s.record.reach() for s in shp))
            if not ok.all():
                self.warn(f'{graph.nodes[n].key}: {int((~ok).sum())} placements dropped (a matrix singular or not '
                          "finite, or placing it past float32's range)")
            rendered = np.isin(purpose, RENDERED)
            for variant, sel in (('', rendered & ok), ('#explicit', ~rendered & ok)):
                subset = [s for s in shp if variant == '' or s.explicit]
                if sel.any() and subset:
                    idx = np.flatnonzero(sel)
                    rows.append((n, variant, subset, matrices[idx], maps[idx], [labels[i] for i in idx]))
        needs = graph.needs_resolution()
        sets = self._material_sets(graph, rows, needs)

        containers, parts = [], []
        set_index: dict[tuple, int] = {}
        for (n, variant, subset, matrices, maps, labels) in rows:
            containers.append(Container(key=graph.nodes[n].key + variant,
                                        meshes=[s.record for s in subset if isinstance(s.record, Mesh)],
                                        spheres=[s.record for s in subset if isinstance(s.record, Sphere)],
                                        curves=[s.record for s in subset if isinstance(s.record, Curves)]))
            # placements whose map needs no resolution use the container's own materials; sets
            # are numbered in the order of their first map id
            resolve = needs[maps]
            ids = np.empty(len(maps), np.int32)
            unique, inverse = np.unique(maps[resolve], return_inverse=True)
            default = int(maps[~resolve].min()) if not resolve.all() else None
            numbers = []
            for u in unique.tolist():
                if default is not None and default < u:
                    ids[~resolve] = set_index.setdefault(tuple(s.record.material for s in subset), len(set_index))
                    default = None
                numbers.append(set_index.setdefault(sets[(n, variant, u)], len(set_index)))
            if default is not None:
                ids[~resolve] = set_index.setdefault(tuple(s.record.material for s in subset), len(set_index))
            ids[resolve] = np.array(numbers, np.int32)[inverse]
            parts.append((np.full(len(matrices), len(containers) - 1, np.int32), matrices, ids, labels))
        k = len(next(iter(placed.values())).matrices[0][0]) if placed else 1
        instances = Instances(
            container=np.concatenate([p[0] for p in parts]) if parts else np.zeros(0, np.int32),
            matrices=np.concatenate([p[1] for p in parts]) if parts else np.zeros((0, k, 4, 4)),
            material_set=np.concatenate([p[2] for p in parts]) if parts else np.zeros(0, np.int32),
            material_sets=list(set_index), paths=[x for p in parts for x in p[3]])
        return containers, instances

    def _material_sets(self, graph: InstanceGraph, rows, needs: np.ndarray) -> dict[tuple, tuple]:
        """Sets each shape's own material (the container's default) and returns the material
        index per shape for each (node, variant, namespace map) that needs resolution (`needs`:
        per map id).

        Shapes resolve on their own prims; placements whose map is marked as needing resolution
        resolve on the composed-stage paths (instance proxies) with `ComputeBoundMaterials`.
        Instances that the graph gives equal binding keys (same prototype, parent and own direct
        bindings) share the result of the first of them when it bound only materials outside
        that instance (a material inside an instance is a different prim per instance): 10^4
        instances overriding the binding the same way cost one query, not 10^4."""
        entries = []                     # (key (node, map id or None, binding path), stage path, group)
        seen = set()
        resolving = {}
        rep_of: dict[tuple, int] = {}    # (node, binding key) -> first map id with that key
        for (n, variant, subset, _, maps, _) in rows:
            ids = np.unique(maps[needs[maps]]).tolist()
            resolving[(n, variant)] = (subset, ids)
            for mi in [None] + ids:
                group = None
                if mi is not None and not graph.collection_bindings:
                    src, dst, _, bkey = graph.maps[mi]
                    if bkey is not None and src == graph.nodes[n].key:
                        group = (n, bkey)
                        rep_of.setdefault(group, mi)
                for s in subset:
                    key = (n, mi, s.binding_path)
                    if key in seen:
                        continue
                    seen.add(key)
                    path = s.binding_path if mi is None else graph._map_path(mi, s.binding_path)
                    entries.append((key, path, group))

        def compute(selected) -> dict:
            found = [(key, prim) for key, prim in ((e[0], self.stage.GetPrimAtPath(e[1])) for e in selected) if prim]
            bound, _ = UsdShade.MaterialBindingAPI.ComputeBoundMaterials([p for _, p in found], UsdShade.Tokens.full) \
                if found else ([], [])
            return {key: (prim, mat) for (key, prim), mat in zip(found, bound)}

        # representatives first; a group shares their results unless one bound a material inside it
        is_rep = [g is not None and rep_of[g] == e[0][1] for e in entries for g in (e[2],)]
        result = compute([e for e, r in zip(entries, is_rep) if r])
        private = set()             # groups whose representative bound a material inside itself or reading primvars
        for (key, path, group), r in zip(entries, is_rep):
            if r and key in result:
                mat = result[key][1]
                inside = graph.maps[key[1]][1]
                # (a material reading primvars: an instance inherits its own from its ancestors)
                if mat and ((str(mat.GetPath()) + '/').startswith(inside + '/') or self.materials.reads_primvars(mat)):
                    private.add(group)
        shared = [group is not None and group not in private and not r for (_, _, group), r in zip(entries, is_rep)]
        result.update(compute([e for e, r, sh in zip(entries, is_rep, shared) if not r and not sh]))

        index = {}
        for (key, path, group), sh in zip(entries, shared):
            if sh:                       # same result as the representative (resolved earlier in this order)
                rep = (key[0], rep_of[group], key[2])
                if rep in index:
                    index[key] = index[rep]
                continue
            if key in result:
                prim, mat = result[key]
                given = graph.map_primvars.get(key[1]) if key[1] is not None else None   # (a PointInstancer's)
                found = self.materials.bound(mat, prim, given) if mat else None
                index[key] = found if found is not None else self.materials.fallback(prim, given)
                glow = mesh_light_radiance(prim, self.tc, self.warn)
                if glow is not None:                 # UsdLux MeshLightAPI: the mesh emits
                    index[key] = self.materials.emitting(index[key], *glow)
                    self.mesh_lights += 1
        for (n, variant, subset, _, _, _) in rows:
            for s in subset:
                s.record.material = index[(n, None, s.binding_path)]
        sets = {}
        for (n, variant), (subset, ids) in resolving.items():
            for mi in ids:
                sets[(n, variant, mi)] = tuple(index.get((n, mi, s.binding_path), s.record.material) for s in subset)
        return sets

    # ------------------------------------------------------------------ lights
    def _lights(self, graph: InstanceGraph, placed: dict[int, Placements], frame: int, up: str) -> list[Light]:
        """Every light of every placed container, at each of its placements (frame-time sample)."""
        lights = []
        for n, acc in placed.items():
            node = graph.nodes[n]
            if not node.lights:
                continue
            world = np.concatenate(acc.matrices)[:, frame]
            if len(world) * len(node.lights) + len(lights) > MAX_LIGHTS:
                self.warn(f'{node.key}: more than {MAX_LIGHTS} light placements; the rest are ignored')
                break
            for prim, rel in zip(node.lights, node.light_xf):
                for w in world:
                    try:
                        light = read_light(prim, w @ rel[frame], self.tc, up, self._light_texture, self.warn)
                    except (Tf.ErrorException, TypeError, ValueError):
                        self.skipped.append(f'{prim.GetPath()}: unreadable light ({mistyped_attributes(prim)})')
                        break
                    if light is not None:
                        lights.append(light)
                        if _is_course_background(prim, self.tc):
                            self.backgrounds.add(light.path)
        return lights

    def _light_texture(self, asset, owner: str, wrap_s: str, wrap_t: str, upside_down: bool,
                       layout: str = 'latlong') -> int:
        index = self.materials.texture(asset, 'auto', wrap_s, wrap_t, (1.0,) * 4, (0.0,) * 4, owner, light=True,
                                       layout=layout)
        if upside_down and index >= 0:                # (a copy whose rows are reversed: a mirrored light's)
            t = self.materials.textures[index]
            flipped = t.pixels.flipped() if isinstance(t.pixels, BytePixels) else np.ascontiguousarray(t.pixels[::-1])
            self.materials.textures.append(replace(t, pixels=flipped))
            index = len(self.materials.textures) - 1
        return index


def _is_course_background(prim: Usd.Prim, time: Usd.TimeCode) -> bool:
    """A constant DomeLight the compiler wrote for a course background colour (`rtc:background`):
    other tools show it as the world colour; rtc gives it to escaping rays only, as the course
    does, instead of lighting the scene with it a second time."""
    attr = prim.GetAttribute('rtc:background')
    return bool(attr and attr.Get(time)) and prim.GetTypeName() in ('DomeLight', 'DomeLight_1')


def mistyped_attributes(prim: Usd.Prim) -> str:
    """In words, which authored attributes of a prim do not have the type its schema declares
    (the usual reason a prim cannot be read), e.g. "radius is a string, the schema says double"."""
    definition = prim.GetPrimDefinition()
    found = []
    for attr in prim.GetAuthoredAttributes():
        declared = definition.GetAttributeDefinition(attr.GetName())
        stack = attr.GetPropertyStack(Usd.TimeCode.Default())
        authored = stack[0].typeName if stack else None
        if declared and authored is not None and authored != declared.GetTypeName():
            found.append(f'{attr.GetName()} is a {authored}, the schema says {declared.GetTypeName()}')
    return '; '.join(found) if found else 'an attribute value of a kind rtc cannot read'


def _camera_world(prim: Usd.Prim, time: float) -> np.ndarray:
    m = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(time))
    return np.array(m).T


def _regular(matrices: np.ndarray, reach: float) -> np.ndarray:
    """Placements whose matrices are finite and invertible at every motion sample (the 3x3 determinant is not
    negligible against the product of the axis lengths: a collapsed axis), and place a container whose coordinates
    reach `reach` within float32's range, where Embree traces (|M p| <= |t| + |L| |p| in the max norm)."""
    lin = matrices[..., :3, :3]
    finite = np.all(np.isfinite(matrices), axis=(1, 2, 3))
    lin = np.where(finite[:, None, None, None], lin, 0.0)
    det = np.abs(np.linalg.det(lin))
    norms = np.prod(np.linalg.norm(lin, axis=-2), axis=-1)
    moved = np.abs(np.where(finite[:, None, None], matrices[..., :3, 3], 0.0)).max(-1)
    with np.errstate(all='ignore'):                     # (a bound past float64 is inf: refused all the same)
        bound = moved + np.abs(lin).sum(-1).max(-1) * reach
    return finite & np.all((norms > 0) & (det > 1e-9 * norms) & (bound <= FLOAT32_MAX), axis=1)


def _collapse_static_motion(desc: SceneDescription) -> None:
    """K > 1 samples that turned out identical everywhere (authored but constant) -> K = 1."""
    m = desc.instances.matrices
    if m.shape[1] < 2 or np.any(m != m[:, :1]) or desc.camera.motion is not None:
        return
    desc.instances.matrices = np.ascontiguousarray(m[:, :1])
    desc.shutter_times = desc.shutter_times[:1]


def _spheres_box(s) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of a sphere gprim (a lone sphere, an ellipsoid, or a point cloud's spheres) in its container."""
    b = s.balls()
    ext = b[:, 3:] * np.linalg.norm(s.matrix[:3, :3], axis=1)       # the half extents of each ball's image
    c = b[:, :3] @ s.matrix[:3, :3].T + s.matrix[:3, 3]
    return (c - ext).min(0), (c + ext).max(0)


def _curves_box(c) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of a curves gprim in its container: its control points' balls (a Bezier segment lies in the hull
    of its control points, its radius between theirs)."""
    v = c.vertices
    return (v[:, :3] - v[:, 3:]).min(0), (v[:, :3] + v[:, 3:]).max(0)


def scene_bounds(desc: SceneDescription, box=points_box) -> tuple[np.ndarray, np.ndarray]:
    """World-space axis-aligned bounds of all placed geometry at the first motion sample
    (inverted infinite box when there is none).  `box(points)`: a mesh's (lo, hi)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    inst = desc.instances
    for c, container in enumerate(desc.containers):
        boxes = [box(m.points) for m in container.meshes]
        boxes += [_spheres_box(s) for s in container.spheres]
        boxes += [_curves_box(c) for c in container.curves]
        if not boxes:
            continue
        box_lo, box_hi = np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
        centre, half = (box_lo + box_hi) / 2, (box_hi - box_lo) / 2
        world = inst.matrices[inst.container == c, 0]
        wc = world[:, :3, :3] @ centre + world[:, :3, 3]
        wh = np.abs(world[:, :3, :3]) @ half
        if len(wc):
            lo, hi = np.minimum(lo, (wc - wh).min(axis=0)), np.maximum(hi, (wc + wh).max(axis=0))
    return lo, hi
