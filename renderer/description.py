"""What the renderer sees of a scene: plain data, no pxr, no Embree.

`rtc.renderer.usd.stage.read_stage()` turns a composed USD stage into a `SceneDescription`;
`rtc.renderer.host.build` turns the description into Embree scenes and numba tables.  Everything
downstream of the stage reader depends only on this module (and numpy).

Conventions
-----------
* Matrices are float64 4x4 for **column vectors** (``p_world = M @ [x, y, z, 1]``); this is the
  transpose of pxr's row-vector ``Gf.Matrix4d``.  Translation is ``M[:3, 3]``.
* World space is Y-up, right-handed, in scene units (a Z-up stage is rotated to Y-up by the
  reader; metersPerUnit is recorded, not applied).
* A *container* is a piece of geometry that is built once (one Embree scene, one BVH): the stage
  root's own gprims, each native prototype, each PointInstancer prototype.  Nested instancing is
  flattened by the reader to one level: every placement of a container is one row of
  ``SceneDescription.instances``.
* Colours are linear RGB float.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

FLOAT32_MAX = float(np.finfo(np.float32).max)     # Embree traces in float32: coordinates past it are inf


# --------------------------------------------------------------------------- geometry
@dataclass
class Mesh:
    """A triangulated polygon mesh, in its container's space (gprim-to-container transform baked)."""
    path: str                          # USD path of the gprim (prototype path for instanced ones)
    points: np.ndarray                 # float64 (n, 3), container space
    triangles: np.ndarray              # int32 (m, 3), counter-clockwise seen from the outside
                                       # (leftHanded orientation and mirrored transforms already fixed)
    normals: Optional[np.ndarray] = None   # float32 (m, 3, 3) per-corner shading normals, container space, unit
    uvs: Optional[np.ndarray] = None       # float32 (m, 3, 2) per-corner texture coordinates (primvars:st)
    colors: Optional[np.ndarray] = None    # float32 (m, 3, 3) per-corner primvars:displayColor where it varies
                                           # over the mesh (a material with vertex_colors multiplies its diffuse);
                                           # (m, 3, 4) with primvars:displayOpacity where that varies (a
                                           # material with vertex_opacity multiplies its opacity by channel 3)
    material: int = -1                 # default material index (binding inside the container), -1 = none
    double_sided: bool = True

    def reach(self) -> float:
        """The largest magnitude of a coordinate of the mesh in container space."""
        return float(np.abs(self.points).max(initial=0.0))


@dataclass
class Sphere:
    """An analytic sphere (UsdGeom.Sphere, course sphere): centre/radius in gprim space plus the
    gprim-to-container matrix, which may be any affine map (ellipsoids are exact); or, with `centers`
    and `radii`, a cloud of spheres (UsdGeom.Points: one gprim, one sphere a point, each its own
    primitive of the gprim's Embree geometry), whose matrix scales each radius by its mean scale where
    it is not a similarity."""
    path: str
    radius: float
    matrix: np.ndarray                 # float64 (4, 4) gprim-to-container, column vectors
    material: int = -1
    centers: Optional[np.ndarray] = None   # float64 (n, 3) gprim space: a point cloud
    radii: Optional[np.ndarray] = None     # float64 (n,) its spheres' radii, gprim space
    colors: Optional[np.ndarray] = None    # float32 (n, 3) a cloud's displayColor a point, where it varies; (n, 4)
                                           # with its displayOpacity, where that varies (as `Mesh.colors`)

    def balls(self) -> np.ndarray:
        """float64 (n, 4): each sphere's centre and radius in gprim space (one row for a lone sphere)."""
        if self.centers is None:
            return np.array([[0.0, 0.0, 0.0, self.radius]])
        return np.column_stack([self.centers, self.radii])

    def placed_balls(self, scale: float) -> np.ndarray:
        """float64 (n, 4): each sphere's centre in container space and its radius times `scale` (the
        matrix's similarity scale)."""
        b = self.balls()
        m = self.matrix
        return np.column_stack([b[:, :3] @ m[:3, :3].T + m[:3, 3], b[:, 3] * scale])

    def reach(self) -> float:
        """A bound of the largest magnitude of a coordinate of the sphere(s) in container space: |M p| <= |M|
        |p| in the max norm, for the points p of the balls (|p| <= |centre| + radius)."""
        b = np.abs(self.balls())
        m = np.abs(self.matrix[:3])
        return float(m[:, 3].max() + m[:, :3].sum(1).max() * (b[:, :3].max(1) + b[:, 3]).max())


