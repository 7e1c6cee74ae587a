"""Time-to-error: rtc against Mitsuba 3 on the same scenes (soft shadows, depth of field).

Optional peer benchmark, never part of the test suite.  Setup (once per machine):

    .venv/bin/pip install -e '.[bench]'               # mitsuba 3.9.1
    apt-get install -y libllvm19                       # Dr.Jit's llvm_ad_rgb backend (Debian 12's LLVM 15 aborts)
    python benchmarks/bench_mitsuba.py --width 320 --height 240 --ref-spp 1024

Both renderers get the same scene, built here from one Python description: a ground plane and a 5 x 5
grid of instances of one 20 000-triangle torus mesh (Mitsuba: shapegroup + instances; rtc: a USD
PointInstancer), diffuse materials, one rectangular area light, a pinhole camera ("soft shadows") or
a thin-lens camera focused on the middle row ("depth of field").  Light transport matches: direct
light only, one light sample per hit (Mitsuba's `direct` integrator with emitter_samples=1,
bsdf_samples=0, default diffuse BSDF; rtc's Cook integrator on a rough, non-specular
UsdPreviewSurface), box pixel filter.

Each renderer is measured against **its own** converged reference (`--ref-spp`), so differences of
radiometric convention do not matter; error = RMSE / mean(reference) (relative RMSE).  For spp in
1, 4, 16, 64, 256 (squares: Mitsuba's multijitter needs them) both render alternately (`--repeats`
rounds, median wall time, fresh seeds), then the time to reach each target error is interpolated on
the log-log error-vs-time curve.  Samplers: rtc Owen-scrambled Sobol', Mitsuba multijitter (its best
in /work/shared/peers-and-sampling.md).  Mitsuba times include forcing the result to numpy
(`dr.eval` returns before the work is done).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np


TORUS_TRIS = 20_000
GRID = 5
SPACING = 3.0
LIGHT_POS = (0.0, 6.0, 1.0)
LIGHT_SIZE = 3.0
LIGHT_L = 4.0
CAM_POS = (0.0, 6.0, 12.0)
CAM_TARGET = (0.0, 0.0, 0.0)
FOV_Y = 40.0
LENS_RADIUS = 0.25


def torus(tris: int):
    """(points float32 (n, 3), triangles int32 (m, 3)): radii 1 and 0.35, resting on y = 0."""
    nu = max(3, int(round(np.sqrt(tris / 2 * 2.5))))
    nv = max(3, int(round(tris / 2 / nu)))
    uu, vv = np.meshgrid(2 * np.pi * np.arange(nu) / nu, 2 * np.pi * np.arange(nv) / nv, indexing='ij')
    rr = 1.0 + 0.35 * np.cos(vv)
    pts = np.stack([rr * np.cos(uu), 0.35 + 0.35 * np.sin(vv), rr * np.sin(uu)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing='ij')
    a, b = i * nv + j, ((i + 1) % nu) * nv + j
    c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
    q = np.stack([a, d, c, b], -1).reshape(-1, 4)
    tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], 1).reshape(-1, 3)
    return pts.astype(np.float32), tri.astype(np.int32)


def placements():
    """4x4 matrices (row-major, column vectors) of the GRID x GRID tori, each turned differently."""
    out = []
    for k in range(GRID * GRID):
        x = (k % GRID - (GRID - 1) / 2) * SPACING
        z = (k // GRID - (GRID - 1) / 2) * SPACING
        yaw = 0.4 * k
        c, s = np.cos(yaw), np.sin(yaw)
        out.append(np.array([[c, 0, s, x], [0, 1, 0, 0], [-s, 0, c, z], [0, 0, 0, 1]]))
    return out


def look_at(eye, target, up=(0, 1, 0)):
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = r, u, -f, eye       # camera looks down its -Z
    return m


# ----------------------------------------------------------------------------- rtc
def rtc_stage(width: int, height: int, dof: bool):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    mat = UsdShade.Material.Define(stage, '/Looks/Grey')
    sh = UsdShade.Shader.Define(stage, '/Looks/Grey/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.6, 0.6, 0.6))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput('specularColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    sh.CreateInput('useSpecularWorkflow', Sdf.ValueTypeNames.Int).Set(1)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    ground = UsdGeom.Mesh.Define(stage, '/World/Ground')
    ground.CreatePointsAttr([(-20, 0, -20), (20, 0, -20), (20, 0, 20), (-20, 0, 20)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ground.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(mat)
    pi = UsdGeom.PointInstancer.Define(stage, '/World/Tori')
    pts, tri = torus(TORUS_TRIS)
    mesh = UsdGeom.Mesh.Define(stage, '/World/Tori/Proto/Torus')
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tri), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tri.ravel()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    pi.CreatePrototypesRel().SetTargets([mesh.GetPath()])
    ms = placements()
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(len(ms), np.int32)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(np.array([m[:3, 3] for m in ms], np.float32)))
    yaw = 0.4 * np.arange(len(ms))
    q = np.zeros((len(ms), 4), np.float32)
    q[:, 0], q[:, 2] = np.cos(yaw / 2), np.sin(yaw / 2)
    pi.CreateOrientationsfAttr(Vt.QuatfArray.FromNumpy(q))
    light = UsdLux.RectLight.Define(stage, '/World/Light')
    light.CreateWidthAttr(LIGHT_SIZE)
    light.CreateHeightAttr(LIGHT_SIZE)
    light.CreateIntensityAttr(LIGHT_L)
    xf = UsdGeom.Xformable(light)
    xf.AddTranslateOp().Set(Gf.Vec3d(*LIGHT_POS))
    xf.AddRotateXOp().Set(-90.0)                                 # emit along -Y
    cam = UsdGeom.Camera.Define(stage, '/World/Camera')
    cam.AddTransformOp().Set(Gf.Matrix4d(look_at(CAM_POS, CAM_TARGET).T.tolist()))
    v_ap = 2 * np.tan(np.radians(FOV_Y) / 2) * 5.0               # focal length 5 (tenths: 50)
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateVerticalApertureAttr(v_ap * 10)
    cam.CreateHorizontalApertureAttr(v_ap * 10 * width / height)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 1000))
    if dof:
        focus = float(np.linalg.norm(np.subtract(CAM_POS, CAM_TARGET)))
        cam.CreateFocusDistanceAttr(focus)
        cam.CreateFStopAttr(5.0 / (2 * LENS_RADIUS))             # radius = focal / (2 fStop)
    stage.SetDefaultPrim(stage.GetPrimAtPath('/World'))
    return stage


class Rtc:
    name = 'rtc'

    def __init__(self, width, height, dof):
        from rtc.renderer.host.render import RenderOptions, Renderer
        from rtc.renderer.usd.stage import read_stage
        self.opts = dict(width=width, height=height, sampler='sobol', filter='box', max_depth=0, integrator='cook')
        self.RenderOptions = RenderOptions
        self.r = Renderer(read_stage(rtc_stage(width, height, dof), camera_path='/World/Camera'))

    def render(self, spp, seed):
        t0 = time.perf_counter()
        img = self.r.render(self.RenderOptions(spp=spp, seed=seed, **self.opts)).image
        return np.asarray(img, np.float64), time.perf_counter() - t0


# ----------------------------------------------------------------------------- Mitsuba
class Mitsuba:
    name = 'mitsuba'

    def __init__(self, width, height, dof):
        import mitsuba as mi
        mi.set_variant('llvm_ad_rgb')
        self.mi = mi
        T = mi.ScalarTransform4f
        pts, tri = torus(TORUS_TRIS)
        mesh = mi.Mesh('torus', len(pts), len(tri), has_vertex_normals=False, has_vertex_texcoords=False)
        p = mi.traverse(mesh)
        p['vertex_positions'] = type(p['vertex_positions'])(pts.ravel())
        p['faces'] = type(p['faces'])(tri.astype(np.uint32).ravel())
        p.update()
        grey = {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': [0.6, 0.6, 0.6]}}
        self.width, self.height, self.dof = width, height, dof
        scene = {'type': 'scene',
                 'integrator': {'type': 'direct', 'emitter_samples': 1, 'bsdf_samples': 0},
                 'ground': {'type': 'rectangle', 'to_world': T().rotate([1, 0, 0], -90).scale(20), 'bsdf': grey},
                 'sg': {'type': 'shapegroup', 'torus': mesh},
                 'light': {'type': 'rectangle',
                           'to_world': T().translate(list(LIGHT_POS)).rotate([1, 0, 0], 90).scale(LIGHT_SIZE / 2),
                           'emitter': {'type': 'area', 'radiance': {'type': 'rgb', 'value': [LIGHT_L] * 3}}}}
        for k, m in enumerate(placements()):
            scene[f'i{k}'] = {'type': 'instance', 'shapegroup': {'type': 'ref', 'id': 'sg'},
                              'to_world': T(m.tolist())}
        self.scene_dict = scene
        self.scenes = {}

    def _scene(self, spp):
        mi = self.mi
        if spp not in self.scenes:
            sensor = {'type': 'thinlens' if self.dof else 'perspective', 'fov': FOV_Y, 'fov_axis': 'y',
                      'to_world': mi.ScalarTransform4f().look_at(origin=list(CAM_POS), target=list(CAM_TARGET),
                                                                 up=[0, 1, 0]),
                      'sampler': {'type': 'multijitter', 'sample_count': spp},
                      'film': {'type': 'hdrfilm', 'width': self.width, 'height': self.height,
                               'rfilter': {'type': 'box'}, 'pixel_format': 'rgb'}}
            if self.dof:
                sensor.update(aperture_radius=LENS_RADIUS,
                              focus_distance=float(np.linalg.norm(np.subtract(CAM_POS, CAM_TARGET))))
            else:
                sensor.update(near_clip=0.01, far_clip=1000.0)
            self.scenes[spp] = mi.load_dict({**self.scene_dict, 'sensor': sensor})
        return self.scenes[spp]

    def render(self, spp, seed):
        scene = self._scene(spp)
        t0 = time.perf_counter()
        img = np.array(self.mi.render(scene, spp=spp, seed=seed), np.float64)
        return img[..., :3], time.perf_counter() - t0


# ----------------------------------------------------------------------------- driver
def rel_rmse(img, ref):
    return float(np.sqrt(np.mean((img - ref) ** 2)) / max(ref.mean(), 1e-12))


def reference(r, spp, chunk=64):
    acc, n, seed = None, 0, 1000
    while n < spp:
        img, _ = r.render(chunk, seed)
        acc = img if acc is None else acc + img
        n += chunk
        seed += 1
    return acc / (n // chunk)


def time_to_error(errors, times, target):
    """Interpolate (log-log) the wall time at which the error falls to `target`; None if never."""
    e, t = np.log(errors), np.log(times)
    for k in range(1, len(e)):
        if e[k] <= np.log(target) <= e[k - 1]:
            a = (np.log(target) - e[k - 1]) / (e[k] - e[k - 1])
            return float(np.exp(t[k - 1] + a * (t[k] - t[k - 1])))
    return None


def run(case, a):
    dof = case == 'dof'
    rs = [Rtc(a.width, a.height, dof), Mitsuba(a.width, a.height, dof)]
    refs = {r.name: reference(r, a.ref_spp) for r in rs}
    print(f'\n== {case}: {a.width}x{a.height}, references {a.ref_spp} spp '
          f'(mean rtc {refs["rtc"].mean():.4f}, mitsuba {refs["mitsuba"].mean():.4f})')
    curves = {}
    for r in rs:
        curves[r.name] = ([], [])
    for spp in a.spps:
        row = {}
        for r in rs:
            errs, times = [], []
            r.render(spp, 0)                               # untimed: kernels for this spp are ready
            for k in range(a.repeats):
                img, dt = r.render(spp, 1 + k)
                errs.append(rel_rmse(img, refs[r.name]))
                times.append(dt)
            curves[r.name][0].append(float(np.sqrt(np.mean(np.square(errs)))))
            curves[r.name][1].append(statistics.median(times))
            row[r.name] = (curves[r.name][0][-1], curves[r.name][1][-1])
        print(f'  spp {spp:4d}: rtc relRMSE {row["rtc"][0]:.4f} in {row["rtc"][1]:.3f} s   '
              f'mitsuba relRMSE {row["mitsuba"][0]:.4f} in {row["mitsuba"][1]:.3f} s', flush=True)
    for target in a.targets:
        tt = {n: time_to_error(*curves[n], target) for n in curves}
        fmt = {n: (f'{v:.3f} s' if v else 'not reached') for n, v in tt.items()}
        ratio = f'  mitsuba/rtc = {tt["mitsuba"] / tt["rtc"]:.2f}' if all(tt.values()) else ''
        print(f'  time to relRMSE {target:.3f}: rtc {fmt["rtc"]}, mitsuba {fmt["mitsuba"]}{ratio}')
    return curves


from bench_mitsuba_path import PathMitsuba, PathRtc, compare_converged  # noqa: E402  (path cases)


def run_path(case, a):
    """Both renderers' path tracers on `case` ('cornell' or 'glossy'): converged agreement (cornell) or
    time to equal relative RMSE and error slopes (glossy)."""
    rs = [PathRtc(case, a.width, a.height), PathMitsuba(case, a.width, a.height)]
    if case == 'cornell':
        return compare_converged(rs, a.ref_spp)
    return run_curves(case, a, rs)


def run_curves(case, a, rs):
    refs = {r.name: reference(r, a.ref_spp) for r in rs}
    print(f'\n== {case}: {a.width}x{a.height}, references {a.ref_spp} spp '
          f'(mean rtc {refs["rtc"].mean():.4f}, mitsuba {refs["mitsuba"].mean():.4f})')
    curves = {r.name: ([], []) for r in rs}
    for spp in a.spps:
        row = {}
        for r in rs:
            errs, times = [], []
            r.render(spp, 0)
            for k in range(a.repeats):
                img, dt = r.render(spp, 1 + k)
                errs.append(rel_rmse(img, refs[r.name]))
                times.append(dt)
            curves[r.name][0].append(float(np.sqrt(np.mean(np.square(errs)))))
            curves[r.name][1].append(statistics.median(times))
            row[r.name] = (curves[r.name][0][-1], curves[r.name][1][-1])
        print(f'  spp {spp:4d}: rtc relRMSE {row["rtc"][0]:.4f} in {row["rtc"][1]:.3f} s '
              f'({row["rtc"][1] / spp * 1e3:.1f} ms/spp)   mitsuba relRMSE {row["mitsuba"][0]:.4f} in '
              f'{row["mitsuba"][1]:.3f} s ({row["mitsuba"][1] / spp * 1e3:.1f} ms/spp)', flush=True)
    for n, (e, t) in curves.items():
        k = np.polyfit(np.log(a.spps), np.log(e), 1)[0]
        print(f'  {n}: error slope over spp {a.spps[0]}-{a.spps[-1]}: {k:.3f}')
    e_m = curves['mitsuba'][0]
    for target in e_m:
        tt = {n: time_to_error(*curves[n], target) for n in curves}
        if all(tt.values()):
            print(f'  time to relRMSE {target:.4f}: rtc {tt["rtc"]:.3f} s, mitsuba {tt["mitsuba"]:.3f} s, '
                  f'rtc/mitsuba = {tt["rtc"] / tt["mitsuba"]:.2f}')
    return curves


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--ref-spp', type=int, default=1024)
    ap.add_argument('--spps', type=int, nargs='+', default=[1, 4, 16, 64, 256])
    ap.add_argument('--targets', type=float, nargs='+', default=[0.10, 0.05, 0.02])
    ap.add_argument('--repeats', type=int, default=3)
    ap.add_argument('--cases', nargs='+', default=['soft_shadows', 'dof'],
                    help='soft_shadows, dof (cook vs direct); cornell, glossy (path vs path)')
    a = ap.parse_args(argv)
    for case in a.cases:
        (run_path if case in ('cornell', 'glossy') else run)(case, a)
    return 0


if __name__ == '__main__':
    sys.exit(main())
