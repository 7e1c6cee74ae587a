"""An emissiveColor driven by a texture (UsdPreviewSurface `emissiveColor` <- UsdUVTexture): the surface
emits its emissiveColor times the texture's value at each point, as the camera sees it (cook and path) and
as it lights the scene (path: a light of the tree, its light samples looking the texture up at the point
they draw).  References are numerical quadratures of the textured emitter's light over its surface, with
the texture's bilinear lookup written out here; light sampling alone, BSDF sampling alone and MIS each
converge to them, so the texture coordinates of a drawn point and of a ray's hit agree."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from rtc.renderer.usd.stage import read_stage
from tests.renderer import test_integrator as ti
from tests.renderer.handmade import ortho_down, quad, scene, translate

N, WIDTH, H, A, B = 24, 4.0, 1.0, 1.2, 0.8
FLOOR = D.Material('/floor', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))
# 4 x 2 texels, a different pattern in each channel (row 0 is the top of the image: t = 1)
TEXELS = np.array([[[0.5, 2.0, 0.1], [1.0, 0.2, 0.1], [2.0, 0.2, 3.0], [4.0, 1.0, 0.1]],
                   [[0.2, 0.1, 2.0], [0.2, 3.0, 0.3], [3.0, 0.1, 0.1], [0.1, 0.5, 1.0]]], np.float32)
SCALE = 1.5


def lookup(s, t):
    """The texture's bilinear value at (s, t), clamped at its edges, as `kernel/textures.sample_texture`
    reads it: (..., 3)."""
    h, w = TEXELS.shape[:2]
    x = np.asarray(s) * w - 0.5
    y = (1.0 - np.asarray(t)) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    ix, iy = x0.astype(int), y0.astype(int)

    def texel(i, j):
        return TEXELS[np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)].astype(np.float64)
    return ((1 - fx) * (1 - fy) * texel(ix, iy) + fx * (1 - fy) * texel(ix + 1, iy)
            + (1 - fx) * fy * texel(ix, iy + 1) + fx * fy * texel(ix + 1, iy + 1))


def glow(model=D.LAMBERTIAN):
    """Emits SCALE times the texture, reflects no diffuse light."""
    return D.Material('/glow', model=model, diffuse=(0.0, 0.0, 0.0), emission=(SCALE,) * 3, emission_texture=0)


def texture():
    return D.Texture(path='<texels>', pixels=TEXELS, wrap_s='clamp', wrap_t='clamp')


def panel():
    """An A x B quad at height H, facing down, its st (0, 0) at (-A/2, -B/2) and (1, 1) at (A/2, B/2)."""
    pts = np.array([[-A / 2, H, -B / 2], [A / 2, H, -B / 2], [A / 2, H, B / 2], [-A / 2, H, B / 2]])
    uv = np.array([[(0, 0), (1, 0), (1, 1)], [(0, 0), (1, 1), (0, 1)]], np.float32)
    return D.Mesh(path='/panel', points=pts, triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=1,
                  uvs=uv)


def panel_scene():
    return scene([D.Container('/', meshes=[quad(40.0), panel()])], [FLOOR, glow()], [], ortho_down(width=WIDTH),
                 width=N, height=N, textures=[texture()])


def panel_reference(dx=0.0, ns=96, nt=64):
    """Floor radiance (albedo / pi x irradiance) from the panel moved by dx along X, midpoint rule over
    ns x nt cells."""
    s, t = (np.arange(ns) + 0.5) / ns, (np.arange(nt) + 0.5) / nt
    S, T = np.meshgrid(s, t)
    L = SCALE * lookup(S, T).reshape(-1, 3)
    ex, ez = (S * A - A / 2 + dx).ravel(), (T * B - B / 2).ravel()
    dA = A * B / (ns * nt)

    def radiance(x, z):
        d2 = (ex[None] - x.reshape(-1, 1)) ** 2 + H * H + (ez[None] - z.reshape(-1, 1)) ** 2
        E = (H * H / d2 ** 2 * dA) @ L                      # cos_x cos_y / d^2 = H^2 / d^4
        return (0.5 / np.pi * E).reshape(*x.shape, 3)
    return _pixel_average3(radiance)


def _pixel_average3(fn, sub=2):
    return np.stack([ti.pixel_average(lambda x, z, c=c: fn(x, z)[..., c], N, WIDTH, sub=sub) for c in range(3)], -1)


def _render(desc, spp, strategy='mis', integrator='path'):
    with Renderer(desc) as r:
        return r.render(RenderOptions(spp=spp, integrator=integrator, strategy=strategy if integrator == 'path' else None,
                                      filter='box', seed=0, sampler='sobol')).image.astype(np.float64)


def _check(img, ref, keep, what):
    for c in range(3):
        assert img[keep, c].mean() == pytest.approx(ref[keep, c].mean(), rel=0.01), (what, c)
        assert np.sqrt(np.mean((img[keep, c] - ref[keep, c]) ** 2)) < 0.03 * ref[keep, c].max(), (what, c)


@pytest.mark.parametrize('strategy', ['mis', 'nee', 'bsdf'])
def test_a_textured_emissive_panel_lights_the_floor_as_the_quadrature_says(strategy):
    ref = panel_reference()
    c = ti.pixel_centers(N, WIDTH)
    X, Z = np.meshgrid(c, c)
    half = 0.5 * WIDTH / N
    keep = (np.abs(X) > A / 2 + half) | (np.abs(Z) > B / 2 + half)        # the floor beside the panel
    img = _render(panel_scene(), 4096 if strategy == 'bsdf' else 512, strategy)
    _check(img, ref, keep, strategy)
    # the texture's orientation shows: its mirror image would light the floor well beyond the tolerance
    flipped = np.flip(ref, 1)
    assert np.sqrt(np.mean((flipped[keep, 0] - ref[keep, 0]) ** 2)) > 0.1 * ref[keep, 0].max()


def test_a_moving_textured_emissive_panel_lights_the_floor_as_its_shutter_average():
    """The panel moving 0.7 along X over the shutter (its placement's two motion samples, lerped): its
    light samples, drawn on its object-space triangles and placed at each path's time, read the texture
    at their triangle's st; each strategy converges to the time average of the quadratures."""
    mats = np.stack([np.stack([np.eye(4), np.eye(4)]), np.stack([translate(-0.4, 0.0, 0.0), translate(0.3, 0.0, 0.0)])])
    inst = D.Instances(container=np.array([0, 1], np.int32), matrices=mats, material_set=np.zeros(2, np.int32),
                       material_sets=[()])
    desc = scene([D.Container('/', meshes=[quad(40.0)]), D.Container('/panel', meshes=[panel()])], [FLOOR, glow()],
                 [], ortho_down(width=WIDTH), instances=inst, width=N, height=N, textures=[texture()])
    times = (np.arange(24) + 0.5) / 24
    ref = np.mean([panel_reference(-0.4 + 0.7 * t, 48, 32) for t in times], 0)
    c = ti.pixel_centers(N, WIDTH)
    X, Z = np.meshgrid(c, c)
    half = 0.5 * WIDTH / N
    keep = (X < -0.4 - A / 2 - half) | (X > 0.3 + A / 2 + half) | (np.abs(Z) > B / 2 + half)
    for strategy, spp in (('mis', 512), ('nee', 512), ('bsdf', 4096)):
        _check(_render(desc, spp, strategy), ref, keep, strategy)


@pytest.mark.parametrize('integrator', ['path', 'cook'])
def test_the_camera_sees_the_texture_on_the_panel(integrator):
    """Seen from above (both sides of an emissive surface emit), each pixel the panel covers is the mean
    of SCALE x the texture over the pixel (a UsdPreviewSurface: the course integrator adds emission for
    that model; nothing else lights the panel)."""
    c = ti.pixel_centers(N, WIDTH)
    X, Z = np.meshgrid(c, c)
    half = 0.5 * WIDTH / N
    inside = (np.abs(X) < A / 2 - half) & (np.abs(Z) < B / 2 - half)
    ref = _pixel_average3(lambda x, z: SCALE * lookup((x + A / 2) / A, (z + B / 2) / B), sub=8)
    desc = scene([D.Container('/', meshes=[panel()])], [FLOOR, glow(D.PREVIEW_SURFACE)], [], ortho_down(width=WIDTH),
                 width=N, height=N, textures=[texture()])
    img = _render(desc, 256, integrator=integrator)
    assert np.allclose(img[inside], ref[inside], rtol=1e-2, atol=1e-3), np.abs(img[inside] - ref[inside]).max()
    assert img[inside].mean(0) == pytest.approx(ref[inside].mean(0), rel=1e-3)


def _rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_a_textured_emissive_sphere_placed_by_a_rotation_lights_the_floor_as_the_quadrature_says():
    """A black sphere whose emission is a lat-long texture (+Y up, seam at -X, in the sphere's own frame),
    placed by a rotation: each strategy converges to the quadrature over its visible half."""
    r, centre, rot = 0.45, np.array([0.3, 0.8, -0.2]), _rotation((1.0, 1.0, 0.3), 0.9)
    place = np.eye(4)
    place[:3, :3], place[:3, 3] = rot, centre
    ball = D.Sphere(path='/ball', radius=r, matrix=np.eye(4), material=1)
    inst = D.Instances(container=np.array([0, 1], np.int32), matrices=np.stack([np.eye(4), place])[:, None],
                       material_set=np.zeros(2, np.int32), material_sets=[()])
    desc = scene([D.Container('/', meshes=[quad(40.0)]), D.Container('/ball', spheres=[ball])], [FLOOR, glow()], [],
                 ortho_down(width=WIDTH), instances=inst, width=N, height=N, textures=[texture()])
    nth, nph = 96, 192
    th, ph = (np.arange(nth) + 0.5) / nth * np.pi, (np.arange(nph) + 0.5) / nph * 2 * np.pi
    TH, PH = np.meshgrid(th, ph, indexing='ij')
    n = np.stack([np.sin(TH) * np.cos(PH), np.cos(TH), np.sin(TH) * np.sin(PH)], -1).reshape(-1, 3)   # object
    L = SCALE * lookup(0.5 + np.arctan2(n[:, 2], -n[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(n[:, 1]) / np.pi)
    nw = n @ rot.T
    y = centre + r * nw
    dA = (r * r * np.sin(TH) * (np.pi / nth) * (2 * np.pi / nph)).ravel()

    def radiance(x, z):
        p = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
        v = y[None] - p[:, None]                                     # floor point -> sphere point
        d2 = (v * v).sum(-1)
        cos_x = v[..., 1] / np.sqrt(d2)
        cos_y = np.maximum(-(v * nw[None]).sum(-1) / np.sqrt(d2), 0.0)  # the half that faces the point
        E = (cos_x * cos_y / d2 * dA) @ L
        return (0.5 / np.pi * E).reshape(*x.shape, 3)
    ref = _pixel_average3(radiance)
    c = ti.pixel_centers(N, WIDTH)
    X, Z = np.meshgrid(c, c)
    keep = np.hypot(X - centre[0], Z - centre[2]) > r + WIDTH / N                  # the floor beside the ball
    for strategy, spp in (('mis', 512), ('nee', 512), ('bsdf', 4096)):
        _check(_render(desc, spp, strategy), ref, keep, strategy)


def _usd_panel(tmp_path, sync=None):
    """A stage: a quad with st whose UsdPreviewSurface's emissiveColor reads TEXELS from an EXR (and,
    with `sync`, MeshLightAPI with that light:materialSyncMode)."""
    import OpenImageIO as oiio
    exr = str(tmp_path / 'glow.exr')
    out = oiio.ImageOutput.create(exr)
    out.open(exr, oiio.ImageSpec(TEXELS.shape[1], TEXELS.shape[0], 3, 'float'))
    out.write_image(np.ascontiguousarray(TEXELS))
    out.close()
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, 'Y')
    mesh = UsdGeom.Mesh.Define(stage, '/World/Panel')
    mesh.CreatePointsAttr([(-0.6, 1, -0.4), (0.6, 1, -0.4), (0.6, 1, 0.4), (-0.6, 1, 0.4)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    mat = UsdShade.Material.Define(stage, '/World/Glow')
    surf = UsdShade.Shader.Define(stage, '/World/Glow/Surface')
    surf.CreateIdAttr('UsdPreviewSurface')
    tex = UsdShade.Shader.Define(stage, '/World/Glow/Texture')
    tex.CreateIdAttr('UsdUVTexture')
    tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(exr)
    tex.CreateInput('sourceColorSpace', Sdf.ValueTypeNames.Token).Set('raw')
    surf.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.CreateOutput('rgb', Sdf.ValueTypeNames.Float3))
    mat.CreateSurfaceOutput().ConnectToSource(surf.ConnectableAPI(), 'surface')
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    if sync is not None:
        UsdLux.MeshLightAPI.Apply(mesh.GetPrim())
        api = UsdLux.LightAPI(mesh.GetPrim())
        api.CreateIntensityAttr(3.0)
        mesh.GetPrim().CreateAttribute('light:materialSyncMode', Sdf.ValueTypeNames.Token).Set(sync)
    return stage


def test_an_emissive_color_texture_is_read_as_the_emission(tmp_path):
    desc = read_stage(_usd_panel(tmp_path))
    assert not [w for w in desc.warnings if 'emissiveColor' in w], desc.warnings
    m = desc.materials[desc.containers[0].meshes[0].material]
    assert m.emission == (1.0, 1.0, 1.0) and m.emission_texture >= 0
    assert np.array_equal(desc.textures[m.emission_texture].pixels[..., :3], TEXELS)


@pytest.mark.parametrize('sync, textured', [('materialGlowTintsLight', True), ('independent', False)])
def test_a_mesh_light_is_tinted_by_its_materials_emission_texture_only_where_its_glow_tints_it(tmp_path, sync,
                                                                                                textured):
    desc = read_stage(_usd_panel(tmp_path, sync))
    m = desc.materials[desc.containers[0].meshes[0].material]
    assert m.emission == pytest.approx((3.0,) * 3)
    assert (m.emission_texture >= 0) == textured
