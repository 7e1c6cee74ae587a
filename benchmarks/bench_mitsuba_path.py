"""The path-tracing cases of bench_mitsuba.py: one scene description, built for rtc (a USD stage,
rendered with `integrator='path'`) and for Mitsuba 3 (`path` integrator, max_depth = D + 1).

cornell  a diffuse Cornell box (walls albedo 0.7, red and green sides, two boxes, a small rect light
         just under the ceiling), D = 8 bounces.  Both sides pure Lambert (rtc: the course's Lambertian
         read by path, kd / pi; Mitsuba: `diffuse`), lights that emit from one side.  The converged
         images must agree: means within 2 %, each of 4 x 4 image blocks within 5 %.
glossy   UsdPreviewSurface spheres (GGX gold metallic roughness 0.3 = alpha 0.09, blue plastic
         roughness 0.25), a brushed-aluminium floor tile (roughness 0.45), 6 instanced tori (roughness
         0.5 metal, shapegroup / PointInstancer), a diffuse floor, a 2 x 2 rect light, D = 3.  Mitsuba:
         roughconductor (perfect-conductor Fresnel x the base colour) and roughplastic; each renderer is
         measured against its own reference, so these differences of BSDF do not enter the comparison.

Run alone, it writes rtc's stage of a case (for `rtc render` / `rtc converge` / `bench_render.py`):
`python benchmarks/bench_mitsuba_path.py glossy glossy.usda [640 480]`.
"""
from __future__ import annotations

import time

import numpy as np

CAM = {'cornell': ((0.0, 1.0, 3.4), (0.0, 1.0, 0.0), 40.0), 'glossy': ((0.0, 2.2, 6.0), (0.0, 0.5, 0.0), 40.0)}
DEPTH = {'cornell': 8, 'glossy': 3}


def _quad(c, u, v):
    """Points and triangles of the parallelogram c +- u +- v, facing u x v (Mitsuba's diffuse is one-sided)."""
    c, u, v = (np.asarray(x, float) for x in (c, u, v))
    pts = np.array([c - u - v, c + u - v, c + u + v, c - u + v])
    return pts, np.array([[0, 1, 2], [0, 2, 3]])


def _box(c, h, w, yaw):
    cy, sy = np.cos(yaw), np.sin(yaw)
    ex, ez = np.array([cy, 0, -sy]) * w, np.array([sy, 0, cy]) * w
    ey = np.array([0, h, 0])
    c = np.asarray(c, float) + ey
    faces = [(c + ey, ex, -ez), (c - ey, ex, ez), (c + ex, ey, ez), (c - ex, ey, -ez), (c + ez, ex, ey),
             (c - ez, -ex, ey)]
    pts, tris = [], []
    for f in faces:
        p, t = _quad(*f)
        tris.append(t + 4 * len(pts))
        pts.append(p)
    return np.concatenate(pts), np.concatenate(tris)


