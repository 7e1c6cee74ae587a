"""UsdLux lights -> `Light` records with UsdLux radiometry folded into `radiance`.

``L = color * intensity * 2**exposure`` (times the blackbody colour when
``enableColorTemperature``), then per type:

* area lights (SphereLight with a radius, RectLight, DiskLight, CylinderLight): `radiance` = L,
  divided by the world-space surface area when ``normalize`` is on (a CylinderLight's: its side,
  2 pi r length; it emits outwards from its side only, not from its caps; ``treatAsLine``, a hint
  that renderers which only support area lights may disregard, is disregarded);
* point (SphereLight with ``treatAsPoint`` or radius 0): `radiance` = radiant intensity I.  With
  ``normalize`` (or a zero radius, whose un-normalised power would be 0) I = L / 4, the limit of
  a normalised sphere (power independent of radius); a non-normalised ``treatAsPoint`` sphere of
  world radius r keeps the power of the sphere it stands for, I = L * pi * r**2;
* DistantLight: `radiance` = irradiance E on a surface facing it: L when normalized, else
  L * sizeFactor (pi sin^2(angle/2) per the UsdLux `normalize` documentation, 1 for angle 0);
* DomeLight: L (multiplies the lat-long texture if any; a mirroredBall, angular or cubeMapVerticalCross image
  is resampled into one, `dome_formats.py`).

A RectLight's ``inputs:texture:file`` multiplies L over the rect.  The schema puts "a texture file's min
coordinates at (+X, +Y) and max coordinates at (-X, -Y)": the image's top-left corner at local (+X, +Y) and
its bottom-right at (-X, -Y), so that the image reads as drawn seen from the side the light shines on (as a
screen does).  Pixar's hdEmbree draws it mirrored left to right (its top-left at (-X, +Y)).

`Light.matrix` is returned **rigid** (orthonormal, det +1; emission along its -Z): scale in the
light's transform is folded into `radius` / `width` / `height` / `length`, which are world-space
sizes (a CylinderLight's length scales with local X, its radius with the geometric mean of the Y and Z
scales).
"""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdLux

from ..description import CYLINDER, DISK, DISTANT, DOME, POINT, RECT, SPHERE, Light
from .dome_formats import FORMATS as DOME_FORMATS
from .ies import IesError, read_ies

Warn = Callable[[str], None]
LIGHT_TYPES = ('SphereLight', 'RectLight', 'DiskLight', 'CylinderLight', 'DistantLight', 'DomeLight',
               'DomeLight_1')


