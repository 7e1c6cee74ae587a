"""DomeLight images in the mirroredBall, angular and cubeMapVerticalCross layouts (`usd/dome_formats.py`):
resampled into the lat-long image the renderer reads.  The images here are made by the layouts' forward maps
(image point -> direction, written out independently of the module's inverse maps) from one environment, so
every layout must give back the lat-long image of that environment."""
from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer.options import RenderOptions
from rtc.renderer.usd import dome_formats
from rtc.renderer.usd.stage import read_stage


def sky(d: np.ndarray) -> np.ndarray:
    """A smooth environment with no symmetry (a mirror or a turn of it would not match)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([1.0 + 0.5 * x + 0.3 * y - 0.2 * z + 0.25 * x * z,
                     1.0 - 0.4 * x + 0.2 * z * y + 0.1 * z,
                     0.5 + 0.3 * z + 0.1 * x * y - 0.2 * y], -1)


def _points(h: int, w: int):
    """Image points (a to the right, b up, in [-1, 1]) of the texel centres of an h x w image."""
    a, b = np.meshgrid((np.arange(w) + 0.5) / w * 2.0 - 1.0, 1.0 - (np.arange(h) + 0.5) / h * 2.0)
    return a, b


def ball_image(n: int, env=sky) -> np.ndarray:
    """A mirror ball photographed from +Z down -Z: the normal (a, b, sqrt(1 - a^2 - b^2)) reflects -Z into D."""
    a, b = _points(n, n)
    r2 = a * a + b * b
    nz = np.sqrt(np.clip(1.0 - r2, 0.0, 1.0))
    d = np.stack([2.0 * nz * a, 2.0 * nz * b, 2.0 * nz * nz - 1.0], -1)
    return np.where((r2 <= 1.0)[..., None], env(d), 0.0).astype(np.float32)


def angular_image(n: int, env=sky) -> np.ndarray:
    """Debevec's angular map: the angle from +Z is pi times the distance from the centre."""
    a, b = _points(n, n)
    rho = np.hypot(a, b)
    theta = np.pi * np.minimum(rho, 1.0)
    s = np.where(rho > 0.0, np.sin(theta) / np.maximum(rho, 1e-300), 0.0)
    d = np.stack([s * a, s * b, np.cos(theta)], -1)
    return np.where((rho <= 1.0)[..., None], env(d), 0.0).astype(np.float32)


# (column, row), the face's axis, the axes along its image's right and down (seen from inside the cube)
CROSS = {(1, 1): ((0, 0, 1), (-1, 0, 0), (0, -1, 0)), (0, 1): ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
         (2, 1): ((-1, 0, 0), (0, 0, -1), (0, -1, 0)), (1, 0): ((0, 1, 0), (-1, 0, 0), (0, 0, 1)),
         (1, 2): ((0, -1, 0), (-1, 0, 0), (0, 0, -1)), (1, 3): ((0, 0, -1), (-1, 0, 0), (0, 1, 0))}


def cross_image(f: int, env=sky) -> np.ndarray:
    img = np.zeros((4 * f, 3 * f, 3), np.float32)
    s, b = _points(f, f)
    for (col, row), (axis, right, down) in CROSS.items():
        d = np.array(axis, float) + s[..., None] * np.array(right, float) - b[..., None] * np.array(down, float)
        img[row * f:(row + 1) * f, col * f:(col + 1) * f] = env(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return img


def exr_cube_image(f: int, env=sky) -> np.ndarray:
    """OpenEXR's cube map (`Imf::CubeMap`): faces +X, -X, +Y, -Y, +Z, -Z stacked, face position (p, q) at integers
    0..f-1 facing (1, u, v), (-1, u, v), (u, 1, v), (u, -1, v), (u, v, 1), (u, v, -1) with u, v = 2 p / (f - 1) - 1,
    2 q / (f - 1) - 1, and placed at image column, row as `CubeMap::pixelPosition` places it."""
    img = np.zeros((6 * f, f, 3), np.float32)
    p, q = np.meshgrid(np.arange(f), np.arange(f))
    u, v = p / (f - 1) * 2.0 - 1.0, q / (f - 1) * 2.0 - 1.0
    one = np.ones_like(u)
    for face, (d, col, row) in enumerate((((one, u, v), q, f - 1 - p), ((-one, u, v), f - 1 - q, f - 1 - p),
                                          ((u, one, v), p, f - 1 - q), ((u, -one, v), p, q),
                                          ((u, v, one), f - 1 - p, f - 1 - q), ((u, v, -one), p, f - 1 - q))):
        d = np.stack(d, -1)
        img[face * f + row, col] = env(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return img


def latlong_image(h: int, w: int, env=sky) -> np.ndarray:
    """The OpenEXR lat-long image: latitude pi/2 at the top, longitude 0 (+Z) in the middle, pi/2 (+X) left of it."""
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    lon = (0.5 - (np.arange(w) + 0.5) / w) * 2.0 * np.pi
    lat, lon = np.meshgrid(lat, lon, indexing='ij')
    d = np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)], -1)
    return env(d).astype(np.float32)