def scene_spec(case):
    """{'meshes': [(name, points, tris, material)], 'spheres': [(name, centre, radius, material)],
    'instances': (points, tris, material, [4x4]), 'materials': {name: dict}, 'light': (centre, size, L)}."""
    import bench_mitsuba as B
    if case == 'cornell':
        mats = {'white': {'kd': (0.7, 0.7, 0.7)}, 'red': {'kd': (0.7, 0.1, 0.1)}, 'green': {'kd': (0.1, 0.7, 0.1)}}
        walls = [('floor', (0, 0, 0), (1, 0, 0), (0, 0, -1), 'white'), ('ceiling', (0, 2, 0), (1, 0, 0), (0, 0, 1), 'white'),
                 ('back', (0, 1, -1), (1, 0, 0), (0, 1, 0), 'white'), ('left', (-1, 1, 0), (0, 1, 0), (0, 0, 1), 'red'),
                 ('right', (1, 1, 0), (0, 1, 0), (0, 0, -1), 'green')]
        meshes = [(n, *_quad(c, u, v), m) for n, c, u, v, m in walls]
        meshes.append(('short', *_box((0.35, 0, 0.3), 0.3, 0.28, 0.3), 'white'))
        meshes.append(('tall', *_box((-0.35, 0, -0.3), 0.6, 0.28, -0.3), 'white'))
        return {'meshes': meshes, 'spheres': [], 'instances': None, 'materials': mats,
                'light': ((0.0, 1.98, 0.0), 0.5, 15.0)}
    mats = {'floor': {'kd': (0.5, 0.5, 0.5), 'rough': 1.0}, 'gold': {'kd': (1.0, 0.77, 0.34), 'metal': 1.0, 'rough': 0.3},
            'plastic': {'kd': (0.1, 0.2, 0.7), 'rough': 0.25}, 'alu': {'kd': (0.91, 0.92, 0.92), 'metal': 1.0, 'rough': 0.45},
            'torus': {'kd': (0.95, 0.64, 0.54), 'metal': 1.0, 'rough': 0.5}}
    meshes = [('floor', *_quad((0, 0, 0), (8, 0, 0), (0, 0, -8)), 'floor'),
              ('tile', *_quad((0, 0.002, -1.5), (2.5, 0, 0), (0, 0, -1.0)), 'alu')]
    spheres = [('gold', (-1.1, 0.6, 0.0), 0.6, 'gold'), ('plastic', (1.1, 0.6, 0.0), 0.6, 'plastic')]
    pts, tri = B.torus(4000)
    pts = pts * 0.4
    mats_xf = []
    for k in range(6):
        a = 2 * np.pi * k / 6
        c, s = np.cos(a), np.sin(a)
        mats_xf.append(np.array([[c, 0, s, 2.6 * np.sin(a)], [0, 1, 0, 0], [-s, 0, c, 2.6 * np.cos(a) - 1.0], [0, 0, 0, 1]]))
    return {'meshes': meshes, 'spheres': spheres, 'instances': (pts, tri, 'torus', mats_xf), 'materials': mats,
            'light': ((0.0, 3.5, 1.0), 2.0, 6.0)}


# ----------------------------------------------------------------------------- rtc
def _rtc_material(stage, name, m, lambert):
    from pxr import Gf, Sdf, UsdShade
    mat = UsdShade.Material.Define(stage, f'/Looks/{name}')
    if lambert:
        mat.GetPrim().CreateAttribute('rtc:model', Sdf.ValueTypeNames.Token, custom=True).Set('lambertian')
        mat.GetPrim().CreateAttribute('rtc:diffuse', Sdf.ValueTypeNames.Color3d, custom=True).Set(Gf.Vec3d(*m['kd']))
        return mat
    sh = UsdShade.Shader.Define(stage, f'/Looks/{name}/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*m['kd']))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(m.get('rough', 0.5))
    sh.CreateInput('metallic', Sdf.ValueTypeNames.Float).Set(m.get('metal', 0.0))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def rtc_stage(case, width, height):
    from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt
    import bench_mitsuba as B
    spec = scene_spec(case)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    mats = {n: _rtc_material(stage, n, m, case == 'cornell') for n, m in spec['materials'].items()}

    def mesh(path, pts, tris, mat):
        g = UsdGeom.Mesh.Define(stage, path)
        g.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(pts, np.float32)))
        g.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tris), 3, np.int32)))
        g.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(tris, np.int32).ravel()))
        g.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        UsdShade.MaterialBindingAPI.Apply(g.GetPrim()).Bind(mats[mat])
        return g
    for name, pts, tris, mat in spec['meshes']:
        mesh(f'/World/{name}', pts, tris, mat)
    for name, c, r, mat in spec['spheres']:
        s = UsdGeom.Sphere.Define(stage, f'/World/{name}')
        s.CreateRadiusAttr(r)
        s.AddTranslateOp().Set(Gf.Vec3d(*c))
        UsdShade.MaterialBindingAPI.Apply(s.GetPrim()).Bind(mats[mat])
    if spec['instances'] is not None:
        pts, tri, mat, xfs = spec['instances']
        pi = UsdGeom.PointInstancer.Define(stage, '/World/Tori')
        proto = mesh('/World/Tori/Proto/Torus', pts, tri, mat)
        pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
        pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(len(xfs), np.int32)))
        pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(np.array([m[:3, 3] for m in xfs], np.float32)))
        yaw = np.arctan2(np.array([m[0, 2] for m in xfs]), np.array([m[0, 0] for m in xfs]))
        q = np.zeros((len(xfs), 4), np.float32)
        q[:, 3], q[:, 1] = np.cos(yaw / 2), np.sin(yaw / 2)         # GfQuatf memory: (i, j, k, real)
        pi.CreateOrientationsfAttr(Vt.QuatfArray.FromNumpy(q))
    c, size, L = spec['light']
    light = UsdLux.RectLight.Define(stage, '/World/Light')
    light.CreateWidthAttr(size)
    light.CreateHeightAttr(size)
    light.CreateIntensityAttr(L)
    xf = UsdGeom.Xformable(light)
    xf.AddTranslateOp().Set(Gf.Vec3d(*c))
    xf.AddRotateXOp().Set(-90.0)
    eye, target, fov = CAM[case]
    cam = UsdGeom.Camera.Define(stage, '/World/Camera')
    cam.AddTransformOp().Set(Gf.Matrix4d(B.look_at(eye, target).T.tolist()))
    v_ap = 2 * np.tan(np.radians(fov) / 2) * 5.0
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateVerticalApertureAttr(v_ap * 10)
    cam.CreateHorizontalApertureAttr(v_ap * 10 * width / height)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 1000))
    rs = UsdRender.Settings.Define(stage, '/Render/Settings')
    rs.CreateResolutionAttr(Gf.Vec2i(width, height))
    stage.SetDefaultPrim(stage.GetPrimAtPath('/World'))
    return stage