@dataclass
class Curves:
    """UsdGeom.BasisCurves as round tubes of the curve's width, in its container's space: cubic curves of any basis
    as cubic Bezier segments (four control points each), linear curves as chains of cones with round joints
    (Embree's round curves: `usd/curves.py`); with `normals`, flat ribbons facing them (Embree's normal-oriented
    Bezier curves; a linear curve's segments then straight Bezier segments)."""
    path: str
    vertices: np.ndarray               # float64 (n, 4): control points x, y, z and the radius there, container space
    segments: np.ndarray               # int64 (k,): each segment's first vertex (cubic: 4 vertices, linear: 2)
    linear: bool
    flags: Optional[np.ndarray] = None     # uint8 (k,) linear: 1 the segment before it joins it, 2 the one after
    colors: Optional[np.ndarray] = None    # float32 (k, 2, 3) displayColor at each segment's two ends, where it varies
    material: int = -1
    normals: Optional[np.ndarray] = None   # float64 (n, 3) a unit normal a vertex: ribbons facing them (cubic only)

    def segment_rows(self) -> np.ndarray:
        """float64 (k, 4, 4): each segment's control points (a linear one's two ends, then its end again)."""
        return segment_rows(self.vertices, self.segments, self.linear)

    def reach(self) -> float:
        """The largest magnitude of a control point's coordinate or radius, in container space."""
        return float(np.abs(self.vertices).max(initial=0.0))


def segment_rows(vertices: np.ndarray, segments: np.ndarray, linear: bool) -> np.ndarray:
    """(k, 4, columns) rows of curve segments (`Curves`): each segment's four control points from its first vertex
    (a linear segment's two ends, then its end again)."""
    take = np.minimum(np.arange(4), 1 if linear else 3)
    return np.ascontiguousarray(vertices[np.asarray(segments, np.int64)[:, None] + take])


@dataclass
class Container:
    key: str                           # stable name within one read ('/', prototype path, 'PI:/path')
    meshes: list[Mesh] = field(default_factory=list)
    spheres: list[Sphere] = field(default_factory=list)
    curves: list[Curves] = field(default_factory=list)

    @property
    def gprims(self) -> list:
        """Gprim order used for per-gprim material sets: meshes first, then spheres, then curves."""
        return [*self.meshes, *self.spheres, *self.curves]


@dataclass
class Instances:
    """All placements of all containers, flattened to one level (structure of arrays).

    ``matrices[i, k]`` is the container-to-world matrix of placement i at motion sample k; the
    K samples are uniformly spaced over the camera shutter (K = 1 for a static scene).
    ``material_sets[s]`` lists one material index per gprim of the container (``Container.gprims``
    order), after resolving bindings on the instance prim and its ancestors; -1 = use the gprim's own
    ``material``.  Placements with identical bindings share a set (a PointInstancer's instances
    usually share one)."""
    container: np.ndarray              # int32 (N,) index into SceneDescription.containers
    matrices: np.ndarray               # float64 (N, K, 4, 4)
    material_set: np.ndarray           # int32 (N,) index into material_sets
    material_sets: list[tuple[int, ...]] = field(default_factory=list)
    paths: list[str] = field(default_factory=list)   # optional: a label per placement (may be empty for PIs)

    @property
    def count(self) -> int:
        return int(self.container.shape[0])

    @property
    def motion_steps(self) -> int:
        return int(self.matrices.shape[1])