IMAGES = {'mirroredBall': lambda: ball_image(512), 'angular': lambda: angular_image(512),
          'cubeMapVerticalCross': lambda: cross_image(128), dome_formats.EXR_CUBE: lambda: exr_cube_image(128)}


@pytest.mark.parametrize('fmt,tol', [('mirroredBall', 3e-4), ('angular', 1e-4), ('cubeMapVerticalCross', 2e-3),
                                     (dome_formats.EXR_CUBE, 1e-4)])
def test_each_layout_resamples_to_the_latlong_image_of_its_environment(fmt, tol):
    """Away from the directions a layout squeezes into its rim (within 30 degrees of -Z for the ball and the
    angular map), every lat-long texel is the environment at its direction to bilinear accuracy; next to -Z, the
    ball keeps its rim's values."""
    out = dome_formats.to_latlong(IMAGES[fmt](), fmt)
    h, w = out.shape[:2]
    expected = latlong_image(h, w)
    assert out.shape == expected.shape and out.dtype == np.float32
    err = np.abs(out - expected).max(-1)
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    lon = (0.5 - (np.arange(w) + 0.5) / w) * 2.0 * np.pi
    z = np.cos(lat)[:, None] * np.cos(lon)[None, :]
    away = z > -np.cos(np.radians(30.0)) if fmt in ('mirroredBall', 'angular') else np.ones_like(z, bool)
    assert err[away].max() < tol
    assert np.quantile(err, 0.99) < 2e-3
    assert err.max() < 0.1


@pytest.mark.parametrize('fmt,image', [('mirroredBall', lambda e: ball_image(257, e)),
                                       ('angular', lambda e: angular_image(257, e)),
                                       ('cubeMapVerticalCross', lambda e: cross_image(64, e)),
                                       (dome_formats.EXR_CUBE, lambda e: exr_cube_image(65, e))])
def test_a_spot_at_plus_x_lands_at_longitude_pi_over_2(fmt, image):
    """A bright spot around +X (where each layout puts it: the ball at a = sqrt(1/2), the angular map at a = 1/2,
    the cross in the middle of its left face) is brightest in the lat-long image at latitude 0, longitude
    pi / 2: a quarter of the way across, halfway down."""
    def spot(d):
        return np.repeat(np.exp(-60.0 * np.sum((d - (1.0, 0.0, 0.0)) ** 2, -1))[..., None], 3, -1)
    out = dome_formats.to_latlong(image(spot), fmt)[..., 0]
    h, w = out.shape
    y, x = np.unravel_index(np.argmax(out), out.shape)
    assert abs((x + 0.5) / w - 0.25) <= 1.5 / w and abs((y + 0.5) / h - 0.5) <= 1.5 / h
    assert out.max() > 0.95


def _exr(path, pixels, **attributes):
    import OpenImageIO as oiio
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.FLOAT)
    for name, value in attributes.items():
        spec.attribute(name, value)
    assert out.open(str(path), spec)
    assert out.write_image(np.ascontiguousarray(pixels, np.float32))
    out.close()


def _dome_stage(image_path, fmt):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, 'Y')
    UsdGeom.Xform.Define(stage, '/World')
    UsdGeom.Sphere.Define(stage, '/World/Ball').CreateRadiusAttr(0.5)
    dome = UsdLux.DomeLight.Define(stage, '/World/Sky')
    dome.CreateTextureFileAttr(Sdf.AssetPath(str(image_path)))
    if fmt is not None:
        dome.CreateTextureFormatAttr(fmt)
    cam = UsdGeom.Camera.Define(stage, '/World/Cam')
    cam.CreateFocalLengthAttr(8.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 2.5))
    return stage


