"""UsdRender.Settings and UsdGeom.Camera -> `RenderSettings` / `Camera`.

USD lens and filmback values are in tenths of a scene unit (`Gf.Camera.FOCAL_LENGTH_UNIT`); the
description stores scene units.  The lens radius is ``focal_length / (2 fStop)`` (fStop 0 =
pinhole).  Many DCCs write millimetre lens values whatever the stage's metersPerUnit (Maya and
Omniverse scenes in metres with focalLength 50 mean 50 mm, not 5 m), which makes depth of field
absurdly strong: `read_camera` compares the lens radius with the scene size and either
reinterprets the lens values as millimetres or disables depth of field, with a warning.

The filmback is conformed to the image aspect ratio following the render settings'
`aspectRatioConformPolicy` (default `expandAperture`), as UsdRender prescribes.
"""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdRender

from ..description import Camera, RenderSettings
from ..errors import SceneError

Warn = Callable[[str], None]
ABSURD_LENS = 0.25        # lens radius above this fraction of the scene diagonal is not a real lens


def render_settings_prim(stage: Usd.Stage, candidates: list[Usd.Prim]) -> Optional[Usd.Prim]:
    """The prim named by the stage's `renderSettingsPrimPath`, else the first RenderSettings
    prim the root walk met."""
    path = stage.GetMetadata('renderSettingsPrimPath') if stage.HasAuthoredMetadata('renderSettingsPrimPath') else ''
    prim = stage.GetPrimAtPath(path) if path else None
    if prim and prim.IsA(UsdRender.Settings):
        return prim
    return candidates[0] if candidates else None


def read_render_settings(prim: Optional[Usd.Prim], time: Usd.TimeCode) -> tuple[RenderSettings, tuple, str]:
    """(settings, background colour, aspect-ratio conform policy) from a RenderSettings prim
    (defaults when None): resolution, camera, custom ``rtc:samplesPerPixel``, ``rtc:imageEncoding``,
    ``rtc:backgroundColor`` and ``rtc:integrator``, disableMotionBlur, disableDepthOfField."""
    settings, background, policy = RenderSettings(), (0.0, 0.0, 0.0), UsdRender.Tokens.expandAperture
    settings.integrator = 'path'            # USD renders with path unless the stage says otherwise
    if prim is None:
        return settings, background, policy
    rs = UsdRender.Settings(prim)
    settings.path = str(prim.GetPath())
    resolution = rs.GetResolutionAttr().Get(time)
    if resolution is not None and resolution[0] > 0 and resolution[1] > 0:    # too large: options.resolve
        settings.width, settings.height = int(resolution[0]), int(resolution[1])
    targets = rs.GetCameraRel().GetForwardedTargets()
    if targets:
        settings.camera_path = str(targets[0])
    spp = prim.GetAttribute('rtc:samplesPerPixel')
    if spp and spp.Get(time) is not None:
        settings.samples_per_pixel = int(spp.Get(time))
    encoding = prim.GetAttribute('rtc:imageEncoding')
    if encoding and encoding.Get(time) in ('srgb', 'linear'):
        settings.encoding = str(encoding.Get(time))
    integrator = prim.GetAttribute('rtc:integrator')
    if integrator and integrator.Get(time) is not None:
        settings.integrator = str(integrator.Get(time))
    bg = prim.GetAttribute('rtc:backgroundColor')
    if bg and bg.Get(time) is not None:
        background = tuple(float(x) for x in bg.Get(time))
    settings.disable_motion_blur = bool(rs.GetDisableMotionBlurAttr().Get(time))
    settings.disable_depth_of_field = bool(rs.GetDisableDepthOfFieldAttr().Get(time))
    policy = rs.GetAspectRatioConformPolicyAttr().Get(time) or policy
    return settings, background, policy


def shutter(camera: Optional[Usd.Prim], time: Usd.TimeCode) -> tuple[float, float]:
    if camera is None:
        return 0.0, 0.0
    cam = UsdGeom.Camera(camera)
    return float(cam.GetShutterOpenAttr().Get(time)), float(cam.GetShutterCloseAttr().Get(time))


def conform(h: float, v: float, aspect: float, policy: str) -> tuple[float, float]:
    """Apertures adjusted so that h / v equals the image aspect ratio."""
    if policy == UsdRender.Tokens.adjustApertureWidth:
        return v * aspect, v
    if policy == UsdRender.Tokens.adjustApertureHeight:
        return h, h / aspect
    if policy == UsdRender.Tokens.cropAperture:
        return (v * aspect, v) if h / v > aspect else (h, h / aspect)
    if policy == UsdRender.Tokens.adjustPixelAspectRatio:
        return h, v
    return (v * aspect, v) if h / v < aspect else (h, h / aspect)      # expandAperture


