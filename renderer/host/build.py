"""SceneDescription -> a two-level Embree scene plus the flat tables the numba kernels shade with.

Precision scheme (see README, "Numerical guarantees"):
* every container's geometry is re-centred on its own bounding-box centre (float64) before it is
  rounded to float32 for Embree, so a prototype keeps full float32 precision wherever it is placed;
* the whole world is expressed relative to the camera position at shutter open (float64), so the
  float32 numbers Embree sees near the camera are small even when the scene sits 10^6 units from
  the origin (a camera far outside the scene's bounds: relative to their point nearest it, `float_origin`);
* the kernels keep instance matrices and hit points in float64 and rebuild hit points from the
  barycentrics on the float32 object-space triangle (independent of the ray length).

Nothing is built for a feature the scene does not use: no normal, UV or texture tables when no
gprim carries them, one motion step when nothing moves, no sphere geometry when there is none.
"""
from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from .. import description as D
from .embree import CurveGeometry, Device, InstanceGroup
from ..images import byte_lut
from ..kernel.trace import MASK_SURFACES
from ..kernel.tables import LIGHT_F, MATERIAL_F, MATERIAL_I, TEXTURE_F, TEXTURE_I, VC_COLOR, VC_OPACITY, WRAP
from .features import see_through
from .gprim_tables import GprimTables

SceneData = namedtuple('SceneData', [
    'gp_kind', 'gp_off', 'gp_flags', 'gp_material', 'gp_n_off', 'gp_uv_off', 'gp_c_off',
    'tri_v', 'tri_n', 'tri_uv', 'tri_c', 'sph', 'crv', 'crv_n',
    'pr_gp_start', 'pr_geom_off', 'pr_geom_gp',
    'in_proto', 'in_xf', 'in_matset', 'matset', 'grp_base',
    'mat_i', 'mat_f',
    'tex_i', 'tex_f', 'tex_data', 'tex_bytes', 'tex_lut',
    'li_type', 'li_f', 'li_tex', 'li_ies',
    'background', 'offset_scale', 'see_through',
])


@dataclass
class BuiltScene:
    """Everything a render needs, owned together (Embree handles live as long as this object)."""
    device: Device
    prototypes: list
    top: object
    data: SceneData
    origin: np.ndarray           # float64 (3,): world position subtracted from everything (`float_origin`)
    motion_steps: int
    has_textures: bool
    has_dome: bool
    n_instances: int
    # the path integrator's prototypes where they differ from `prototypes` (`_path_prototypes`): built on
    # its first use, then kept, and taken over by a `reuse` build as the prototypes are (a shot's frames)
    path_prototypes: dict | None = None

    @property
    def handle(self) -> int:
        return self.top.handle

    def close(self):
        self.top.close()
        for p in list(self.prototypes) + list((self.path_prototypes or {}).values()):
            p.close()
        if self.device is not None:          # None once another build took the device over (`reuse`)
            self.device.close()


def _similarity_scale(m3: np.ndarray) -> float | None:
    """Uniform scale s if m3 = s * R (R orthonormal, possibly mirrored), else None."""
    g = m3.T @ m3
    s2 = np.trace(g) / 3.0
    if s2 <= 0 or not np.allclose(g, s2 * np.eye(3), rtol=1e-9, atol=1e-12 * max(s2, 1e-300)):
        return None
    return float(np.sqrt(s2))


def _container_radius(c: D.Container, ctr: np.ndarray) -> float:
    """Radius of a ball about `ctr` that holds the container's geometry (0 if empty)."""
    r = 0.0
    for m in c.meshes:
        if len(m.points):
            r = max(r, float(np.max(np.linalg.norm(np.asarray(m.points, np.float64) - ctr, axis=1))))
    for s in c.spheres:
        b = s.placed_balls(float(np.linalg.norm(s.matrix[:3, :3], 2)))
        r = max(r, float(np.max(np.linalg.norm(b[:, :3] - ctr, axis=1) + b[:, 3])))
    for x in c.curves:                 # (a Bezier segment lies in its control points' hull)
        r = max(r, float(np.max(np.linalg.norm(x.vertices[:, :3] - ctr, axis=1) + x.vertices[:, 3])))
    return r if np.isfinite(r) else 0.0


FAR_OUTSIDE = 4.0