def rigid_frame(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split an affine matrix into a rigid one (same origin and Z direction) and the lengths of
    its three axes."""
    lin = m[:3, :3]
    scale = np.linalg.norm(lin, axis=0)
    z = lin[:, 2] / scale[2]
    x = lin[:, 0] - np.dot(lin[:, 0], z) * z
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, 0], out[:3, 1], out[:3, 2], out[:3, 3] = x, np.cross(z, x), z, m[:3, 3]
    return out, scale


def _rotate_x(degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], np.float64)


def read_light(prim: Usd.Prim, to_world: np.ndarray, time: Usd.TimeCode, up_axis: str,
               load_texture: Callable, warn: Warn) -> Optional[Light]:
    """A Light for a UsdLux light prim, or None (with a warning) when it cannot be used.

    `load_texture(asset_path, owner, wrap_s, wrap_t, upside_down[, layout]) -> index` loads a DomeLight's image
    (one in another layout than lat-long, `dome_formats.FORMATS`, as the lat-long image resampled from it) and a
    RectLight's image (upside down: its rows in reverse order)."""
    path, kind = str(prim.GetPath()), prim.GetTypeName()
    bad = _nonfinite_input(prim, time)
    if bad is not None:                   # (an infinite width: its samples' directions NaN, which Embree must not see)
        warn(f'{path}.{bad[0]}: {bad[1]} is not a finite number; light ignored')
        return None
    api = UsdLux.LightAPI(prim)
    base = _base(api, time)
    normalize = bool(api.GetNormalizeAttr().Get(time))
    if not (np.all(np.isfinite(base)) and np.all(np.isfinite(to_world))):
        warn(f'{path}: non-finite light parameters or transform; light ignored')
        return None
    if abs(np.linalg.det(to_world[:3, :3])) < 1e-300:
        warn(f'{path}: singular light transform; light ignored')
        return None
    gains = _lobe_gains(api, path, time, warn)
    if kind in ('DomeLight', 'DomeLight_1'):
        m = to_world
        if kind == 'DomeLight_1':
            pole = prim.GetAttribute('poleAxis').Get(time) or 'scene'
            if pole == 'Z' or (pole == 'scene' and up_axis == 'Z'):
                m = to_world @ _rotate_x(90.0)        # the dome's top pole (+Y) onto local +Z
        frame, _ = rigid_frame(m)
        texture = -1
        asset = _asset_input(prim, 'inputs:texture:file', path, time, warn)
        if asset is not None:
            fmt = prim.GetAttribute('inputs:texture:format').Get(time) or 'automatic'
            if fmt == 'latlong':
                texture = load_texture(asset, path, 'repeat', 'clamp', False)
            elif fmt in DOME_FORMATS or fmt == 'automatic':   # (resampled into a lat-long image: `dome_formats.py`)
                texture = load_texture(asset, path, 'repeat', 'clamp', False, fmt)
            else:
                warn(f'{path}.inputs:texture:format: "{fmt}" is not a dome texture format; read as lat-long')
                texture = load_texture(asset, path, 'repeat', 'clamp', False)
        return Light(path=path, type=DOME, matrix=frame, radiance=_rgb(base), texture=texture, gains=gains)

    frame, scale = rigid_frame(to_world)
    light = _physical_light(prim, kind, path, frame, scale, to_world, base, normalize, time, warn)
    if light is not None and light.type == RECT:
        asset = _asset_input(prim, 'inputs:texture:file', path, time, warn)
        if asset is not None:                         # (clamped at its edges: the image ends where the rect does)
            # under a mirroring transform the rigid frame's Y is the light's -Y: the image upside down in it
            light.texture = load_texture(asset, path, 'clamp', 'clamp', bool(np.linalg.det(to_world[:3, :3]) < 0))
    if light is not None:
        light.gains = gains
        light.shaping = _shaping(prim, path, light.type, time, warn)
        _ies(light, prim, time, warn)
    course = prim.GetAttribute('rtc:intensity')
    if light is not None and course and course.Get(time) is not None:
        light.course_intensity = _rgb(course.Get(time))
    return light


def _asset_input(prim: Usd.Prim, name: str, path: str, time: Usd.TimeCode, warn: Warn) -> Optional[Sdf.AssetPath]:
    """The asset path of the light's input `name` (`inputs:texture:file`, `inputs:shaping:ies:file`), None where none
    is authored (or an empty one); an attribute authored with another type (a string, a number) is warned and read
    as none, as Hydra reads it (its light adapters take the value only if it holds an asset path)."""
    attr = prim.GetAttribute(name)
    value = attr.Get(time) if attr else None
    if value is None:
        return None
    if not isinstance(value, Sdf.AssetPath):
        stack = attr.GetPropertyStack(time)                  # (its authored type: the schema's says asset)
        kind = str(stack[0].typeName) if stack else type(value).__name__
        warn(f'{path}.{name}: authored as {kind}, not an asset path; the light without it')
        return None
    return value if value.path else None


def _physical_light(prim, kind, path, frame, scale, to_world, base, normalize, time, warn) -> Optional[Light]:
    """The UsdLux radiometry of a distant, sphere, rect or disk light (see the module docstring)."""
    if kind == 'DistantLight':
        angle = float(UsdLux.DistantLight(prim).GetAngleAttr().Get(time))
        theta = min(max(math.radians(angle) / 2, 0.0), math.pi)
        if normalize or theta == 0:
            size = 1.0
        elif theta <= math.pi / 2:
            size = math.pi * math.sin(theta) ** 2
        else:
            size = (2 - math.sin(theta) ** 2) * math.pi
        return Light(path=path, type=DISTANT, matrix=frame, radiance=_rgb(base * size), angle=angle)
    if kind == 'SphereLight':
        light = UsdLux.SphereLight(prim)
        r = float(light.GetRadiusAttr().Get(time)) * float(np.prod(scale)) ** (1 / 3)
        if np.ptp(scale) > 1e-3 * scale.max():
            warn(f'{path}: non-uniform scale on a SphereLight; using the mean radius {r:g}')
        if light.GetTreatAsPointAttr().Get(time) or r <= 0:
            intensity = base / 4 if (normalize or r <= 0) else base * math.pi * r * r
            return Light(path=path, type=POINT, matrix=frame, radiance=_rgb(intensity))
        area = 4 * math.pi * r * r
        return Light(path=path, type=SPHERE, matrix=frame, radius=r,
                     radiance=_rgb(base / area if normalize else base))
    cross = float(np.linalg.norm(np.cross(to_world[:3, 0], to_world[:3, 1])))   # area scale in XY
    if kind == 'RectLight':
        light = UsdLux.RectLight(prim)
        w, h = float(light.GetWidthAttr().Get(time)), float(light.GetHeightAttr().Get(time))
        area = w * h * cross
        if area <= 0:
            warn(f'{path}: RectLight with zero area; light ignored')
            return None
        return Light(path=path, type=RECT, matrix=frame, width=w * scale[0], height=h * scale[1],
                     radiance=_rgb(base / area if normalize else base))
    if kind == 'DiskLight':
        r = float(UsdLux.DiskLight(prim).GetRadiusAttr().Get(time))
        area = math.pi * r * r * cross
        if area <= 0:
            warn(f'{path}: DiskLight with zero area; light ignored')
            return None
        return Light(path=path, type=DISK, matrix=frame, radius=r * math.sqrt(cross),
                     radiance=_rgb(base / area if normalize else base))
    if kind == 'CylinderLight':
        return _cylinder_light(prim, path, frame, scale, base, normalize, time, warn)
    warn(f'{path}: {kind} is not supported; light ignored')
    return None


def _shaping(prim: Usd.Prim, path: str, kind: int, time: Usd.TimeCode, warn: Warn) -> Optional[tuple]:
    """(cone angle in degrees, softness, focus, focus tint) of a light with UsdLux.ShapingAPI (`Light.shaping`;
    applied by `kernel/lights.shaped`), None where it shapes nothing: no ShapingAPI, a cone of 180 degrees or more
    without focus, or a DistantLight (whose emission has one direction: warned).  Values past their range are
    clamped (angle 0-180, softness 0-1, focus >= 0); one that is not finite leaves the light unshaped, warned.  An
    IES profile is read apart (`_ies`)."""
    api = UsdLux.ShapingAPI(prim)
    if not prim.HasAPI(UsdLux.ShapingAPI) and not any(
            a.HasAuthoredValue() for a in (api.GetShapingConeAngleAttr(), api.GetShapingFocusAttr())):
        return None

    def get(attr, default):
        value = attr.Get(time) if attr else None
        return default if value is None else value

    cone, softness = get(api.GetShapingConeAngleAttr(), 90.0), get(api.GetShapingConeSoftnessAttr(), 0.0)
    focus, tint = get(api.GetShapingFocusAttr(), 0.0), get(api.GetShapingFocusTintAttr(), (0.0, 0.0, 0.0))
    values = np.array([cone, softness, focus, *tint], np.float64)
    if not np.all(np.isfinite(values)):
        warn(f'{path}: a ShapingAPI input that is not finite ({values.tolist()}); the light emits unshaped')
        return None
    cone, softness = min(max(float(cone), 0.0), 180.0), min(max(float(softness), 0.0), 1.0)
    focus = max(float(focus), 0.0)
    if cone >= 180.0 and focus == 0.0:
        return None
    if kind == DISTANT:
        warn(f'{path}: ShapingAPI on a DistantLight (one direction) is not applied')
        return None
    return cone, softness, focus, tuple(float(c) for c in tint)


def _ies(light: Light, prim: Usd.Prim, time: Usd.TimeCode, warn: Warn) -> None:
    """Light.ies, ies_angle_scale and ies_gain from `inputs:shaping:ies:file`, `angleScale` and `normalize` (the
    gain: 1 / the profile's mean intensity when normalised, else 1: the profile's candela multiply the emission, as
    in hdEmbree).  A file that cannot be found or read leaves the light without a profile, warned with the reason
    (`usd/ies.py`); so does a DistantLight's (one direction).  An angleScale that is not finite or at most -1 (a
    mapping of no angle) is warned and not applied."""
    api = UsdLux.ShapingAPI(prim)
    asset = _asset_input(prim, 'inputs:shaping:ies:file', light.path, time, warn)
    if asset is None:
        return
    where = f'{light.path}.inputs:shaping:ies:file'
    if light.type == DISTANT:
        warn(f'{where}: an IES profile on a DistantLight (one direction) is not applied')
        return
    if not asset.resolvedPath:
        warn(f'{where}: "{asset.path}" not found; the light emits without its profile')
        return
    try:
        light.ies = read_ies(asset.resolvedPath)
    except IesError as e:
        warn(f'{where}: {e}; the light emits without its profile')
        return
    scale_attr, norm_attr = api.GetShapingIesAngleScaleAttr(), api.GetShapingIesNormalizeAttr()
    scale = scale_attr.Get(time) if scale_attr else None
    if scale is not None and not (math.isfinite(scale) and scale > -1.0):
        warn(f'{light.path}.inputs:shaping:ies:angleScale: {scale:g} maps no angle (finite and > -1 do); not applied')
        scale = None
    light.ies_angle_scale = float(scale or 0.0)
    if norm_attr and norm_attr.Get(time):
        if light.ies.mean > 0.0:
            light.ies_gain = 1.0 / light.ies.mean
        else:
            warn(f'{where}: the profile emits nothing; normalize leaves it so')


def _cylinder_light(prim, path, frame, scale, base, normalize, time, warn) -> Optional[Light]:
    """A CylinderLight: along local X, `length` x scale X long, `radius` x sqrt(scale Y x scale Z)."""
    light = UsdLux.CylinderLight(prim)
    length = float(light.GetLengthAttr().Get(time)) * float(scale[0])
    r = float(light.GetRadiusAttr().Get(time)) * math.sqrt(float(scale[1] * scale[2]))
    if abs(scale[1] - scale[2]) > 1e-3 * max(scale[1], scale[2]):
        warn(f'{path}: different Y and Z scales on a CylinderLight; using the mean radius {r:g}')
    area = 2 * math.pi * r * length
    if not area > 0:
        warn(f'{path}: CylinderLight with zero area; light ignored')
        return None
    return Light(path=path, type=CYLINDER, matrix=frame, radius=r, length=length,
                 radiance=_rgb(base / area if normalize else base))


# the inputs a light's reading uses (`inputs:colorTemperature` too when enabled): a value that is not finite in any of
# them drops the light; one in an input it does not read (a shaping cone angle) is left alone, as renderers that do not
# read it would
READ_INPUTS = ('intensity', 'exposure', 'color', 'width', 'height', 'radius', 'length', 'angle', 'diffuse', 'specular')


def _lobe_gains(api: UsdLux.LightAPI, path: str, time: Usd.TimeCode, warn: Warn) -> tuple:
    """(inputs:diffuse, inputs:specular): the multipliers of the light's effect on the diffuse and on the
    specular response of the surfaces it lights (UsdLux; 1 where unauthored; an input authored with a type
    that is not a number is warned and read as 1)."""
    gains = []
    for attr in (api.GetDiffuseAttr(), api.GetSpecularAttr()):
        value = attr.Get(time) if attr else None
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
            stack = attr.GetPropertyStack(time)              # (its authored type: the schema's says float)
            kind = str(stack[0].typeName) if stack else type(value).__name__
            warn(f'{path}.{attr.GetName()}: authored as {kind}, not a number; read as 1')
            value = None
        gains.append(1.0 if value is None else float(value))
    return tuple(gains)


def _nonfinite_input(prim: Usd.Prim, time: Usd.TimeCode) -> Optional[tuple[str, str]]:
    """(name, value) of the first input in `READ_INPUTS` of a light whose number is not finite."""
    names = READ_INPUTS + (('colorTemperature',) if prim.GetAttribute('inputs:enableColorTemperature').Get(time)
                           else ())
    for name in names:
        attr = prim.GetAttribute('inputs:' + name)
        value = attr.Get(time) if attr else None
        if value is None or isinstance(value, str):
            continue
        numbers = np.asarray(value)                       # (a number, a Gf vector; other types: not 'f')
        if numbers.dtype.kind == 'f' and not np.all(np.isfinite(numbers)):
            return attr.GetName(), str(value)
    return None


def _base(api: UsdLux.LightAPI, time: Usd.TimeCode) -> np.ndarray:
    """color * intensity * 2**exposure (times the blackbody colour when enableColorTemperature)."""
    colour = np.array(api.GetColorAttr().Get(time), np.float64)
    exposure = float(api.GetExposureAttr().Get(time))
    gain = 2.0 ** exposure if exposure < 1024.0 else math.inf       # (past float64: inf, refused as non-finite)
    base = colour * float(api.GetIntensityAttr().Get(time)) * gain
    if api.GetEnableColorTemperatureAttr().Get(time):
        base = base * np.array(UsdLux.BlackbodyTemperatureAsRgb(api.GetColorTemperatureAttr().Get(time)))
    return base


SYNC_MODES = ('materialGlowTintsLight', 'independent', 'noMaterialResponse')


def mesh_light_radiance(prim: Usd.Prim, time: Usd.TimeCode, warn: Warn) -> Optional[tuple]:
    """(radiance, materialSyncMode, lobe gains) of a Mesh with UsdLux MeshLightAPI (or of a GeomSubset of one),
    None for any other prim: L as for the other lights, divided by the mesh's world-space area (at this
    prim's placement) when ``normalize`` is on, how the bound material combines with it
    (`light:materialSyncMode`, MeshLightAPI's fallback ``materialGlowTintsLight``; an unknown token is
    warned and read as the fallback), and its inputs:diffuse and inputs:specular (`_lobe_gains`).  The renderer
    gives the mesh a material emitting it (`MaterialTable.emitting`): emissive surfaces are lights of the path
    integrator (`host/surface_lights.py`)."""
    if prim.IsA(UsdGeom.Subset):
        prim = prim.GetParent()
    if not prim or not prim.HasAPI(UsdLux.MeshLightAPI):
        return None
    api = UsdLux.LightAPI(prim)
    base = _base(api, time)
    if api.GetNormalizeAttr().Get(time):
        area = _mesh_area(prim, time)
        if not area > 0:
            warn(f'{prim.GetPath()}: MeshLightAPI on a mesh of zero area; no emission')
            return None
        base = base / area
    gains = _lobe_gains(api, str(prim.GetPath()), time, warn)
    if not (np.all(np.isfinite(base)) and np.all(np.isfinite(gains))):
        warn(f'{prim.GetPath()}: non-finite MeshLightAPI parameters; no emission')
        return None
    mode = str(api.GetMaterialSyncModeAttr().Get(time) or SYNC_MODES[0])
    if mode not in SYNC_MODES:
        warn(f'{prim.GetPath()}: light:materialSyncMode "{mode}" is none of {", ".join(SYNC_MODES)}; '
             f'read as {SYNC_MODES[0]}')
        mode = SYNC_MODES[0]
    return _rgb(base), mode, gains


def _mesh_area(prim: Usd.Prim, time: Usd.TimeCode) -> float:
    """World-space area of a Mesh prim's faces (fans of its polygons)."""
    mesh = UsdGeom.Mesh(prim)
    pts = np.array(mesh.GetPointsAttr().Get(time) or [], np.float64).reshape(-1, 3)
    counts = np.array(mesh.GetFaceVertexCountsAttr().Get(time) or [], np.int64)
    idx = np.array(mesh.GetFaceVertexIndicesAttr().Get(time) or [], np.int64)
    if not len(pts) or not len(counts) or counts.sum() != len(idx) or idx.min() < 0 or idx.max() >= len(pts):
        return 0.0
    m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)).T
    world = pts @ m[:3, :3].T + m[:3, 3]
    start = np.cumsum(counts) - counts
    fans = [(idx[s], idx[s + j], idx[s + j + 1]) for s, c in zip(start, counts) for j in range(1, c - 1)]
    if not fans:
        return 0.0
    a, b, c = (world[np.array(f)] for f in zip(*fans))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def _rgb(v) -> tuple:
    return tuple(float(x) for x in v)


def default_lights(camera_matrix: np.ndarray) -> list[Light]:
    """What a stage without lights is lit by: a DistantLight 'headlight' shining along the
    camera's view direction (irradiance 3, so an 18% grey surface facing the camera shows
    ~0.17) plus a dim constant DomeLight (radiance 0.1) so that shadowed sides are not black."""
    frame, _ = rigid_frame(camera_matrix)
    frame[:3, 3] = 0.0
    return [Light(path='<default headlight>', type=DISTANT, matrix=frame, radiance=(3.0, 3.0, 3.0)),
            Light(path='<default dome>', type=DOME, matrix=np.eye(4), radiance=(0.1, 0.1, 0.1))]
