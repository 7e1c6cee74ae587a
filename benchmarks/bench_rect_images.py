"""What drawing a textured rect light's points by its image buys: the path integrator as shipped (points of a rect
seen from farther than its diagonal drawn by the image's luminance, `kernel/rect_sampling.py`) against the same
renderer with the rects' image tables dropped (points uniform over the rect, the image a factor of the emission),
in one process, renders alternating (`--rounds`).

    python benchmarks/bench_rect_images.py [--spp 16] [--ref-spp 1024] [--rounds 3] [--threads 2]

Stages (USD, written to a temporary folder and read by the stage reader):
* *window* (diffuse): a floor and a box lit by a 2.4 x 1.6 RectLight whose image is a window (four panes behind a
  dark frame: a mild contrast), 4.7 m away, and a dim dome.
* *sign* (glossy): a plastic floor (roughness 0.25) and a rough gold sphere lit by a 3 x 1 RectLight whose image is
  an LED sign (three bright strokes on black: 23 % of the texels hold all the light).
* *panels* (many lights): a matte floor under an 8 x 8 grid of 0.6 x 0.2 RectLights 2.5 m up, each with the sign's
  image (one file, read once).
Reported per stage and variant: relative RMSE at `--spp` against a `--ref-spp` reference of the shipped renderer
(another seed), time a sample, and the efficiency 1 / (relMSE x time) of the image strategy over the uniform one.
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np



def _material(st, path, diffuse, roughness, metallic=0.0):
    from pxr import Gf, Sdf, UsdShade
    mat = UsdShade.Material.Define(st, path)
    sh = UsdShade.Shader.Define(st, path + '/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(roughness)
    sh.CreateInput('metallic', Sdf.ValueTypeNames.Float).Set(metallic)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _aimed(at, target):
    """A light's transform (USD's row-vector matrix) at `at` whose emission (its local -Z) points at `target`, its
    local +Y as near world +Y as that allows."""
    from pxr import Gf
    z = np.asarray(at, float) - np.asarray(target, float)
    z /= np.linalg.norm(z)                                   # (local +Z: away from the target)
    x = np.cross((0.0, 1.0, 0.0), z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return Gf.Matrix4d(*x, 0.0, *y, 0.0, *z, 0.0, *at, 1.0)


def window_image(path: Path) -> None:
    """A window of four panes (daylight, warm at the top, paler blue below) behind a dark frame, 96 x 64."""
    import OpenImageIO as oiio
    h, w = 64, 96
    y = (np.arange(h) + 0.5) / h
    img = np.repeat(np.stack([1.0 - 0.25 * y, 0.95 - 0.1 * y, 0.8 + 0.15 * y], -1)[:, None, :], w, 1)
    frame = np.zeros((h, w), bool)
    frame[:5], frame[-5:], frame[:, :5], frame[:, -5:] = True, True, True, True
    frame[h // 2 - 2:h // 2 + 2], frame[:, w // 2 - 2:w // 2 + 2] = True, True
    img[frame] = (0.05, 0.04, 0.03)
    buf = oiio.ImageBuf(oiio.ImageSpec(w, h, 3, 'float'))
    buf.set_pixels(oiio.ROI(0, w, 0, h), np.ascontiguousarray(img, np.float32))
    buf.write(str(path))


def sign_image(path: Path) -> None:
    """An LED sign: three bright strokes (a 'Z', roughly) on black, 96 x 32."""
    import OpenImageIO as oiio
    img = np.zeros((32, 96, 3), np.float32)
    img[4:8, 8:88] = (1.0, 0.6, 0.2)
    img[24:28, 8:88] = (1.0, 0.6, 0.2)
    for i in range(16):
        img[8 + i, 84 - 5 * i:88 - 5 * i] = (1.0, 0.6, 0.2)
    buf = oiio.ImageBuf(oiio.ImageSpec(96, 32, 3, 'float'))
    buf.set_pixels(oiio.ROI(0, 96, 0, 32), img)
    buf.write(str(path))


def stage(folder: Path, name: str) -> Path:
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
    path = folder / f'{name}.usda'
    st = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    glossy = name == 'sign'
    floor_mat = _material(st, '/Looks/Floor', (0.5, 0.5, 0.5), 0.25 if glossy else 0.8)         # (plastic or matte)
    floor(st, floor_mat)
    if glossy:
        gold_ball(st, 0.6)
        sign_image(folder / 'sign.exr')
        light = UsdLux.RectLight.Define(st, '/World/Sign')
        light.CreateWidthAttr(3.0)
        light.CreateHeightAttr(1.0)
        light.CreateIntensityAttr(30.0)
        light.CreateTextureFileAttr(Sdf.AssetPath('sign.exr'))
        light.AddTransformOp().Set(_aimed((-0.5, 3.0, -4.0), (0.0, 0.0, 0.0)))
    elif name == 'panels':
        sign_image(folder / 'sign.exr')
        for k in range(64):
            panel = UsdLux.RectLight.Define(st, f'/World/Panels/P{k}')
            panel.CreateWidthAttr(0.6)
            panel.CreateHeightAttr(0.2)
            panel.CreateIntensityAttr(4.0)
            panel.CreateTextureFileAttr(Sdf.AssetPath('sign.exr'))
            panel.AddTranslateOp().Set(Gf.Vec3d(-5.6 + 1.6 * (k % 8), 2.5, -5.6 + 1.6 * (k // 8)))
            panel.AddRotateXOp().Set(-90.0)                  # (facing down)
    else:
        box = UsdGeom.Cube.Define(st, '/World/Box')
        box.CreateSizeAttr(1.2)
        box.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.6, 0.0))
        UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(floor_mat)
        light = UsdLux.RectLight.Define(st, '/World/Window')
        light.CreateWidthAttr(2.4)
        light.CreateHeightAttr(1.6)
        light.CreateIntensityAttr(15.0)
        window_image(folder / 'window.exr')
        light.CreateTextureFileAttr(Sdf.AssetPath('window.exr'))
        light.AddTransformOp().Set(_aimed((-2.0, 3.0, -3.0), (0.0, 0.0, 0.0)))
        UsdLux.DomeLight.Define(st, '/World/Sky').CreateIntensityAttr(0.05)
    finish(st)
    return path


def gold_ball(st, x: float) -> None:
    """A rough gold sphere of radius 0.8 resting on the floor at (x, 0.3)."""
    from pxr import Gf, UsdGeom, UsdShade
    ball = UsdGeom.Sphere.Define(st, '/World/Ball')
    ball.CreateRadiusAttr(0.8)
    ball.AddTranslateOp().Set(Gf.Vec3d(x, 0.8, 0.3))
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(_material(st, '/Looks/Gold', (1.0, 0.78, 0.34), 0.3, 1.0))


def floor(st, material) -> None:
    """A 16 x 16 floor at y = 0 bound to `material`."""
    from pxr import UsdGeom, UsdShade
    mesh = UsdGeom.Mesh.Define(st, '/World/Floor')
    mesh.CreatePointsAttr([(-8, 0, -8), (8, 0, -8), (8, 0, 8), (-8, 0, 8)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def finish(st) -> None:
    """The benchmark stages' camera (3 up, 7 back, looking 20 degrees down) and render settings (160 x 120); saved."""
    from pxr import Gf, UsdGeom, UsdRender
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 3.0, 7.0))
    cam.AddRotateXOp().Set(-20.0)
    cam.CreateFocalLengthAttr(28.0)
    UsdRender.Settings.Define(st, '/Render/Settings').CreateResolutionAttr(Gf.Vec2i(160, 120))
    st.Save()


