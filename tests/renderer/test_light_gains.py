"""A light's UsdLux `inputs:diffuse` and `inputs:specular`: multipliers of its effect on the diffuse and on the
specular lobes of the surfaces it lights, in both integrators (were warned and ignored).

Independent references: the estimators are linear in the two gains, so with the same samples an image with gains
(a, b) must be a (diffuse-only image) + b (specular-only image), each less what a camera sees of the light directly
(which no gain touches: the image with gains (0, 0)); the diffuse-only and specular-only images add up to the plain
light's.  Light sampling alone, BSDF sampling alone and MIS agree under gains (the BSDF-sampled ray weighs the
light it finds by the shares of the BSDF value it was drawn with).  A Lambert floor under a diffuse gain g is g
times the plain floor; a metal floor under a specular gain 0 is black."""
import numpy as np
import pytest
from pxr import Usd, UsdGeom, UsdLux

from rtc.renderer import description as D
from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import estimator_means, look_at, ortho_down, quad, rect_light, scene, translate

W, H = 40, 30


def _lights(gains, dome=False):
    """A rect light in view of the camera and a sphere light beside it (so that the light tree chooses), both
    with `gains`; with `dome`, a dim dome with them too."""
    rect = rect_light((0.0, 2.0, -1.0), 1.0, 0.6, (6.0, 5.0, 4.0))
    rect.gains = gains
    ball = D.Light(path='/ball', type=D.SPHERE, matrix=translate(1.5, 1.2, 0.5), radiance=(3.0, 3.0, 4.0),
                   radius=0.2, gains=gains)
    out = [rect, ball]
    if dome:
        out.append(D.Light(path='/dome', type=D.DOME, matrix=np.eye(4), radiance=(0.3, 0.35, 0.4), gains=gains))
    return out


def _plastic_scene(gains, dome=False, material=None):
    """A plastic floor (diffuse and a GGX highlight) and a plastic ball, seen at a grazing angle so that the
    floor reflects the rect light; the rect light itself is in view."""
    mat = material or D.Material('/plastic', diffuse=(0.5, 0.4, 0.3), roughness=0.3)
    ball = D.Mesh(path='/ball', points=np.array([[-0.6, 0.0, 0.3], [0.0, 0.8, 0.0], [0.4, 0.0, 0.6]], np.float64),
                  triangles=np.array([[0, 2, 1]], np.int32), material=0)
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 1.2, 4.0), (0.0, 0.6, -1.0)), focal_length=2.5,
                   horizontal_aperture=2.0, vertical_aperture=1.5)
    return scene([D.Container('/', meshes=[quad(10.0), ball])], [mat], _lights(gains, dome), cam, width=W, height=H)


def _render(desc, integrator, spp=16, **kw):
    opts = dict(spp=spp, integrator=integrator, sampler='sobol', seed=3)
    if integrator == 'path':
        opts.update(max_depth=3)
    opts.update(kw)
    with Renderer(desc, threads=2) as r:
        return r.render(RenderOptions(**opts)).image.astype(np.float64)[..., :3]