def float_origin(camera: np.ndarray, world: np.ndarray, in_proto: np.ndarray, centers: np.ndarray,
                 radii: np.ndarray) -> np.ndarray:
    """The world point subtracted from every position before it is rounded to float32: the camera at shutter
    open, unless the camera is farther outside the bounds of the placed geometry than FAR_OUTSIDE times their
    diagonal (a telephoto shot): then the point of the bounds nearest the camera, so that the rays that leave
    surfaces (shadow, bounce, reflection) start from small numbers.  A camera 1e4 away from a scene 10 across
    put its surface points at float32 steps of 1e-3 and their ray offsets at 0.25 (README, "Where float32
    remains").  Camera rays start far then, which moves their origin by at most half a float32 step: the
    pinhole, not the hits (rebuilt from barycentrics in float64)."""
    camera = np.asarray(camera, np.float64)
    if not len(in_proto) or world.ndim != 4:
        return camera.copy()
    c = np.einsum('rkij,rj->rki', world[:, :, :3, :3], centers[in_proto]) + world[:, :, :3, 3]     # (N, K, 3)
    # the placed bounding sphere's exact box: half-extent along axis i is r * |row i of the linear part|
    r = radii[in_proto][:, None, None] * np.sqrt(np.sum(world[:, :, :3, :3] ** 2, axis=3))      # (N, K, 3)
    ok = (np.isfinite(c) & np.isfinite(r)).all(axis=2)
    if not ok.any():
        return camera.copy()
    lo = np.min(np.where(ok[..., None], c - r, np.inf), axis=(0, 1))
    hi = np.max(np.where(ok[..., None], c + r, -np.inf), axis=(0, 1))
    nearest = np.clip(camera, lo, hi)
    if np.linalg.norm(camera - nearest) <= FAR_OUTSIDE * max(float(np.linalg.norm(hi - lo)), 1e-300):
        return camera.copy()
    return nearest


def offset_scale(xf: np.ndarray, in_proto: np.ndarray, radii: np.ndarray) -> float:
    """Scale of the near-origin fallback of `vecmath.offset_origin` (Ray Tracing Gems' fixed 2^-16
    offset within 2^-5 of the origin, which assumes objects of size ~1 or more): the smallest world
    radius of a placed object (container radius x Frobenius norm of its placement's linear part),
    rounded down to a power of two (exact in float), at most 1 so that ordinary and large scenes
    keep the published constants.  Makes the offset invariant under a global change of units."""
    if not len(in_proto):
        return 1.0
    lin = np.sqrt(np.max(np.sum(xf[:, :, :, :3] ** 2, axis=(2, 3)), axis=1))      # (N,) max over steps
    r = radii[in_proto] * lin
    r = r[(r > 0) & np.isfinite(r)]
    if not len(r):
        return 1.0
    return float(min(1.0, max(2.0 ** -100, 2.0 ** np.floor(np.log2(r.min())))))


def _container_center(c: D.Container) -> np.ndarray:
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for m in c.meshes:
        if len(m.points):
            lo = np.minimum(lo, m.points.min(0))
            hi = np.maximum(hi, m.points.max(0))
    for s in c.spheres:
        ctr = s.placed_balls(1.0)[:, :3]
        lo = np.minimum(lo, ctr.min(0))
        hi = np.maximum(hi, ctr.max(0))
    for x in c.curves:
        lo = np.minimum(lo, x.vertices[:, :3].min(0))
        hi = np.maximum(hi, x.vertices[:, :3].max(0))
    return np.where(np.isfinite(lo), 0.5 * (lo + hi), 0.0)


def _cat(parts, shape, dtype):
    return np.ascontiguousarray(np.concatenate(parts), dtype) if parts else np.zeros(shape, dtype)


def _material_tables(materials: list[D.Material]):
    """(mat_i, mat_f); the last row is the default material for unbound gprims."""
    mats = [*materials, D.Material(path='<default>', model=D.PREVIEW_SURFACE, diffuse=(0.18, 0.18, 0.18),
                                   roughness=0.5, use_specular_workflow=True)]
    mat_i = np.zeros((len(mats), MATERIAL_I.width), np.int32)
    mat_f = np.zeros((len(mats), MATERIAL_F.width), np.float32)
    for k, m in enumerate(mats):
        MATERIAL_I.write(mat_i[k], MODEL=m.model, DIFFUSE_TEX=m.diffuse_texture, SPECULAR_TEX=m.specular_texture,
                         EMISSION_TEX=m.emission_texture,
                         VERTEX_COLOR=VC_COLOR * m.vertex_colors | VC_OPACITY * m.vertex_opacity,
                         SCALAR_TEX=m.scalar_textures, SCALAR_CH=m.scalar_channels, NORMAL_TEX=m.normal_texture)
        MATERIAL_F.write(mat_f[k], KD=m.diffuse, KS=m.specular, EXP=m.exponent, MIRROR=m.mirror_coef,
                         ROUGH=m.roughness, IOR=m.ior, ATTEN=m.attenuation, EMIT=m.emission, METAL=m.metallic,
                         OPACITY=m.opacity, SPECWF=1.0 if m.use_specular_workflow else 0.0,
                         CLEARCOAT=m.clearcoat, CC_ROUGH=m.clearcoat_roughness, OPACITY_CUT=m.opacity_threshold,
                         GAIN=m.light_gains)
    return mat_i, mat_f


