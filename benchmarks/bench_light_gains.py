"""What a light's `inputs:diffuse` / `inputs:specular` cost the path integrator: each stage rendered as authored (some
lights with gains other than 1: the kernels weigh the BSDF's diffuse and specular parts apart, and every BSDF
sample computes the diffuse share of its value) and with every gain set to 1 (the kernels without that code), in
one process, renders alternating (`--rounds`).

    python benchmarks/bench_light_gains.py [--spp 16] [--ref-spp 1024] [--rounds 3] [--threads 2]

Stages (USD, written to a temporary folder and read by the stage reader):
* *fill* (glossy, few lights): a plastic floor (roughness 0.25), a gold sphere and a matte box; a key RectLight as
  authored, a large fill RectLight with `inputs:specular = 0` (it adds no highlight), a dome with
  `inputs:diffuse = 0.5` and `inputs:specular = 2`.
* *lamps* (diffuse, many lights): a matte floor and 48 small SphereLights in three rows, the rows' gains (1, 1),
  (1, 0.2) and (0.3, 1.5).
Reported per stage and variant: time a sample (median of the rounds) and its ratio, and the relative RMSE at `--spp`
against a `--ref-spp` reference of the same variant (another seed): the gains change the image, not its noise.
"""
from __future__ import annotations

import argparse
import copy
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_rect_images import _aimed, _material


def stage(folder: Path, name: str) -> Path:
    from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade
    path = folder / f'{name}.usda'
    st = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    fill = name == 'fill'
    floor_mat = _material(st, '/Looks/Floor', (0.5, 0.45, 0.4), 0.25 if fill else 0.8)
    floor = UsdGeom.Mesh.Define(st, '/World/Floor')
    floor.CreatePointsAttr([(-8, 0, -8), (8, 0, -8), (8, 0, 8), (-8, 0, 8)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    UsdShade.MaterialBindingAPI.Apply(floor.GetPrim()).Bind(floor_mat)
    box = UsdGeom.Cube.Define(st, '/World/Box')
    box.CreateSizeAttr(1.0)
    box.AddTranslateOp().Set(Gf.Vec3d(-1.2, 0.5, 0.0))
    UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(_material(st, '/Looks/Matte', (0.6, 0.6, 0.6), 0.9))
    if fill:
        ball = UsdGeom.Sphere.Define(st, '/World/Ball')
        ball.CreateRadiusAttr(0.8)
        ball.AddTranslateOp().Set(Gf.Vec3d(0.8, 0.8, 0.3))
        UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(
            _material(st, '/Looks/Gold', (1.0, 0.78, 0.34), 0.3, 1.0))
        key = UsdLux.RectLight.Define(st, '/World/Key')
        key.CreateWidthAttr(1.5)
        key.CreateHeightAttr(1.0)
        key.CreateIntensityAttr(25.0)
        key.AddTransformOp().Set(_aimed((-2.5, 3.5, 2.0), (0.0, 0.5, 0.0)))
        fill_light = UsdLux.RectLight.Define(st, '/World/Fill')
        fill_light.CreateWidthAttr(4.0)
        fill_light.CreateHeightAttr(3.0)
        fill_light.CreateIntensityAttr(3.0)
        fill_light.CreateSpecularAttr(0.0)
        fill_light.AddTransformOp().Set(_aimed((4.0, 2.5, 3.0), (0.0, 0.5, 0.0)))
        dome = UsdLux.DomeLight.Define(st, '/World/Sky')
        dome.CreateIntensityAttr(0.1)
        dome.CreateDiffuseAttr(0.5)
        dome.CreateSpecularAttr(2.0)
    else:
        for k in range(48):
            row, col = divmod(k, 16)
            lamp = UsdLux.SphereLight.Define(st, f'/World/Lamps/L{k}')
            lamp.CreateRadiusAttr(0.08)
            lamp.CreateIntensityAttr(60.0)
            lamp.CreateDiffuseAttr((1.0, 1.0, 0.3)[row])
            lamp.CreateSpecularAttr((1.0, 0.2, 1.5)[row])
            lamp.AddTranslateOp().Set(Gf.Vec3d(-6.0 + 0.8 * col, 1.0 + 0.3 * row, -3.0 + 2.5 * row))
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 3.0, 7.0))
    cam.AddRotateXOp().Set(-20.0)
    cam.CreateFocalLengthAttr(28.0)
    UsdRender.Settings.Define(st, '/Render/Settings').CreateResolutionAttr(Gf.Vec2i(160, 120))
    st.Save()
    return path


def renderers(usd: Path, threads: int):
    """{'gains': the stage as authored, 'ones': every light's gains set to 1}."""
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.usd.stage import read_stage
    desc = read_stage(str(usd))
    assert any(tuple(light.gains) != (1.0, 1.0) for light in desc.lights)
    ones = copy.deepcopy(desc)
    for light in ones.lights:
        light.gains = (1.0, 1.0)
    return {'gains': Renderer(desc, threads=threads), 'ones': Renderer(ones, threads=threads)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--ref-spp', type=int, default=1024)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--threads', type=int, default=2)
    a = ap.parse_args()
    from rtc.renderer.options import RenderOptions
    with tempfile.TemporaryDirectory() as tmp:
        for name in ('fill', 'lamps'):
            rs = renderers(stage(Path(tmp), name), a.threads)
            refs, norms = {}, {}
            for n, r in rs.items():
                refs[n] = r.render(RenderOptions(spp=a.ref_spp, seed=1000, integrator='path')).image.astype(
                    np.float64)
                norms[n] = np.sqrt(np.mean(refs[n] ** 2))
            err = {n: [] for n in rs}
            secs = {n: [] for n in rs}
            for k in range(a.rounds):
                order = list(rs) if k % 2 == 0 else list(rs)[::-1]
                for n in order:
                    t0 = time.perf_counter()
                    img = rs[n].render(RenderOptions(spp=a.spp, seed=1 + k, integrator='path')).image
                    secs[n].append((time.perf_counter() - t0) / a.spp)
                    err[n].append(float(np.sqrt(np.mean((img - refs[n]) ** 2)) / norms[n]))
            e = {n: statistics.median(err[n]) for n in rs}
            t = {n: statistics.median(secs[n]) for n in rs}
            ratios = [sg / so for sg, so in zip(secs['gains'], secs['ones'])]
            print(f'{name}: time a sample gains {1e3 * t["gains"]:.1f} ms, ones {1e3 * t["ones"]:.1f} ms '
                  f'({statistics.median(ratios):.3f}x, rounds {min(ratios):.3f}-{max(ratios):.3f}); relRMSE gains '
                  f'{e["gains"]:.4f}, ones {e["ones"]:.4f}; image mean gains / ones '
                  f'{refs["gains"].mean() / refs["ones"].mean():.3f}', flush=True)
            for r in rs.values():
                r.close()


if __name__ == '__main__':
    main()