MATERIALS = {
    'plastic': None,                                          # (`_plastic_scene`'s own)
    'clearcoat': D.Material('/coated', diffuse=(0.5, 0.4, 0.3), roughness=0.4, clearcoat=0.8,
                            clearcoat_roughness=0.1),
    'blinn-phong': D.Material('/blinn', model=D.BLINN_PHONG, diffuse=(0.5, 0.4, 0.3), specular=(0.4, 0.4, 0.4),
                              exponent=30.0),
}


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('dome', [False, True])
@pytest.mark.parametrize('material', list(MATERIALS))
def test_an_image_is_linear_in_the_gains(integrator, dome, material):
    """image(a, b) = Z + a (image(1, 0) - Z) + b (image(0, 1) - Z), Z = image(0, 0) (the light as the camera sees
    it), and image(1, 0) + image(0, 1) - Z = the plain light's image: the same samples, so to rounding.  Also for
    a negative gain (a subtractive light), a clearcoat (the layer below it dimmed by the coat) and the course's
    Blinn-Phong (its highlight specular)."""
    gains = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 2.0), (-0.5, 0.7), (1.0, 1.0)]
    imgs = {g: _render(_plastic_scene(g, dome, MATERIALS[material]), integrator) for g in gains}
    z, d, s = imgs[(0.0, 0.0)], imgs[(1.0, 0.0)] - imgs[(0.0, 0.0)], imgs[(0.0, 1.0)] - imgs[(0.0, 0.0)]
    scale = imgs[(1.0, 1.0)].max()
    assert d.mean() > 0.05 * z.mean() and s.mean() > 0.02 * d.mean()     # (both parts matter in this scene)
    assert np.abs(imgs[(1.0, 1.0)] - (z + d + s)).max() < 2e-6 * scale          # (float32 images)
    for a, b in gains[3:5]:
        assert np.abs(imgs[(a, b)] - (z + a * d + b * s)).max() < 2e-6 * scale, (a, b)
    if integrator == 'path':                     # (cook: course semantics; no rect light in view)
        assert z.max() > 0.5 * scale             # the rect light is in view, unchanged by the gains


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_lambert_floor_under_a_diffuse_gain(integrator):
    """A Lambert floor lit from above, direct light only: a diffuse gain g gives g times the plain image; the
    specular gain changes nothing."""
    def floor(gains):
        light = rect_light((0.0, 2.0, 0.0), 1.0, 1.0, (4.0,) * 3)
        light.gains = gains
        mat = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.7, 0.6, 0.5))
        return scene([D.Container('/', meshes=[quad(8.0)])], [mat], [light], ortho_down(width=6.0), width=16,
                     height=16)
    kw = dict(max_depth=1) if integrator == 'path' else {}
    plain = _render(floor((1.0, 1.0)), integrator, **kw)
    assert plain.mean() > 0.01
    assert np.allclose(_render(floor((0.4, 3.0)), integrator, **kw), 0.4 * plain, rtol=1e-6, atol=0)


def test_a_metal_floor_under_a_specular_gain_of_zero_is_black():
    """A metal reflects with its specular lobe alone: with inputs:specular 0 the light does not light it, in light
    samples and in the BSDF rays that find the light (the image is exactly 0)."""
    metal = D.Material('/metal', diffuse=(0.9, 0.8, 0.6), metallic=1.0, roughness=0.3)
    light = rect_light((0.0, 2.0, 0.0), 1.0, 1.0, (4.0,) * 3)
    light.gains = (5.0, 0.0)
    desc = scene([D.Container('/', meshes=[quad(8.0)])], [metal], [light], ortho_down(width=6.0), width=16, height=16)
    assert _render(desc, 'path', max_depth=1).max() == 0.0
    light.gains = (5.0, 1.0)
    assert _render(desc, 'path', max_depth=1).max() > 0.01