class PathRtc:
    name = 'rtc'

    def __init__(self, case, width, height):
        t0 = time.perf_counter()
        from rtc.renderer.host.render import RenderOptions, Renderer
        from rtc.renderer.usd.stage import read_stage
        self.opts = dict(width=width, height=height, sampler='sobol', filter='box', max_depth=DEPTH[case],
                         integrator='path')
        self.RenderOptions = RenderOptions
        self.r = Renderer(read_stage(rtc_stage(case, width, height), camera_path='/World/Camera'))
        self.r.render(RenderOptions(spp=1, **self.opts))             # kernels loaded
        self.startup = time.perf_counter() - t0

    def render(self, spp, seed):
        t0 = time.perf_counter()
        img = self.r.render(self.RenderOptions(spp=spp, seed=seed, **self.opts)).image
        return np.asarray(img, np.float64), time.perf_counter() - t0


# ----------------------------------------------------------------------------- Mitsuba
class PathMitsuba:
    name = 'mitsuba'

    def __init__(self, case, width, height):
        t0 = time.perf_counter()
        import mitsuba as mi
        mi.set_variant('llvm_ad_rgb')
        self.mi, self.case, self.width, self.height = mi, case, width, height
        spec = scene_spec(case)
        T = mi.ScalarTransform4f

        def bsdf(m):
            rgb = {'type': 'rgb', 'value': list(m['kd'])}
            if case == 'cornell' or m.get('rough', 0.5) >= 1.0:
                return {'type': 'diffuse', 'reflectance': rgb}
            a = m['rough'] ** 2
            if m.get('metal', 0.0) > 0:
                return {'type': 'roughconductor', 'material': 'none', 'alpha': a, 'specular_reflectance': rgb}
            return {'type': 'roughplastic', 'alpha': a, 'diffuse_reflectance': rgb, 'int_ior': 1.5}

        scene = {'type': 'scene', 'integrator': {'type': 'path', 'max_depth': DEPTH[case] + 1}}
        for name, pts, tris, m in spec['meshes']:
            scene[name] = self._mesh_with_bsdf(name, pts, tris, bsdf(spec['materials'][m]))
        for name, c, r, m in spec['spheres']:
            scene[name] = {'type': 'sphere', 'center': list(c), 'radius': r, 'bsdf': bsdf(spec['materials'][m])}
        if spec['instances'] is not None:
            pts, tri, m, xfs = spec['instances']
            scene['sg'] = {'type': 'shapegroup',
                           'torus': self._mesh_with_bsdf('torus', pts, tri, bsdf(spec['materials'][m]))}
            for k, x in enumerate(xfs):
                scene[f'i{k}'] = {'type': 'instance', 'shapegroup': {'type': 'ref', 'id': 'sg'},
                                  'to_world': T(x.tolist())}
        c, size, L = spec['light']
        scene['light'] = {'type': 'rectangle', 'to_world': T().translate(list(c)).rotate([1, 0, 0], 90).scale(size / 2),
                          'bsdf': {'type': 'diffuse', 'reflectance': {'type': 'rgb', 'value': [0, 0, 0]}},
                          'emitter': {'type': 'area', 'radiance': {'type': 'rgb', 'value': [L] * 3}}}
        self.scene_dict = scene
        self.scenes = {}
        self.render(1, 0)
        self.startup = time.perf_counter() - t0

    def _mesh_with_bsdf(self, name, pts, tris, bsdf):
        mi = self.mi
        props = mi.Properties()
        props['bsdf'] = mi.load_dict(bsdf)
        sh = mi.Mesh(name, len(pts), len(tris), has_vertex_normals=False, has_vertex_texcoords=False, props=props)
        p = mi.traverse(sh)
        p['vertex_positions'] = type(p['vertex_positions'])(np.asarray(pts, np.float32).ravel())
        p['faces'] = type(p['faces'])(np.asarray(tris, np.uint32).ravel())
        p.update()
        return sh

    def _scene(self, spp):
        mi = self.mi
        if spp not in self.scenes:
            eye, target, fov = CAM[self.case]
            sensor = {'type': 'perspective', 'fov': fov, 'fov_axis': 'y', 'near_clip': 0.01, 'far_clip': 1000.0,
                      'to_world': mi.ScalarTransform4f().look_at(origin=list(eye), target=list(target), up=[0, 1, 0]),
                      'sampler': {'type': 'multijitter', 'sample_count': spp},
                      'film': {'type': 'hdrfilm', 'width': self.width, 'height': self.height,
                               'rfilter': {'type': 'box'}, 'pixel_format': 'rgb'}}
            self.scenes[spp] = mi.load_dict({**self.scene_dict, 'sensor': sensor})
        return self.scenes[spp]

    def render(self, spp, seed):
        scene = self._scene(spp)
        t0 = time.perf_counter()
        img = np.array(self.mi.render(scene, spp=spp, seed=seed), np.float64)
        return img[..., :3], time.perf_counter() - t0


