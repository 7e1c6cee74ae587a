"""Time per sample of the path integrator against the number of lights (issue 13, "many lights").

    python benchmarks/bench_many_lights.py [--lights 1000] [--spp 8] [--time-spp 32] [--repeats 3] [--threads N] [--glossy]

A USD stage: a floor lit by one dominant 3 x 3 rect light and a 10 x 10 grid of instanced lamps (native
instancing: each prototype holds a small box and, in the many-light scenes, a 0.2 x 0.2 RectLight, so 100
of the lights are inside instances), plus free point and 0.3 x 0.3 rect lights up to the requested count,
half each.  Scenes: *one light* (the dominant light, the lamps' boxes without their lights: the same
geometry, the baseline the issue asks for); *one light, no lamps* (the floor alone: the earlier
baseline); the minor lights *dominant* (their intensities times `--minor`, 0.02: they add ~1 % to the
image, the issue's "noise of the dominant light"), measured both as the whole image's noise and as the noise of
the dominant light's own share (*dominant: its own light*: the same light tree and choices, the minor
lights' radiance zeroed in the kernel's light table after the tree was built); and *bright* (intensities times 1: the 900 lights near
the floor outshine the main light, a different, harder image).  Whole renders alternate (median of
`--repeats` rounds, each render `--time-spp` samples), path integrator, D = 3, 320 x 240.  Reported: time per
sample per pixel of each and its ratio to the one-light scene (issue target <= 2): the median of the rounds'
ratios and their range, in wall time and in process CPU time, the relative RMSE of each at `--spp` against its own
`--ref-spp` reference and its ratio to the one-light scene's (target <= 1 for the dominant scene), and
how much the minor lights add to the image mean.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np


def stage(n_lights: int, minor: float = 1.0, lamps: bool = True, glossy: bool = False):
    """The stage with n_lights lights: the dominant rect light, and the minor lights' intensities times
    `minor`; `lamps`: the grid of 100 instanced lamps (their boxes, and their lights if n_lights > 100);
    `glossy`: the scene of another character - the dominant light a sphere (radius 0.6) off-centre, the
    floor and boxes a rough metal (roughness 0.2)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    mat = UsdShade.Material.Define(st, '/Looks/Grey')
    sh = UsdShade.Shader.Define(st, '/Looks/Grey/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*((0.8, 0.7, 0.5) if glossy else (0.6,) * 3)))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(0.2 if glossy else 0.4)
    if glossy:
        sh.CreateInput('metallic', Sdf.ValueTypeNames.Float).Set(1.0)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    floor = UsdGeom.Mesh.Define(st, '/World/Floor')
    floor.CreatePointsAttr([(-20, 0, -20), (20, 0, -20), (20, 0, 20), (-20, 0, 20)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    floor.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(floor.GetPrim()).Bind(mat)
    if glossy:                                                    # the dominant light
        main = UsdLux.SphereLight.Define(st, '/World/Main')
        main.CreateRadiusAttr(0.6)
        main.CreateIntensityAttr(60.0)
        UsdGeom.Xformable(main).AddTranslateOp().Set(Gf.Vec3d(-3, 5, -2))
    else:
        main = UsdLux.RectLight.Define(st, '/World/Main')
        main.CreateWidthAttr(3.0)
        main.CreateHeightAttr(3.0)
        main.CreateIntensityAttr(20.0)
        UsdGeom.Xformable(main).AddTranslateOp().Set(Gf.Vec3d(0, 6, 0))
        UsdGeom.Xformable(main).AddRotateXOp().Set(-90.0)
    rest = n_lights - 1
    n_inst = 100 if lamps and rest >= 100 else 0           # lights inside the lamps
    if lamps:
        UsdGeom.Xform.Define(st, '/Lamp')
        box = UsdGeom.Cube.Define(st, '/Lamp/Box')
        box.CreateSizeAttr(0.2)
        UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(mat)
        if n_inst:
            lamp = UsdLux.RectLight.Define(st, '/Lamp/Light')
            lamp.CreateWidthAttr(0.2)
            lamp.CreateHeightAttr(0.2)
            lamp.CreateIntensityAttr(2.0 * minor)
            UsdGeom.Xformable(lamp).AddTranslateOp().Set(Gf.Vec3d(0, 0.5, 0))
            UsdGeom.Xformable(lamp).AddRotateXOp().Set(-90.0)
        for k in range(100):
            p = st.DefinePrim(f'/World/Lamps/L{k}')
            p.GetReferences().AddInternalReference('/Lamp')
            p.SetInstanceable(True)
            UsdGeom.Xformable(p).AddTranslateOp().Set(Gf.Vec3d(-9 + 2 * (k % 10), 0.1, -9 + 2 * (k // 10)))
    if rest > 0:
        rng = np.random.default_rng(1)
        for k in range(rest - n_inst):
            pos = Gf.Vec3d(*rng.uniform([-15, 1, -15], [15, 4, 15]))
            if k % 2:
                l = UsdLux.SphereLight.Define(st, f'/World/Free/P{k}')
                l.CreateTreatAsPointAttr(True)
            else:
                l = UsdLux.RectLight.Define(st, f'/World/Free/R{k}')
                l.CreateWidthAttr(0.3)
                l.CreateHeightAttr(0.3)
            l.CreateIntensityAttr(0.5 * minor)
            UsdGeom.Xformable(l).AddTranslateOp().Set(pos)
            if not k % 2:
                UsdGeom.Xformable(l).AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 8, 16))
    cam.AddRotateXOp().Set(-28.0)
    cam.CreateFocalLengthAttr(30.0)
    rs = UsdRender.Settings.Define(st, '/Render/Settings')
    rs.CreateResolutionAttr(Gf.Vec2i(320, 240))
    return st


def timed_rounds(renderers: dict, a, RenderOptions) -> dict:
    """{name: (wall seconds, process CPU seconds) of each round}: the renderers' renders of a.time_spp
    samples alternate within each round, so that a round's ratios compare renders made side by side
    (the host's drift between rounds cancels in them); the CPU time leaves out the time the host gives
    to other processes."""
    times = {n: ([], []) for n in renderers}
    for k in range(a.repeats):
        for n, r in renderers.items():
            c0, t0 = time.process_time(), time.perf_counter()
            r.render(RenderOptions(spp=a.time_spp, seed=1 + k, integrator='path', max_depth=3, threads=a.threads))
            times[n][0].append(time.perf_counter() - t0)
            times[n][1].append(time.process_time() - c0)
    return times


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--lights', type=int, default=1000)
    ap.add_argument('--spp', type=int, default=8, help='samples of the noise measurement')
    ap.add_argument('--time-spp', type=int, default=32, help='samples of each timed render')
    ap.add_argument('--threads', type=int, default=None, help='render threads of the timed renders (default: all cores)')
    ap.add_argument('--repeats', type=int, default=3)
    ap.add_argument('--minor', type=float, default=0.02,
                    help="the 'dominant' scene's minor lights: intensities times this")
    ap.add_argument('--ref-spp', type=int, default=256, help='samples of each scene\'s own reference')
    ap.add_argument('--glossy', action='store_true', help='a sphere as the dominant light over a rough metal floor')
    a = ap.parse_args(argv)
    from rtc.renderer.host.render import RenderOptions, Renderer
    from rtc.renderer.kernel.tables import LF_RAD
    from rtc.renderer.usd.stage import read_stage
    scenes = {'one light': (1, 1.0, True), 'one light, no lamps': (1, 1.0, False),
              f'{a.lights} lights, dominant': (a.lights, a.minor, True), f'{a.lights} lights, bright': (a.lights, 1.0, True)}
    rs = {}
    for name, (n, minor, lamps) in scenes.items():
        desc = read_stage(stage(n, minor, lamps, a.glossy), camera_path='/World/Camera')
        types = {}
        for l in desc.lights:
            types[l.type] = types.get(l.type, 0) + 1
        print(f'{name}: {len(desc.lights)} lights read (by type {types}), warnings {desc.warnings[:2]}')
        r = Renderer(desc)
        r.render(RenderOptions(spp=1, integrator='path', max_depth=3))
        rs[name] = r
    # the dominant light's own share of the dominant scene: the same renderer (the same light tree, so the
    # same choices and probabilities), with the minor lights' radiance set to zero in the kernel's light
    # table after the tree was built from it: its image is the estimate of the dominant light's light alone
    own = f'{a.lights} lights, dominant: its own light'
    r = Renderer(read_stage(stage(a.lights, a.minor, True, a.glossy), camera_path='/World/Camera'))
    r.render(RenderOptions(spp=1, integrator='path', max_depth=3))
    li_f = r.built.data.li_f
    top = li_f[:, LF_RAD:LF_RAD + 3].max(axis=1)
    li_f[top < top.max(), LF_RAD:LF_RAD + 3] = 0.0
    rs[own] = r
    one = 'one light'
    times = timed_rounds({n: r for n, r in rs.items() if n != own}, a, RenderOptions)
    for n, (wall, cpu) in times.items():
        rw, rc = ([x / y for x, y in zip(t, times[one][j])] for j, t in enumerate((wall, cpu)))
        print(f'  {n:>24}: {statistics.median(wall) / a.time_spp * 1e3:6.1f} ms per sample per pixel (median of '
              f'{a.repeats}), {statistics.median(rw):.2f}x the one-light scene (rounds {min(rw):.2f}-{max(rw):.2f}); '
              f'CPU time {statistics.median(rc):.2f}x ({min(rc):.2f}-{max(rc):.2f}) (target <= 2)')
    # noise: each scene against a reference of itself (another seed), relative RMSE at a.spp over seeds
    err, mean = {}, {}
    for n, r in rs.items():
        ref = r.render(RenderOptions(spp=a.ref_spp, seed=1000, integrator='path', max_depth=3)).image.astype(np.float64)
        e = [np.sqrt(np.mean((r.render(RenderOptions(spp=a.spp, seed=1 + k, integrator='path', max_depth=3)).image
                              - ref) ** 2)) / ref.mean() for k in range(a.repeats)]
        err[n], mean[n] = float(np.sqrt(np.mean(np.square(e)))), float(ref.mean())
    for n in rs:
        print(f'  {n:>24}: relative RMSE at {a.spp} spp {err[n]:.4f} (reference {a.ref_spp} spp), '
              f'{err[n] / err[one]:.2f}x the one-light scene; the minor lights add '
              f'{100 * (mean[n] / mean[one] - 1):.0f} % to the image mean')
    for r in rs.values():
        r.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