@pytest.mark.parametrize('dome', [False, True])
@pytest.mark.parametrize('sun', [False, True])
def test_light_and_bsdf_sampling_agree_under_gains(dome, sun):
    """Direct light of a plastic floor under a rect light (and a dome, a sun: a distant light of 20 degrees) with
    inputs:diffuse 0.3 and inputs:specular 2: the gains are weighed in each light sample by the BSDF's parts and,
    where a BSDF ray finds the light, by the shares of the value it was drawn with: the three estimators agree.
    (With the dome the plastic is rougher: light samples of a dome drawn by the cosine find a narrow highlight too
    rarely for 256 samples - at roughness 0.3, four seeds give 0.1286-0.1383 against 0.1320.)"""
    mat = D.Material('/plastic', diffuse=(0.5, 0.4, 0.3), roughness=0.5 if dome else 0.3)
    light = rect_light((0.3, 1.0, 0.0), 1.2, 0.8, (2.0, 2.0, 2.0))
    light.gains = (0.3, 2.0)
    lights = [light]
    if dome:
        lights.append(D.Light(path='/dome', type=D.DOME, matrix=np.eye(4), radiance=(0.2,) * 3, gains=(0.3, 2.0)))
    if sun:                               # (emits along its -Z, down and towards the camera: a highlight in view)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2] = (1.0, 0.0, 0.0), (0.0, -0.8, -0.6), (0.0, 0.6, -0.8)
        lights.append(D.Light(path='/sun', type=D.DISTANT, matrix=m, radiance=(1.0,) * 3, angle=20.0,
                              gains=(0.3, 2.0)))
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 1.0, 3.0), (0.0, 0.0, -0.5)), focal_length=2.0,
                   horizontal_aperture=2.0, vertical_aperture=2.0)
    desc = scene([D.Container('/', meshes=[quad(8.0)])], [mat], lights, cam, width=24, height=24)
    nee, bsdf, mis = estimator_means(desc, nee_spp=256, bsdf_spp=2048, mis_spp=256)
    assert mis > 1e-3
    assert nee == pytest.approx(mis, rel=0.01) and bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def _glow_scene(gains, floor=None):
    """The plastic floor (or `floor`) and ball lit by a glowing card (a MeshLightAPI mesh's material: emission with
    lobe gains; an emissive surface is a light of the path integrator), in view of the camera."""
    card = D.Mesh(path='/card', points=np.array([[-0.6, 0.4, -3.0], [0.6, 0.4, -3.0], [0.6, 1.4, -3.0],
                                                 [-0.6, 1.4, -3.0]], np.float64),
                  triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=1)    # (upright, facing +Z)
    glow = D.Material('/glow', diffuse=(0.0, 0.0, 0.0), emission=(6.0, 5.0, 4.0), light_gains=gains)
    desc = _plastic_scene((1.0, 1.0), material=floor)
    desc.containers[0].meshes.append(card)
    desc.materials.append(glow)
    desc.lights = []
    return desc


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_mesh_lights_gains_are_linear(integrator):
    """A MeshLightAPI mesh's gains, as a light's: the image is linear in them (the same identity as above); in path
    its light samples and the BSDF rays that find it weigh them, in cook the mirror reflections that find it (cook
    does not light surfaces by emission: its floor is a course mirror, which shows the card by its specular gain)."""
    gains = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 2.0), (1.0, 1.0)]
    floor = D.Material('/mirror', model=D.MIRROR, specular=(0.8, 0.8, 0.8)) if integrator == 'cook' else None
    imgs = {g: _render(_glow_scene(g, floor), integrator) for g in gains}
    z, d, s = imgs[(0.0, 0.0)], imgs[(1.0, 0.0)] - imgs[(0.0, 0.0)], imgs[(0.0, 1.0)] - imgs[(0.0, 0.0)]
    scale = imgs[(1.0, 1.0)].max()
    assert s.mean() > 0.01 * z.mean() and (d.mean() == 0.0 if integrator == 'cook' else d.mean() > 0.01 * z.mean())
    assert np.abs(imgs[(1.0, 1.0)] - (z + d + s)).max() < 2e-6 * scale
    assert np.abs(imgs[(0.3, 2.0)] - (z + 0.3 * d + 2.0 * s)).max() < 2e-6 * scale


def test_light_and_bsdf_sampling_agree_for_a_mesh_lights_gains():
    """The glowing card with gains (0.3, 2) over the plastic floor: light samples of the emissive surface and the
    BSDF rays that hit it weigh the gains alike (direct light; the three estimators agree)."""
    nee, bsdf, mis = estimator_means(_glow_scene((0.3, 2.0)), nee_spp=256, bsdf_spp=2048, mis_spp=256)
    assert mis > 1e-3
    assert nee == pytest.approx(mis, rel=0.01) and bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def _stage(tmp_path, text):
    path = tmp_path / 'gains.usda'
    path.write_text('#usda 1.0\n(\n    upAxis = "Y"\n)\n' + text)
    return str(path)