def compare_converged(rs, spp):
    """Cornell box: converged means within 2 %, every block of a 4 x 4 grid within 5 %."""
    import bench_mitsuba as B
    imgs = {r.name: B.reference(r, spp) for r in rs}
    a, b = imgs['rtc'], imgs['mitsuba']
    print(f'\n== cornell: {a.shape[1]}x{a.shape[0]}, {spp} spp each; start-up rtc {rs[0].startup:.2f} s, '
          f'mitsuba {rs[1].startup:.2f} s')
    print(f'  mean rtc {a.mean():.5f}  mitsuba {b.mean():.5f}  ratio {a.mean() / b.mean():.4f}')
    h, w = a.shape[0] // 4, a.shape[1] // 4
    ratios = np.array([[a[i * h:(i + 1) * h, j * w:(j + 1) * w].mean() / b[i * h:(i + 1) * h, j * w:(j + 1) * w].mean()
                        for j in range(4)] for i in range(4)])
    print('  4x4 block ratios rtc/mitsuba:')
    for row in ratios:
        print('   ', ' '.join(f'{x:.3f}' for x in row))
    print(f'  worst block {np.abs(ratios - 1).max() * 100:.2f} %  (targets: mean 2 %, blocks 5 %)')
    return ratios


if __name__ == '__main__':
    # python benchmarks/bench_mitsuba_path.py glossy glossy.usda [WIDTH HEIGHT]: write rtc's stage of a case
    import sys
    sys.path.insert(0, str(__import__('pathlib').Path(__file__).parent))
    case, out = sys.argv[1], sys.argv[2]
    size = [int(x) for x in sys.argv[3:5]] or [640, 480]
    st = rtc_stage(case, *size)
    st.GetRootLayer().Export(out)
    print(f'{case} -> {out}')