def test_a_stage_renders_each_layout_as_the_latlong_image(tmp_path):
    """Through the stage reader and both integrators: a diffuse ball under the dome, and the dome itself around
    it, render from each layout's file as from the lat-long file of the same environment (the dome seen directly
    within 1 % in every pixel, the whole image's mean within 1 %)."""
    from rtc.renderer.host.render import Renderer
    files = {'latlong': latlong_image(256, 512), 'mirroredBall': ball_image(512), 'angular': angular_image(512),
             'cubeMapVerticalCross': cross_image(128)}
    images = {}
    for fmt, pixels in files.items():
        _exr(tmp_path / f'{fmt}.exr', pixels)
        desc = read_stage(_dome_stage(tmp_path / f'{fmt}.exr', fmt))
        assert not desc.warnings, desc.warnings
        [dome] = desc.lights
        assert desc.textures[dome.texture].pixels.shape[0] * 2 == desc.textures[dome.texture].pixels.shape[1]
        with Renderer(desc) as r:
            images[fmt] = {i: r.render(RenderOptions(width=40, height=30, spp=64, integrator=i, seed=3)).image
                           for i in ('path', 'cook')}
    ref = images.pop('latlong')
    ys, xs = np.mgrid[0:30, 0:40]
    background = np.hypot(xs - 19.5, ys - 14.5) > 13.0            # (the ball spans ~11 pixels of radius)
    for fmt, by in images.items():
        for integrator, img in by.items():
            r = ref[integrator]
            assert np.abs(img - r)[background].max() < 0.01 * r[background].max(), (fmt, integrator)
            assert img.mean() == pytest.approx(r.mean(), rel=0.01), (fmt, integrator)


def test_an_image_that_does_not_fit_its_layout_is_read_as_latlong_with_a_warning(tmp_path):
    """A vertical cross must be 3 faces wide and 4 tall: a 2:1 image called one is read as the lat-long image it
    looks like, warned with the prim, the attribute and the size; a format token UsdLux does not define is read
    as lat-long too (the layout of most dome images), warned."""
    _exr(tmp_path / 'wide.exr', latlong_image(32, 64))
    desc = read_stage(_dome_stage(tmp_path / 'wide.exr', 'cubeMapVerticalCross'))
    warned = [w for w in desc.warnings if 'texture:format' in w]
    assert len(warned) == 1 and '/World/Sky' in warned[0] and '64 x 32' in warned[0]
    [dome] = desc.lights
    np.testing.assert_array_equal(desc.textures[dome.texture].pixels, latlong_image(32, 64))
    stage = _dome_stage(tmp_path / 'wide.exr', None)
    stage.GetPrimAtPath('/World/Sky').GetAttribute('inputs:texture:format').Set('fisheye')
    desc = read_stage(stage)
    warned = [w for w in desc.warnings if 'texture:format' in w]
    assert len(warned) == 1 and '"fisheye"' in warned[0] and '/World/Sky' in warned[0]
    np.testing.assert_array_equal(desc.textures[desc.lights[0].texture].pixels, latlong_image(32, 64))


def test_an_automatic_dome_reads_an_openexr_cube_map_as_its_header_names_it(tmp_path):
    """`automatic` (the format where none is authored) reads an OpenEXR file whose header says it is a cube-face
    environment as OpenEXR's cube map; the same pixels in a file that does not say so are read as lat-long, as
    they are; a file that says so but is not 6 faces tall is read as lat-long, warned."""
    cube = exr_cube_image(64)
    _exr(tmp_path / 'cube.exr', cube, textureformat='CubeFace Environment')
    _exr(tmp_path / 'plain.exr', cube)
    _exr(tmp_path / 'short.exr', cube[:320], textureformat='CubeFace Environment')
    desc = read_stage(_dome_stage(tmp_path / 'cube.exr', None))
    assert not desc.warnings, desc.warnings
    got = desc.textures[desc.lights[0].texture].pixels
    assert got.shape == (128, 256, 3)
    assert np.abs(got - latlong_image(128, 256)).max() < 5e-3
    desc = read_stage(_dome_stage(tmp_path / 'plain.exr', None))
    assert not desc.warnings, desc.warnings
    np.testing.assert_array_equal(desc.textures[desc.lights[0].texture].pixels, cube)
    desc = read_stage(_dome_stage(tmp_path / 'short.exr', None))
    warned = [w for w in desc.warnings if 'texture:format' in w]
    assert len(warned) == 1 and 'cube map' in warned[0] and '/World/Sky' in warned[0] and '64 x 320' in warned[0]
    np.testing.assert_array_equal(desc.textures[desc.lights[0].texture].pixels, cube[:320])