# --------------------------------------------------------------------------- appearance
# Material models.  Course models carry their exact parameters (``rtc:`` attributes on the
# Material prim); everything else is a UsdPreviewSurface.
LAMBERTIAN, BLINN_PHONG, MIRROR, GLAZE, BLINN_PHONG_MIRRORED, DIELECTRIC, COOL_TO_WARM, PREVIEW_SURFACE = range(8)
MODEL_NAMES = {
    'lambertian': LAMBERTIAN, 'blinnPhong': BLINN_PHONG, 'mirror': MIRROR, 'glaze': GLAZE,
    'blinnPhongMirrored': BLINN_PHONG_MIRRORED, 'dielectric': DIELECTRIC, 'coolToWarm': COOL_TO_WARM,
    'previewSurface': PREVIEW_SURFACE,
}


@dataclass
class Material:
    path: str
    model: int = PREVIEW_SURFACE
    diffuse: tuple = (0.18, 0.18, 0.18)     # kd / diffuseColor
    specular: tuple = (0.0, 0.0, 0.0)       # ks / specularColor
    exponent: float = 0.0                   # Blinn-Phong exponent (course phongExp)
    mirror_coef: float = 0.0                # course mirrorCoef
    roughness: float = 0.0                  # course glossy roughness / UsdPreviewSurface roughness
    ior: float = 1.5                        # dielectric refractive index / UsdPreviewSurface ior
    attenuation: tuple = (1.0, 1.0, 1.0)    # dielectric per-unit-distance transmittance (Beer)
    emission: tuple = (0.0, 0.0, 0.0)       # UsdPreviewSurface emissiveColor
    metallic: float = 0.0                   # UsdPreviewSurface
    opacity: float = 1.0                    # UsdPreviewSurface
    opacity_threshold: float = 0.0          # UsdPreviewSurface: > 0, opacity below it is 0, at or above it 1
    use_specular_workflow: bool = False     # UsdPreviewSurface
    clearcoat: float = 0.0
    clearcoat_roughness: float = 0.01
    # a MeshLightAPI mesh's inputs:diffuse and inputs:specular: its emission's effect on the diffuse and on the
    # specular lobes of the surfaces it lights (as a light's, `Light.gains`)
    light_gains: tuple = (1.0, 1.0)
    diffuse_texture: int = -1               # index into SceneDescription.textures (multiplies diffuse)
    specular_texture: int = -1
    emission_texture: int = -1              # (multiplies emission: emissiveColor connected to a UsdUVTexture)
    vertex_colors: bool = False             # diffuse times the gprim's per-corner displayColor (Mesh.colors)
    vertex_opacity: bool = False            # opacity times the gprim's per-corner displayOpacity (its channel 3)
    # UsdPreviewSurface roughness, metallic, opacity, clearcoat, clearcoatRoughness connected to a UsdUVTexture's
    # r, g, b or a output: its index (-1: none) and the channel (0-3) for each, in that order; the input's value (1)
    # is multiplied by it
    scalar_textures: tuple = (-1, -1, -1, -1, -1)
    scalar_channels: tuple = (0, 0, 0, 0, 0)
    normal_texture: int = -1                # UsdPreviewSurface normal connected to a UsdUVTexture (tangent space)
    # cool-to-warm (Gooch): the course's diffuse is the object colour; cool/warm tints are fixed constants


@dataclass
class BytePixels:
    """An 8-bit image's pixels as its bytes, (h, w, c) uint8, read through `images.byte_lut`: its first `srgb`
    channels sRGB-decoded, the others (alpha, or every channel of a raw image) as v / 255.  A quarter of the
    float32 image's memory, and the same values (`linear`)."""
    data: np.ndarray
    srgb: int = 0

    @property
    def shape(self) -> tuple:
        return self.data.shape

    def flipped(self) -> 'BytePixels':
        """The image upside down (rows reversed)."""
        return BytePixels(np.ascontiguousarray(self.data[::-1]), self.srgb)

    def linear(self) -> np.ndarray:
        """The float32 linear values the kernels read (what the float32 path decodes, bit for bit)."""
        from .images import byte_lut
        lut = byte_lut()
        c = self.data.shape[2]
        return np.stack([lut[1 if k < self.srgb else 0][self.data[..., k]] for k in range(c)], -1)