def test_the_stage_reader_reads_the_gains(tmp_path):
    """inputs:diffuse / inputs:specular authored: read, no warning; unauthored: 1; not finite: the light is
    left out, warned (as any non-finite light input); authored with a type that is not a number: warned, 1;
    on a MeshLightAPI mesh: the gains of the material that emits its light (not finite: no emission, warned)."""
    text = '''
def RectLight "A" {
    float inputs:diffuse = 0.25
    float inputs:specular = 3
}
def SphereLight "B" {
}
def DomeLight "C" {
    float inputs:specular = 0
}
def DiskLight "Bad" {
    float inputs:diffuse = nan
}
def DistantLight "Odd" {
    string inputs:specular = "high"
}
def Mesh "Glow" ( prepend apiSchemas = ["MeshLightAPI"] ) {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    float inputs:diffuse = 0.5
}
def Mesh "BadGlow" ( prepend apiSchemas = ["MeshLightAPI"] ) {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 2), (1, 0, 2), (0, 1, 2)]
    float inputs:specular = inf
}
'''
    desc = read_stage(_stage(tmp_path, text), options=RenderOptions(width=8, height=8, spp=1))
    gains = {light.path: tuple(light.gains) for light in desc.lights}
    assert gains['/A'] == (0.25, 3.0) and gains['/B'] == (1.0, 1.0) and gains['/C'] == (1.0, 0.0)
    assert gains['/Odd'] == (1.0, 1.0) and '/Bad' not in gains
    text = '\n'.join(desc.warnings)
    assert '/Bad.inputs:diffuse: nan is not a finite number; light ignored' in text
    assert '/Odd.inputs:specular: authored as string, not a number; read as 1' in text
    assert not any('/A' in w or '/C' in w or '/Glow' in w for w in desc.warnings)
    glow = [m for m in desc.materials if 'MeshLightAPI' in m.path]
    assert len(glow) == 1 and tuple(glow[0].light_gains) == (0.5, 1.0)      # (BadGlow: no emission, warned)
    assert '/BadGlow: non-finite MeshLightAPI parameters; no emission' in text


def test_gains_authored_with_pxr_render_through_the_stage_reader(tmp_path):
    """A stage written with UsdLux's API (a rect light in view over a floor): the images with gains (1, 0),
    (0, 1) and (0, 0) add up as the linearity above says to the plain light's."""
    def write(diffuse, specular):
        stage = Usd.Stage.CreateNew(str(tmp_path / f'g{diffuse}{specular}.usda'))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        cam = UsdGeom.Camera.Define(stage, '/Cam')
        cam.AddTranslateOp().Set((0.0, 3.0, 5.0))
        cam.AddRotateXOp().Set(-35.0)
        cam.CreateFocalLengthAttr(18.0)
        floor = UsdGeom.Mesh.Define(stage, '/Floor')
        floor.CreatePointsAttr([(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)])
        floor.CreateFaceVertexCountsAttr([4])
        floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
        light = UsdLux.RectLight.Define(stage, '/Key')
        light.AddTranslateOp().Set((0.0, 2.0, 0.0))
        light.AddRotateXOp().Set(-90.0)
        light.CreateIntensityAttr(5.0)
        if diffuse != 1.0:
            light.CreateDiffuseAttr(diffuse)
        if specular != 1.0:
            light.CreateSpecularAttr(specular)
        stage.GetRootLayer().Save()
        return stage.GetRootLayer().realPath
    imgs = {}
    for g in [(1.0, 1.0), (1.0, 0.0), (0.0, 1.0), (0.0, 0.0)]:
        desc = read_stage(write(*g), options=RenderOptions(width=24, height=18, spp=8))
        assert not desc.warnings or not any('inputs:' in w for w in desc.warnings), desc.warnings
        imgs[g] = _render(desc, 'path', spp=8, width=24, height=18)
    assert imgs[(1.0, 0.0)].mean() > 0.01 and imgs[(0.0, 1.0)].mean() > 0.0
    total = imgs[(1.0, 0.0)] + imgs[(0.0, 1.0)] - imgs[(0.0, 0.0)]
    assert np.abs(total - imgs[(1.0, 1.0)]).max() < 2e-6 * imgs[(1.0, 1.0)].max()