_ZERO_TEXEL = np.zeros((1, 1, 1), np.float32)
_IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)


def _texture_tables(textures: list[D.Texture]):
    """(tex_i, tex_f, tex_data, tex_bytes) of the textures, in their order; each UDIM texture's entries (the one read
    outside its tiles, then its tiles, a missing one a texel 0: clamped, its scale and bias, no transform) after them
    all.  A float image's values go to tex_data, an 8-bit one's bytes to tex_bytes (TI_BYTES: its sRGB-decoded
    channels, -1 for floats; `kernel/textures._texel` looks them up in `images.byte_lut`), from TI_OFFSET."""
    rows = [(t.pixels, t.wrap_s, t.wrap_t, t.scale, t.bias, t.transform) for t in textures]
    udim = [-1] * len(textures)
    for k, t in enumerate(textures):
        if t.tiles:
            udim[k] = len(rows)
            rows += [(_ZERO_TEXEL if px is None else px, 'clamp', 'clamp', t.scale, t.bias, _IDENTITY)
                     for px in (None,) + tuple(t.tiles)]
    tex_i = np.zeros((max(len(rows), 1), TEXTURE_I.width), np.int64)
    tex_i[:, TEXTURE_I.offset['UDIM']] = -1
    tex_i[:, TEXTURE_I.offset['BYTES']] = -1
    tex_f = np.zeros((max(len(rows), 1), TEXTURE_F.width), np.float32)
    chunks, off = {np.float32: [], np.uint8: []}, {np.float32: 0, np.uint8: 0}
    for k, (pixels, wrap_s, wrap_t, scale, bias, transform) in enumerate(rows):
        kind = np.uint8 if isinstance(pixels, D.BytePixels) else np.float32
        px = np.ascontiguousarray(pixels.data if kind is np.uint8 else pixels, kind)
        if px.ndim == 2:
            px = px[:, :, None]
        h, w, c = px.shape
        TEXTURE_I.write(tex_i[k], OFFSET=off[kind], WIDTH=w, HEIGHT=h, CHANNELS=c, WRAP_S=WRAP.get(wrap_s, 0),
                        WRAP_T=WRAP.get(wrap_t, 0), BYTES=pixels.srgb if kind is np.uint8 else -1)
        if k < len(udim) and udim[k] >= 0:
            TEXTURE_I.write(tex_i[k], UDIM=udim[k], UDIM_ROWS=len(textures[k].tiles) // 10)
        TEXTURE_F.write(tex_f[k], SCALE=scale, BIAS=bias, XF=transform)
        chunks[kind].append(px.ravel())
        off[kind] += px.size
    return (tex_i, tex_f, *(np.concatenate(chunks[kind]) if chunks[kind] else np.zeros(1, kind)
                            for kind in (np.float32, np.uint8)))


def _light_tables(lights: list[D.Light], origin: np.ndarray):
    nl = len(lights)
    li_type = np.full(max(nl, 1), -1, np.int32)
    li_f = np.zeros((max(nl, 1), LIGHT_F.width), np.float64)
    li_tex = np.full(max(nl, 1), -1, np.int32)
    li_f[:, LIGHT_F.offset['IES']] = -1.0
    profiles, blocks, size = {}, [], 0                # each IES profile once (lights share them)
    for k, l in enumerate(lights):
        m = np.array(l.matrix, np.float64)
        m3 = m[:3, :].copy()
        m3[:, 3] -= origin
        li_type[k] = l.type
        radius, area = l.radius, 0.0
        if l.type == D.RECT:
            area = np.linalg.norm(np.cross(m[:3, 0] * l.width, m[:3, 1] * l.height))
        elif l.type == D.DISK:
            area = np.pi * np.linalg.norm(np.cross(m[:3, 0] * l.radius, m[:3, 1] * l.radius))
        elif l.type == D.SPHERE:
            radius = l.radius * np.cbrt(abs(np.linalg.det(m[:3, :3])))
            area = 4 * np.pi * radius * radius
        elif l.type == D.CYLINDER:                   # its side (Light.matrix is rigid: world sizes)
            area = 2 * np.pi * l.radius * l.length
        if l.type in (D.DOME, D.RECT):
            li_tex[k] = l.texture
        LIGHT_F.write(li_f[k], M=m3.ravel(), RAD=l.radiance, RADIUS=radius, W=l.width, H=l.height,
                      COS_MAX=np.cos(np.radians(0.5 * l.angle)), AREA=area, LENGTH=l.length, GAIN=l.gains)
        if l.course_intensity is not None and l.type in (D.POINT, D.RECT):
            LIGHT_F.write(li_f[k], COURSE=1.0, COURSE_I=l.course_intensity)
        if l.shaping is not None:
            cone, softness, focus, tint = l.shaping
            theta = np.radians(cone)
            LIGHT_F.write(li_f[k], SHAPED=1.0, CONE=(theta, theta * (1.0 - softness)), FOCUS=focus, TINT=tint)
        if l.ies is not None:
            if id(l.ies) not in profiles:
                p = l.ies
                profiles[id(l.ies)] = size
                h, c = p.horizontal, p.candela
                if not np.any(c != c[:1]):           # the same all round: one row (`ies_profiles.ies_weight`)
                    h, c = h[:1], c[:1]
                blocks.append(np.concatenate([[len(p.vertical), len(h)], p.vertical, h, c.ravel()]))
                size += len(blocks[-1])
            if l.shaping is None:                    # (no cone: one past every angle)
                LIGHT_F.write(li_f[k], SHAPED=1.0, CONE=(4.0, 4.0), FOCUS=0.0)
            LIGHT_F.write(li_f[k], IES=(profiles[id(l.ies)], 1.0 + l.ies_angle_scale, l.ies_gain))
    li_ies = np.ascontiguousarray(np.concatenate(blocks) if blocks else np.zeros(1), np.float64)
    return li_type, li_f, li_tex, li_ies


def _container_shapes(c: D.Container, ctr: np.ndarray):
    """A container's Embree geometry in its object space (re-centred on `ctr`): ([(vertices float32,
    triangles uint32)] per mesh, [rows (centre - ctr, radius) float64 (n, 4)] per sphere gprim (one row, or a
    point cloud's n), or None for a lone sphere that is not similarity-placed (an ellipsoid: an instance of the
    unit sphere); a point cloud's spheres under such a matrix stay spheres, their radii scaled by its mean
    scale, |det|^(1/3)), [`embree.CurveGeometry`] per curves gprim)."""
    meshes = [((np.asarray(m.points, np.float64) - ctr).astype(np.float32),
               np.ascontiguousarray(m.triangles, np.uint32)) for m in c.meshes]
    spheres = []
    for s in c.spheres:
        scale = _similarity_scale(s.matrix[:3, :3])
        if scale is None and s.centers is not None:
            scale = float(abs(np.linalg.det(s.matrix[:3, :3])) ** (1.0 / 3.0))
        if scale is None:
            spheres.append(None)
            continue
        b = s.placed_balls(scale)
        b[:, :3] -= ctr
        spheres.append(b)
    curves = [CurveGeometry(x.linear, (x.vertices - np.append(ctr, 0.0)).astype(np.float32),
                            x.segments.astype(np.uint32), x.flags,
                            None if x.normals is None else x.normals.astype(np.float32)) for x in c.curves]
    return meshes, spheres, curves


def _prototypes(dev: Device, containers: list, tables: GprimTables, kept: list):
    """One Embree scene per container, geometry re-centred on the container's centre; spheres that
    are not similarity-placed (ellipsoids) are left out and listed (container, sphere index) to be
    placed as instances of the unit sphere.  `kept`: the prototype scenes of an earlier build of the
    same containers, taken over instead of built (empty: build them).  -> (scenes, centres, radii, first gprim per
    container, Embree geometry -> gprim per container, ellipsoids)."""
    protos, centers, radii, pr_gp_start, pr_geom, ellipsoids = [], [], [], [], [], []
    for ci, c in enumerate(containers):
        ctr = _container_center(c)
        centers.append(ctr)
        radii.append(_container_radius(c, ctr))
        pr_gp_start.append(len(tables.kind))
        e_meshes, spheres, curves = _container_shapes(c, ctr)
        e_spheres, geom_to_gp = [], []
        for m, (v32, tris) in zip(c.meshes, e_meshes):
            geom_to_gp.append(len(tables.kind))
            tables.add_mesh(v32, tris, m)
        for si, (s, cr) in enumerate(zip(c.spheres, spheres)):
            if cr is None:                            # an ellipsoid: placed as an instance below
                ellipsoids.append((ci, si))
                tables.add_sphere(None, s.material)
                continue
            geom_to_gp.append(len(tables.kind))
            tables.add_sphere(cr, s.material, s.colors)
            e_spheres.append(cr.astype(np.float32))
        for x, geometry in zip(c.curves, curves):
            geom_to_gp.append(len(tables.kind))
            tables.add_curves(geometry, x)
        protos.append(kept[ci] if kept else dev.prototype_scene(e_meshes, e_spheres, curve_gprims=curves))
        pr_geom.append(geom_to_gp)
    return protos, centers, radii, pr_gp_start, pr_geom, ellipsoids


def _ellipsoid_placements(containers, ellipsoids, unit: int, rows: dict, material_sets: list) -> None:
    """Append to `rows` (placement rows: proto, world, set) one placement of the unit-sphere
    container `unit` per placed ellipsoid, with a material set of its own material."""
    set_of = {}
    base_proto, base_world, base_set = rows['proto'][0], rows['world'][0], rows['set'][0]
    for ci, si in ellipsoids:
        sel = np.nonzero(base_proto == ci)[0]
        if not len(sel):
            continue
        s = containers[ci].spheres[si]
        slot = len(containers[ci].meshes) + si
        per_set = np.array([ms[slot] if slot < len(ms) else -1 for ms in material_sets] or [-1], np.int64)
        mats = per_set[base_set[sel]] if material_sets else np.full(len(sel), -1)
        mats = np.where(mats >= 0, mats, s.material)
        uniq, inv = np.unique(mats, return_inverse=True)
        ids = []
        for mv in uniq:
            key = (int(mv),)
            if key not in set_of:
                set_of[key] = len(material_sets)
                material_sets.append(key)
            ids.append(set_of[key])
        rows['proto'].append(np.full(len(sel), unit, np.int64))
        rows['world'].append(base_world[sel] @ (s.matrix @ np.diag([s.radius] * 3 + [1.0])))
        rows['set'].append(np.asarray(ids, np.int64)[inv])


def _flat_material_sets(material_sets: list, set_rows: np.ndarray):
    """(flat material list, per placement offset into it); -1 offset = the placement binds nothing
    (use the gprims' own materials)."""
    set_off = np.full(len(material_sets) + 1, -1, np.int64)
    flat = []
    for k, s in enumerate(material_sets):
        if any(v >= 0 for v in s):
            set_off[k] = len(flat)
            flat.extend(s)
    return flat, (set_off[set_rows] if len(set_rows) else np.zeros(0, np.int64))


def _top_level(dev: Device, protos: list, in_proto: np.ndarray, xf: np.ndarray, K: int):
    """The top-level scene: static placements in one instance array, moving ones in another (K time
    steps).  -> (scene, placement order of the instance rows, first row of each instance geometry)."""
    moving = np.zeros(len(in_proto), bool)
    if K > 1 and len(xf):
        moving = np.any(xf != xf[:, :1], axis=(1, 2, 3))
    groups, order = [], []
    for rows, steps in ((np.nonzero(~moving)[0], 1), (np.nonzero(moving)[0], K)):
        if len(rows):
            groups.append(InstanceGroup(in_proto[rows].astype(np.uint32),
                                        np.ascontiguousarray(xf[rows, :steps].transpose(1, 0, 2, 3), np.float32)))
            order.append(rows)
    top = dev.top_scene(protos, groups)
    top.groups = groups                     # kept for `path_top`
    perm = np.concatenate(order) if order else np.zeros(0, np.int64)
    gids = list(top.group_geom_ids)
    grp_base = np.full(max(gids, default=0) + 1, -1, np.int64)
    start = 0
    for gid, rows in zip(gids, order):
        grp_base[gid] = start
        start += len(rows)
    return top, perm, grp_base


def _flat_geometry(built: 'BuiltScene', containers: list):
    """The geometry of every placement, placed (camera-relative world space), when the scene can be one
    level: nothing moves and every container is placed once (a prototype placed twice is never
    flattened), by an invertible matrix (and, where the container holds spheres, a similarity: a placed
    sphere stays a sphere), and no container holds curves.  -> [(placement row, (meshes, spheres) placed, their
    geometry ids in the prototype)], or None."""
    d = built.data
    if built.motion_steps != 1 or len(built.top.groups) != 1:
        return None
    if np.any(np.bincount(d.in_proto) > 1) or np.any(d.in_proto >= len(containers)):   # the ellipsoids' unit sphere
        return None
    out = []
    for row in range(len(d.in_proto)):
        m = d.in_xf[row, 0]
        if not np.isfinite(m).all() or abs(np.linalg.det(m[:, :3])) < 1e-300:
            return None
        c = containers[int(d.in_proto[row])]
        if c.curves:                                  # (curves stay in their prototype)
            return None
        meshes, spheres, _ = _container_shapes(c, _container_center(c))
        spheres = [cr for cr in spheres if cr is not None]
        scale = _similarity_scale(m[:, :3])
        if spheres and scale is None:
            return None
        placed_meshes = [((v.astype(np.float64) @ m[:, :3].T + m[:, 3]).astype(np.float32), t) for v, t in meshes]
        placed_spheres = [_placed_rows(cr, m, scale) for cr in spheres]
        out.append((row, (placed_meshes, placed_spheres), list(range(len(meshes) + len(spheres)))))
    return out


def _placed_rows(rows: np.ndarray, m: np.ndarray, scale: float) -> np.ndarray:
    """Sphere rows (centre, radius) placed by the (3, 4) matrix m of similarity scale `scale`."""
    if len(rows) == 1:
        return np.array([[*(m[:, :3] @ rows[0, :3] + m[:, 3]), rows[0, 3] * scale]], np.float64)
    return np.column_stack([rows[:, :3] @ m[:, :3].T + m[:, 3], rows[:, 3] * scale])


def _path_prototypes(built: 'BuiltScene', containers: list) -> list:
    """The prototypes the path integrator's instances place: the built ones, except where a container holds
    spheres (and the ellipsoids' unit sphere): those are built again with their spheres as user geometry
    (`embree.Device.prototype_scene(user_shapes=True)`: the ray-sphere test in float64, 1.2-2x faster a
    ray than Embree's SPHERE_POINT, RESULTS.md "Spheres as user geometry"), the cook integrator's keeping
    Embree's own spheres (its images unchanged).  Built once a BuiltScene (`built.path_prototypes`, which a
    shot's next frame takes over with the prototypes)."""
    if built.path_prototypes is None:
        own = {}
        for ci, c in enumerate(containers):
            meshes, spheres, curves = _container_shapes(c, _container_center(c))
            spheres = [cr for cr in spheres if cr is not None]
            if spheres:                               # (with curves beside them: Embree's, as in `_prototypes`)
                own[ci] = built.device.prototype_scene(meshes, spheres, user_shapes=True, curve_gprims=curves)
        if len(built.prototypes) > len(containers):       # the ellipsoids' unit sphere (`build`)
            own[len(containers)] = built.device.prototype_scene([], [np.array([[0.0, 0.0, 0.0, 1.0]])],
                                                                user_shapes=True)
        built.path_prototypes = own
    return [built.path_prototypes.get(k, p) for k, p in enumerate(built.prototypes)]


def _mask_runs(masks: list[int]) -> list[tuple[int, int, int]]:
    """(start, end, mask) of each run of equal consecutive masks."""
    runs = []
    for j, m in enumerate(masks):
        if runs and runs[-1][2] == m:
            runs[-1] = (runs[-1][0], j + 1, m)
        else:
            runs.append((j, j + 1, m))
    return runs


def path_top(built: 'BuiltScene', containers: list, shapes, light_group: int):
    """The path integrator's top level: (Embree scene, or None when the built top level serves as it is;
    the geomID of its first geometry of its own; int64 (n, 3) rows (instance id, instance index, geometry
    id in its prototype) that the hits on each of those geometries stand for, in geomID order).

    * The light shapes (`shapes`: (geometry, masks) of light_selection.shape_geometry, or None) are in it,
      so that one query of a camera or BSDF ray finds the nearest surface or light shape; they stand for
      instance `light_group`.  They have ray masks MASK_LIGHT_SHAPES or MASK_FACING << g (one-sided
      planar lights facing one way: a ray that cannot see their emitting side leaves that bit out) and
      every surface MASK_SURFACES, so that shadow rays (mask MASK_SURFACES) pass them: light shapes
      occlude nothing.
    * A scene that can be one level (`_flat_geometry`: every prototype placed once, nothing moving) is:
      its geometry and the light shapes sit in the top level itself, placed, and a ray meets them without
      entering an instance (Embree's time on the path integrator's own rays: 1/1.04-1/1.61 of the
      instanced scene's).
      Otherwise the built placements stay instance arrays 0..n-1 and the light shapes are instances
      `light_group`, `light_group` + 1, ..., one per ray mask (each its own BVH: Embree tests a ray's
      mask against an instance's before it enters, but against a primitive's only in a leaf; their geomIDs
      are those of `shape_geometry`'s order across them): Embree traverses one BVH per kind of geometry in a scene,
      and in a scene that keeps instances, geometry taken out of them adds a BVH that every ray traverses (Embree
      time 0.71x-1.33x measured: RESULTS.md, "The path integrator's top level").
    * Its spheres (placed, in the prototypes it instances, and the sphere lights) and the cylinder lights'
      shapes are user geometry, tested in float64 (`user_geometry.py`, `_path_prototypes`): the cylinders
      exact (open) where Embree's round linear curves were capsules, and no Embree curve beside user
      geometry (the two in one Embree scene are traversed 1.6x slower: RESULTS.md, "Spheres as user
      geometry").  A scene with none of the above is traced in the built top level."""
    flat = _flat_geometry(built, containers)
    if flat is None:
        protos, lights = _path_prototypes(built, containers), []
        if shapes is None and not built.path_prototypes:
            return None, -1, np.zeros((0, 3), np.int64)
        groups, group_masks = list(built.top.groups), [MASK_SURFACES] * len(built.top.groups)
        if shapes is not None:
            (meshes, spheres, curves), masks = shapes
            n_m, n_s = len(meshes), len(spheres)
            for a, b, mask in _mask_runs(masks):
                lights.append(built.device.prototype_scene(
                    meshes[a:b], spheres[max(a - n_m, 0):max(b - n_m, 0)], first_id=a,
                    curves=curves[max(a - n_m - n_s, 0):max(b - n_m - n_s, 0)], masks=[mask] * (b - a),
                    user_shapes=True))
                groups.append(InstanceGroup(np.array([len(protos)], np.uint32),
                                            np.eye(4, dtype=np.float32)[None, None, :3]))
                protos.append(lights[-1])
                group_masks.append(mask)
        top = built.device.top_scene(protos, groups, masks=group_masks)
        for scene in lights:
            scene.close()                                 # the top level holds its own reference
        return top, -1, np.zeros((0, 3), np.int64)
    base = light_group + 1
    direct, table = [], []
    for row, (meshes, spheres), geoms in flat:
        direct.append((base + len(table), MASK_SURFACES, meshes, spheres, ()))
        table += [(0, row, g) for g in geoms]
    if shapes is not None:
        (meshes, spheres, curves), masks = shapes
        direct.append((base + len(table), masks, meshes, spheres, curves))
        table += [(light_group, 0, g) for g in range(len(meshes) + len(spheres) + len(curves))]
    top = built.device.top_scene([], [], direct=direct, user_shapes=True)
    return top, base, np.array(table, np.int64).reshape(-1, 3)


def build(desc: D.SceneDescription, threads: int | None = None, reuse: BuiltScene | None = None) -> BuiltScene:
    """Build Embree scenes (one per container + the top level) and the shading tables.

    `reuse`: the BuiltScene of a description whose containers are the same as `desc`'s (e.g. the
    previous frame of a shot where only placements, the camera, lights or materials change): its
    device and prototype BVHs are taken over and only the top level is built; `reuse` keeps nothing
    (its top level is released) and must not be rendered afterwards."""
    inst = desc.instances
    containers = list(desc.containers)
    tables = GprimTables()
    dev = reuse.device if reuse is not None else Device(threads=threads)
    kept = list(reuse.prototypes) if reuse is not None else []
    kept_path = reuse.path_prototypes if reuse is not None else None
    protos, centers, radii, pr_gp_start, pr_geom, ellipsoids = _prototypes(dev, containers, tables, kept)

    rows = {'proto': [np.asarray(inst.container, np.int64)], 'world': [np.asarray(inst.matrices, np.float64)],
            'set': [np.asarray(inst.material_set, np.int64)]}
    material_sets = [tuple(int(v) for v in s) for s in inst.material_sets]
    if ellipsoids:                                    # one shared unit-sphere container
        unit = len(protos)
        centers.append(np.zeros(3))
        radii.append(1.0)
        pr_gp_start.append(len(tables.kind))
        pr_geom.append([len(tables.kind)])
        tables.add_sphere(np.array([[0.0, 0.0, 0.0, 1.0]]), -1)
        protos.append(kept[unit] if kept else dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)]))
        _ellipsoid_placements(containers, ellipsoids, unit, rows, material_sets)

    in_proto = np.concatenate(rows['proto'])
    world = np.concatenate(rows['world'], axis=0) if rows['world'][0].ndim == 4 else rows['world'][0]
    set_rows = np.concatenate(rows['set'])
    K = int(world.shape[1]) if world.ndim == 4 and len(world) else 1

    # placement matrices act on re-centred containers (M' = M T(centre)), relative to the float origin
    ctr_arr = np.array(centers, np.float64).reshape(-1, 3)
    origin = float_origin(desc.camera.matrix[:3, 3], world, in_proto, ctr_arr, np.array(radii, np.float64))
    xf = np.zeros((len(in_proto), K, 3, 4), np.float64)
    if len(in_proto):
        xf[:] = world[:, :, :3, :]
        xf[:, :, :, 3] += np.einsum('rkij,rj->rki', world[:, :, :3, :3], ctr_arr[in_proto])
        xf[:, :, :, 3] -= origin
    flat, in_matset = _flat_material_sets(material_sets, set_rows)
    top, perm, grp_base = _top_level(dev, protos, in_proto, xf, K)
    if reuse is not None:                             # the prototypes and the device now belong to this build
        reuse.top.close()
        reuse.prototypes, reuse.device, reuse.path_prototypes = [], None, None

    mat_i, mat_f = _material_tables(desc.materials)
    tex_i, tex_f, tex_data, tex_bytes = _texture_tables(desc.textures)
    li_type, li_f, li_tex, li_ies = _light_tables(desc.lights, origin)
    geom_off = np.cumsum([0] + [len(g) for g in pr_geom]).astype(np.int64)
    gp_material = np.array(tables.material, np.int32)
    gp_material[gp_material < 0] = len(mat_i) - 1       # unbound -> default material

    data = SceneData(
        gp_kind=np.array(tables.kind, np.int32), gp_off=np.array(tables.off, np.int64),
        gp_flags=np.array(tables.flags, np.int32), gp_material=gp_material,
        gp_n_off=np.array(tables.n_off, np.int64), gp_uv_off=np.array(tables.uv_off, np.int64),
        gp_c_off=np.array(tables.c_off, np.int64),
        tri_v=_cat(tables.tri_v, (1, 3, 3), np.float32), tri_n=_cat(tables.tri_n, (1, 3, 3), np.float32),
        tri_uv=_cat(tables.tri_uv, (1, 3, 2), np.float32), tri_c=_cat(tables.tri_c, (1, 3, 4), np.float32),
        sph=np.array(tables.sph, np.float64).reshape(-1, 4) if tables.sph else np.zeros((1, 4)),
        crv=_cat(tables.crv, (1, 4, 4), np.float32), crv_n=_cat(tables.crv_n, (1, 4, 3), np.float32),
        pr_gp_start=np.array(pr_gp_start, np.int64), pr_geom_off=geom_off,
        pr_geom_gp=np.array([g for gs in pr_geom for g in gs] or [0], np.int64),
        in_proto=np.ascontiguousarray(in_proto[perm], np.int32),
        in_xf=np.ascontiguousarray(xf[perm]) if len(perm) else np.zeros((1, K, 3, 4)),
        in_matset=np.ascontiguousarray(in_matset[perm], np.int64) if len(perm) else np.zeros(1, np.int64),
        matset=np.array(flat or [-1], np.int32), grp_base=grp_base,
        mat_i=mat_i, mat_f=mat_f, tex_i=tex_i, tex_f=tex_f, tex_data=tex_data, tex_bytes=tex_bytes,
        tex_lut=byte_lut() if desc.textures else np.zeros((2, 256), np.float32),
        li_type=li_type, li_f=li_f, li_tex=li_tex, li_ies=li_ies,
        background=np.array(desc.background, np.float64),
        offset_scale=np.array([offset_scale(xf, in_proto, np.array(radii, np.float64))], np.float64),
        see_through=np.zeros(1, np.int32),
    )
    data.see_through[0] = see_through(data)          # (the cook integrator's shadow rays: `integrator._transmittance`)
    return BuiltScene(device=dev, prototypes=protos, top=top, data=data, origin=origin, motion_steps=K,
                      has_textures=bool(desc.textures), has_dome=bool(np.any(li_type == D.DOME)),
                      n_instances=len(perm), path_prototypes=kept_path)