def uniform_renderer(desc, threads: int):
    """A Renderer of `desc` whose path integrator draws rect lights' points as if they had no image (the rects' image
    tables dropped: uniform by area far away, the image still a factor of the emission): the baseline of the image
    strategy.  Its light tables are built at its first path render, made here while `image_tables` is patched."""
    import rtc.renderer.host.light_selection as LS
    from rtc.renderer import description as D
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.options import RenderOptions
    real = LS.image_tables

    def uniform(d):
        image_i, cdf, means = real(d)
        for k, light in enumerate(d.lights):
            if light.type == D.RECT:
                image_i[k] = -1
        return image_i, cdf, means
    LS.image_tables = uniform
    try:
        r = Renderer(desc, threads=threads)
        r.render(RenderOptions(spp=1, width=8, height=8, integrator='path'))
    finally:
        LS.image_tables = real
    return r


def renderers(usd: Path, threads: int):
    """{'image': the renderer as shipped, 'uniform': `uniform_renderer`}."""
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.usd.stage import read_stage
    return {'image': Renderer(read_stage(str(usd)), threads=threads),
            'uniform': uniform_renderer(read_stage(str(usd)), threads)}


def arguments(doc: str):
    """The command line of the path benchmarks that alternate renderers in one process (--spp, --ref-spp, --rounds,
    --threads)."""
    ap = argparse.ArgumentParser(description=doc.split('\n')[0])
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--ref-spp', type=int, default=1024)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--threads', type=int, default=2)
    return ap.parse_args()


def alternate(rs: dict, refs: dict, spp: int, rounds: int):
    """Render each renderer of `rs` at `spp` (path, seeds 1, 2, ...) `rounds` times, alternating their order round by
    round: ({name: median relative RMSE against refs[name]}, {name: median seconds a sample}, {name: [seconds a
    sample, a round]})."""
    from rtc.renderer.options import RenderOptions
    norms = {n: np.sqrt(np.mean(refs[n] ** 2)) for n in rs}
    err = {n: [] for n in rs}
    secs = {n: [] for n in rs}
    for k in range(rounds):
        order = list(rs) if k % 2 == 0 else list(rs)[::-1]
        for n in order:
            t0 = time.perf_counter()
            img = rs[n].render(RenderOptions(spp=spp, seed=1 + k, integrator='path')).image
            secs[n].append((time.perf_counter() - t0) / spp)
            err[n].append(float(np.sqrt(np.mean((img - refs[n]) ** 2)) / norms[n]))
    return {n: statistics.median(err[n]) for n in rs}, {n: statistics.median(secs[n]) for n in rs}, secs


def main() -> None:
    a = arguments(__doc__)
    from rtc.renderer.options import RenderOptions
    with tempfile.TemporaryDirectory() as tmp:
        for name in ('window', 'sign', 'panels'):
            rs = renderers(stage(Path(tmp), name), a.threads)
            rs['image'].render(RenderOptions(spp=1, integrator='path'))
            ref = rs['image'].render(RenderOptions(spp=a.ref_spp, seed=1000, integrator='path')).image.astype(
                np.float64)
            e, t, _ = alternate(rs, {n: ref for n in rs}, a.spp, a.rounds)
            print(f'{name}: relRMSE image {e["image"]:.4f} uniform {e["uniform"]:.4f} '
                  f'({e["image"] / e["uniform"]:.3f}x);'
                  f' time a sample {1e3 * t["image"]:.1f} / {1e3 * t["uniform"]:.1f} ms '
                  f'({t["image"] / t["uniform"]:.3f}x); efficiency '
                  f'{(e["uniform"] ** 2 * t["uniform"]) / (e["image"] ** 2 * t["image"]):.2f}x', flush=True)
            for r in rs.values():
                r.close()


if __name__ == '__main__':
    main()