def linear_pixels(pixels) -> np.ndarray:
    """A texture's (or tile's) pixels as float32 linear values, whether stored as floats or as `BytePixels`."""
    return pixels.linear() if isinstance(pixels, BytePixels) else np.asarray(pixels, np.float32)


def float_textures(desc: 'SceneDescription') -> 'SceneDescription':
    """`desc` with every texture's (and UDIM tile's) pixels as float32 values, as rtc kept them before 8-bit images
    kept their bytes: the same values (benchmarks and tests compare the two, and give an older renderer these)."""
    from dataclasses import replace
    return replace(desc, textures=[replace(t, pixels=linear_pixels(t.pixels), tiles=tuple(
        None if p is None else linear_pixels(p) for p in t.tiles)) for t in desc.textures])


@dataclass
class Texture:
    path: str                               # resolved file path
    pixels: np.ndarray                      # float32 (h, w, c) linear (sRGB decoded where the file is sRGB), or
                                            # an 8-bit file's `BytePixels`
    wrap_s: str = 'repeat'                  # 'repeat' | 'clamp' | 'mirror' | 'black'
    wrap_t: str = 'repeat'
    scale: tuple = (1.0, 1.0, 1.0, 1.0)
    bias: tuple = (0.0, 0.0, 0.0, 0.0)
    # UsdTransform2d between the texture coordinates and the lookup: s' = a s + b t + c, t' = d s + e t + f
    transform: tuple = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    # UDIM (a file path with <UDIM>): the pixels of tiles 1001, 1002, ... (ten a row of t; None: no such tile, read
    # as 0), whose tile s, t in [0, 10) x [0, rows) reads at (s - floor s, t - floor t); `pixels` then unused
    tiles: tuple = ()


# Light types
POINT, SPHERE, RECT, DISK, DISTANT, DOME, CYLINDER = range(7)


@dataclass(frozen=True, eq=False)
class IesProfile:
    """A luminaire's photometric profile (an IES LM-63 file of photometric type C, `usd/ies.py`): its luminous
    intensity (candela) at each vertical angle (radians from the nadir: 0 along the light's -Z axis) and
    horizontal angle (radians, 0 to 2 pi: the file's symmetries unfolded), interpolated bilinearly between them;
    0 at vertical angles the file does not cover."""
    path: str                               # resolved file path
    vertical: np.ndarray                    # float64 (nv,) ascending, within [0, pi]
    horizontal: np.ndarray                  # float64 (nh,) ascending, from 0 to 2 pi
    candela: np.ndarray                     # float64 (nh, nv)
    mean: float                             # the mean intensity over the (hemi)sphere it covers (`ies.mean_intensity`)