def read_camera(prim: Usd.Prim, matrix: np.ndarray, motion: Optional[np.ndarray], time: Usd.TimeCode,
                settings: RenderSettings, fit: tuple[float, str], scene_diagonal: float, meters_per_unit: float,
                warn: Warn) -> Camera:
    """A Camera from a UsdGeom.Camera; `matrix` is its camera-to-world transform (already in
    the description's Y-up world), `motion` its samples over the shutter or None; `fit` is
    (image aspect ratio, aspectRatioConformPolicy)."""
    path = str(prim.GetPath())
    cam = UsdGeom.Camera(prim)
    g = cam.GetCamera(time)
    unit = Gf.Camera.FOCAL_LENGTH_UNIT                                   # 0.1
    for name, aperture in (('horizontalAperture', g.horizontalAperture), ('verticalAperture', g.verticalAperture)):
        if not aperture > 0:                                             # (NaN too) no frustum to conform
            raise SceneError(f'{path}.{name}: the camera aperture must be positive, not {aperture:g}')
    h, v = conform(g.horizontalAperture, g.verticalAperture, *fit)
    near, far = g.clippingRange.min, g.clippingRange.max
    out = Camera(path=path, matrix=_without_scale(matrix),
                 projection='orthographic' if g.projection == Gf.Camera.Orthographic else 'perspective',
                 focal_length=g.focalLength * unit, horizontal_aperture=h * unit, vertical_aperture=v * unit,
                 horizontal_aperture_offset=g.horizontalApertureOffset * unit,
                 vertical_aperture_offset=g.verticalApertureOffset * unit,
                 focus_distance=float(g.focusDistance) if g.focusDistance > 0 else 1.0,
                 clip_near=max(float(near), 1e-6), clip_far=float(far) if far > near else float('inf'),
                 motion=None if motion is None else np.stack([_without_scale(m) for m in motion]))
    out.shutter_open, out.shutter_close = shutter(prim, time)
    if g.fStop > 0 and not settings.disable_depth_of_field and out.projection == 'perspective':
        out.lens_radius = _sane_lens_radius(path, g.focalLength, g.fStop, g.focusDistance, scene_diagonal,
                                            meters_per_unit, warn)
    _check_finite(out, g)
    return out


def _check_finite(cam: Camera, g: Gf.Camera) -> None:
    """A camera with a NaN/Inf transform or lens value would make every ray NaN (a black image, every
    sample dropped): refuse it at load time, naming the prim and the attribute."""
    authored = [('focalLength', g.focalLength), ('horizontalAperture', g.horizontalAperture),
                ('verticalAperture', g.verticalAperture), ('horizontalApertureOffset', g.horizontalApertureOffset),
                ('verticalApertureOffset', g.verticalApertureOffset), ('focusDistance', cam.focus_distance),
                ('clippingRange', cam.clip_near)]                    # (the last two as read: NaN or <= 0 defaults)
    for name, value in authored:
        if not math.isfinite(value):
            raise SceneError(f'{cam.path}.{name}: {value:g} is not a finite number; the camera cannot be used')
    moving = [] if cam.motion is None else [cam.motion]
    if not all(np.all(np.isfinite(np.asarray(m, np.float64))) for m in [cam.matrix, *moving]):
        raise SceneError(f'{cam.path}: the camera\'s transform (its xformOps or an ancestor\'s) is not finite')
    derived = [cam.horizontal_aperture, cam.vertical_aperture, cam.lens_radius]
    if not all(math.isfinite(v) for v in derived):           # finite inputs whose conform or lens overflowed
        raise SceneError(f'{cam.path}: the camera\'s apertures or lens overflow (horizontalAperture '
                         f'{g.horizontalAperture:g}, verticalAperture {g.verticalAperture:g}, fStop {g.fStop:g})')
    if cam.projection == 'perspective' and not cam.focal_length > 0:
        raise SceneError(f'{cam.path}.focalLength: the camera focal length must be positive, not {g.focalLength:g}')


def _sane_lens_radius(path, focal_tenths, fstop, focus, diagonal, mpu, warn) -> float:
    radius = focal_tenths * Gf.Camera.FOCAL_LENGTH_UNIT / (2 * fstop)
    if focus <= 0:
        warn(f'{path}: fStop {fstop:g} with focusDistance {focus:g}; depth of field disabled')
        return 0.0
    if not diagonal or radius <= ABSURD_LENS * diagonal:
        return radius
    as_mm = focal_tenths * 0.001 / mpu / (2 * fstop)          # the lens values were millimetres
    if as_mm <= ABSURD_LENS * diagonal:
        warn(f'{path}: lens radius {radius:g} is absurd for a scene of size {diagonal:g}; reading '
             f'focalLength as millimetres (lens radius {as_mm:g})')
        return as_mm
    warn(f'{path}: lens radius {radius:g} is absurd for a scene of size {diagonal:g}; depth of field disabled')
    return 0.0


def _without_scale(m: np.ndarray) -> np.ndarray:
    """Camera frames are used as rigid frames: normalise the axes (keep their directions)."""
    out = np.array(m, np.float64)
    out[:3, :3] /= np.linalg.norm(out[:3, :3], axis=0)
    return out


def default_camera(lo: np.ndarray, hi: np.ndarray, fit: tuple[float, str]) -> Camera:
    """A perspective camera (USD's default 50 mm lens on a 35 mm filmback) looking at the
    centre of the box [lo, hi] from the front, slightly above and to the right, far enough
    that the box's bounding sphere fills the narrower field of view."""
    base = Camera(path='<default camera>', matrix=np.eye(4))
    h, v = conform(base.horizontal_aperture, base.vertical_aperture, *fit)
    base.horizontal_aperture, base.vertical_aperture = h, v
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi >= lo)):
        lo, hi = -np.ones(3), np.ones(3)
    centre, radius = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
    half_fov = math.atan(min(h, v) / (2 * base.focal_length))
    distance = 1.1 * radius / math.sin(half_fov)
    back = np.array([0.35, 0.3, 1.0]) / np.linalg.norm([0.35, 0.3, 1.0])     # camera +Z (it looks down -Z)
    right = np.cross([0.0, 1.0, 0.0], back)
    right /= np.linalg.norm(right)
    base.matrix[:3, 0], base.matrix[:3, 1], base.matrix[:3, 2] = right, np.cross(back, right), back
    base.matrix[:3, 3] = centre + distance * back
    base.focus_distance = distance
    base.clip_near, base.clip_far = max(distance - 2 * radius, distance * 1e-4), distance + 2 * radius
    return base
