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

import contextlib
import copy
import statistics
import tempfile
from pathlib import Path

import numpy as np

from bench_rect_images import _aimed, _material, alternate, arguments, finish, floor, gold_ball


def stage(folder: Path, name: str) -> Path:
    from pxr import Gf, Usd, UsdGeom, UsdLux, UsdShade
    path = folder / f'{name}.usda'
    st = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    fill = name == 'fill'
    floor_mat = _material(st, '/Looks/Floor', (0.5, 0.45, 0.4), 0.25 if fill else 0.8)
    floor(st, floor_mat)
    box = UsdGeom.Cube.Define(st, '/World/Box')
    box.CreateSizeAttr(1.0)
    box.AddTranslateOp().Set(Gf.Vec3d(-1.2, 0.5, 0.0))
    UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(_material(st, '/Looks/Matte', (0.6, 0.6, 0.6), 0.9))
    if fill:
        gold_ball(st, 0.8)
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
    finish(st)
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


def report(name: str, e: dict, t: dict, secs: dict, refs: dict) -> str:
    """One stage's line: time a sample of each variant and the median of the rounds' ratios, relRMSE, image means."""
    ratios = [sg / so for sg, so in zip(secs['gains'], secs['ones'])]
    return (f'{name}: time a sample gains {1e3 * t["gains"]:.1f} ms, ones {1e3 * t["ones"]:.1f} ms '
            f'({statistics.median(ratios):.3f}x, rounds {min(ratios):.3f}-{max(ratios):.3f}); '
            f'relRMSE gains {e["gains"]:.4f}, ones {e["ones"]:.4f}; '
            f'image mean gains / ones {refs["gains"].mean() / refs["ones"].mean():.3f}')


def main() -> None:
    a = arguments(__doc__)
    from rtc.renderer.options import RenderOptions
    with tempfile.TemporaryDirectory() as tmp:
        for name in ('fill', 'lamps'):
            with contextlib.ExitStack() as stack:
                rs = {n: stack.enter_context(r) for n, r in renderers(stage(Path(tmp), name), a.threads).items()}
                refs = {n: r.render(RenderOptions(spp=a.ref_spp, seed=1000, integrator='path')).image.astype(
                    np.float64) for n, r in rs.items()}
                print(report(name, *alternate(rs, refs, a.spp, a.rounds), refs), flush=True)


if __name__ == '__main__':
    main()