@dataclass
class Light:
    path: str
    type: int
    matrix: np.ndarray                      # float64 (4, 4) light-to-world (UsdLux local frame: emits along -Z)
    radiance: tuple                         # linear RGB: color * intensity * 2**exposure (normalize applied,
                                            # see below); for POINT the radiant intensity (W/sr) instead
    radius: float = 0.0                     # SPHERE, DISK, CYLINDER
    width: float = 0.0                      # RECT (local X)
    height: float = 0.0                     # RECT (local Y)
    angle: float = 0.0                      # DISTANT: angular diameter in degrees
    length: float = 0.0                     # CYLINDER: along local X (centred on the origin; emits from its
                                            # side, outwards, not from its caps)
    texture: int = -1                       # DOME: lat-long texture; RECT: its image (top-left corner at local
                                            # (+X, +Y)); -1 = constant colour
    course_intensity: Optional[tuple] = None  # a course light (RtcCourseLightAPI): the course's intensity I
    # UsdLux.ShapingAPI: (cone angle in degrees off the -Z axis, cone softness, focus, focus tint rgb); None: unshaped
    shaping: Optional[tuple] = None
    # UsdLux.ShapingAPI's IES profile: its intensities multiply the emission towards each direction (divided by the
    # profile's mean when ies:normalize is on: `ies_gain`), at the vertical angle ies:angleScale maps the
    # direction's to (`kernel/ies_profiles.py`)
    ies: Optional[IesProfile] = None
    ies_angle_scale: float = 0.0
    ies_gain: float = 1.0
    # UsdLux inputs:diffuse and inputs:specular: the light's effect on the diffuse and on the specular lobes of
    # the surfaces it lights (direct light only: the light as a camera sees it is unchanged)
    gains: tuple = (1.0, 1.0)
    # For area lights `radiance` is the emitted radiance L after `normalize` (divided by the world-space
    # area when normalize is on); a POINT light's `radiance` is its radiant intensity I, so the irradiance
    # at distance d facing it is I / d**2.  DISTANT: irradiance E on a surface facing it.


@dataclass
class Camera:
    path: str
    matrix: np.ndarray                      # float64 (4, 4) camera-to-world (looks down local -Z, +Y up)
    projection: str = 'perspective'         # 'perspective' | 'orthographic'
    focal_length: float = 5.0               # scene units (USD focalLength * 0.1)
    horizontal_aperture: float = 2.0955     # scene units (USD horizontalAperture * 0.1)
    vertical_aperture: float = 1.5291       # scene units
    horizontal_aperture_offset: float = 0.0
    vertical_aperture_offset: float = 0.0
    lens_radius: float = 0.0                # scene units; 0 = pinhole  (focal_length / (2 fStop))
    focus_distance: float = 1.0             # scene units
    shutter_open: float = 0.0               # time codes relative to the frame
    shutter_close: float = 0.0
    clip_near: float = 1e-6
    clip_far: float = float('inf')
    motion: Optional[np.ndarray] = None     # float64 (K, 4, 4) camera matrices over the shutter, or None


@dataclass
class RenderSettings:
    """What the stage's UsdRender.Settings prim says (None: not authored; `rtc.renderer.options.resolve`
    fills in what is asked for and the defaults)."""
    width: Optional[int] = None
    height: Optional[int] = None
    samples_per_pixel: Optional[int] = None
    camera_path: Optional[str] = None
    disable_motion_blur: bool = False
    disable_depth_of_field: bool = False
    integrator: Optional[str] = None        # custom rtc:integrator: 'cook' (compiled course scenes) or 'path'
                                            # (what the reader gives any other stage); None (descriptions
                                            # built by hand) = cook
    path: Optional[str] = None              # the settings prim, for messages
    encoding: Optional[str] = None          # 8/16-bit image encoding the stage asks for (rtc:imageEncoding)


@dataclass
class SceneDescription:
    source: str                             # file the stage was opened from ('<memory>' if none)
    containers: list[Container]
    instances: Instances
    materials: list[Material]
    textures: list[Texture]
    lights: list[Light]
    camera: Camera
    settings: RenderSettings
    background: tuple = (0.0, 0.0, 0.0)     # radiance of rays that escape when there is no DomeLight
    shutter_times: tuple = (0.0,)           # the K time codes of the motion samples
    meters_per_unit: float = 1.0
    up_axis: str = 'Y'                      # authored up axis (the description itself is always Y-up)
    warnings: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)   # what could not be loaded, with reasons
    options: Optional[object] = None        # the RenderOptions the reader resolved (and fitted the camera to)

    # -- summaries used by `rtc info`, the benchmarks and the tests
    def triangle_counts(self) -> tuple[int, int]:
        """(unique triangles, instanced triangles = sum over placements)."""
        per = np.array([sum(len(m.triangles) for m in c.meshes) for c in self.containers], np.int64)
        unique = int(per.sum())
        instanced = int(per[self.instances.container].sum()) if self.instances.count else 0
        return unique, instanced
