"""Interop (issue #6): `rtc render` renders every file of the shared USD corpus (real USD from
Pixar's OpenUSD tests and the USD Working Group's assets) that usd-core opens.

Each file is rendered at 48 x 36, 4 spp, in this process (the numba kernel is compiled or loaded
once) and the image must be finite and not uniform.  Files that genuinely contain nothing the
renderer can draw are found with an independent pxr walk (no surface gprim with data anywhere in
the composed stage, instance proxies included); for those the image must be uniform (the default
dome light's radiance), with the reason recorded.  The default run renders a representative
subset; `-m slow` renders the whole corpus (about 40 s).
"""
from __future__ import annotations

import subprocess

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.usd.stage import read_stage

from tests.interop.interop_helpers import RTC, USD_CORPUS, corpus_files

W, H, SPP = 48, 36, 4
SURFACES = {'Mesh', 'Sphere', 'Cube', 'Cylinder', 'Cylinder_1', 'Cone', 'Capsule', 'Capsule_1', 'Plane', 'Points',
            'BasisCurves', 'NurbsCurves', 'TetMesh', 'NurbsPatch'}

#: Files with surface gprims that must still render nothing, and why.
EMPTY_BY_DESIGN = {
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_bad_schema_input.usda':
        'every PointInstancer lacks prototypes, protoIndices or positions (its prototypes are inactive); '
        "usdImaging's expected image for this test is empty too",
}

#: Representative subset for the default run: every feature the corpus exercises.
DEFAULT_SUBSET = [
    'openusd/extras/usd/examples/usdGeomExamples/basisCurves.usda',                      # curves only
    'openusd/extras/usd/tutorials/animatedTop/top.geom.usd',                              # USD 0.4 crate
    'openusd/extras/usd/tutorials/convertingLayerFormats/Sphere.usd',
    'openusd/extras/usd/tutorials/endToEnd/assets/Ball/Ball.usd',                         # Maya, ri-only material
    'openusd/extras/usd/tutorials/endToEnd/assets/shot.usd',                              # camera only
    'openusd/extras/usd/tutorials/simpleShading/simpleShading.usda',                     # textured preview surface
    'openusd/pxr/usd/usd/testenv/testUsdLoadUnloadDeepNestedInstancing.testenv/Earth.usd',  # meshes without points
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLAnimatedCamera/cameraMoving.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLHdEmbree/primitives.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInheritedPurpose/InheritedPurposes_Nested_Instances.usd',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/instance2.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/instancedCubes2NoInstancing.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/nestedInstancedCubes.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/ni_pi.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/sphereInstancer.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancingWithMaterials/ni_ni_material_outside_prototype.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_bad_schema_input.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_masking.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_ni_pi.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_pi.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPointInstancer/pi_varying.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPreviewSurface/testPreviewSurfaceSpecular.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPreviewSurface/testPreviewSurfaceTransform2d.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLPurpose/world.usda',
    'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLVelocityMotion/scene.usda',
    'usd-wg/full_assets/SubdivisionSurfaces/Creases_SpinningPyramids.usda',
    'usd-wg/full_assets/SubdivisionSurfaces/Pyramid/mtl.usda',                          # materials only
    'usd-wg/test_assets/RoughnessTest/RoughnessTest.usdz',
    'usd-wg/test_assets/USDZ/AnimatedCube/AnimatedCube.usdz',
]


def surface_census(path) -> tuple[int, set[str]]:
    """(number of surface gprims with data, prim types) over ALL prims of the composed stage,
    instance proxies, inactive, abstract and `over` prims included: an upper bound of what
    any renderer could draw, computed without the rtc reader."""
    stage = Usd.Stage.Open(str(path))
    t = stage.GetStartTimeCode()
    count, types = 0, set()
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
        kind = prim.GetTypeName()
        types.add(str(kind))
        if kind == 'Mesh':
            has_data = bool(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(t))
        elif kind in ('Points', 'BasisCurves', 'NurbsCurves', 'TetMesh', 'NurbsPatch'):
            has_data = bool(UsdGeom.PointBased(prim).GetPointsAttr().Get(t))
        else:
            has_data = True
        if kind in SURFACES and has_data:
            count += 1
    return count, types


def empty_reason(rel: str) -> str | None:
    """Why the file renders nothing, or None when it must render something."""
    if rel in EMPTY_BY_DESIGN:
        return EMPTY_BY_DESIGN[rel]
    count, types = surface_census(USD_CORPUS / rel)
    if count:
        return None
    if 'Mesh' in types:
        return 'its meshes have no faces (an asset for composition tests)'
    if 'Camera' in types:
        return 'a camera only'
    return 'no gprims at all (composition-test scopes, a materials or instancer layer)'


def render_corpus_file(rel: str):
    desc = read_stage(str(USD_CORPUS / rel), options=RenderOptions(width=W, height=H, spp=SPP))
    result = render(desc, RenderOptions(width=W, height=H, spp=SPP))
    return desc, result.image


def check_file(rel: str):
    desc, img = render_corpus_file(rel)
    assert img.shape == (H, W, 3)
    assert np.isfinite(img).all(), f'{rel}: non-finite pixels'
    reason = empty_reason(rel)
    if reason is None:
        assert img.std() > 1e-4 and np.ptp(img) > 1e-3, \
            f'{rel}: image is (nearly) uniform: std {img.std():g}; warnings {desc.warnings}; skipped {desc.skipped}'
    else:
        assert desc.triangle_counts() == (0, 0) and not any(c.spheres or c.curves for c in desc.containers), (rel, reason)
        assert np.ptp(img) == 0, f'{rel} ({reason}): expected a uniform image'


def test_default_subset_exists(usd_corpus):
    files = set(corpus_files())
    assert set(DEFAULT_SUBSET) <= files
    assert len(files) >= 150


@pytest.mark.parametrize('rel', DEFAULT_SUBSET)
def test_corpus_file_renders(rel, usd_corpus):
    check_file(rel)


@pytest.mark.slow
@pytest.mark.parametrize('rel', corpus_files())
def test_every_corpus_file_renders(rel, usd_corpus):
    check_file(rel)


def test_usdz_and_z_up_through_the_cli(usd_corpus, tmp_path):
    """The real command line on a packaged (.usdz) Blender export: exit 0, an image, no traceback, and its
    texture-driven roughness read (no warning that it is not)."""
    rel = 'usd-wg/test_assets/RoughnessTest/RoughnessTest.usdz'
    out = tmp_path / 'roughness.png'
    r = subprocess.run(RTC + ['render', str(USD_CORPUS / rel), '-o', str(out), '--width', str(W),
                              '--spp', str(SPP)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert 'Traceback' not in r.stderr and 'not supported' not in r.stderr and 'warning: no camera' in r.stderr
    from rtc.renderer.host.film import read_image
    img = read_image(out)
    assert img.shape == (H, W, 3) and img.std() > 1e-3


MISSING = '''#usda 1.0
(
    subLayers = [@./does_not_exist.usda@]
)
def Xform "World"
{
    def Sphere "Ball"
    {
        double radius = 1
    }
    def "Look" (
        prepend references = @./looks.mtlx@</MaterialX>
    )
    {
    }
    def "Prop" (
        prepend references = @./missing_prop.usd@
    )
    {
    }
}
'''


def test_unloadable_layers_are_skipped_with_warnings(tmp_path):
    """A missing sublayer, a MaterialX reference (no usdMtlx in usd-core) and a missing asset:
    what can be rendered is rendered, each skipped layer is named in a warning."""
    scene = tmp_path / 'scene.usda'
    scene.write_text(MISSING)
    (tmp_path / 'looks.mtlx').write_text('<?xml version="1.0"?>\n<materialx version="1.38"/>\n')
    desc = read_stage(str(scene), options=RenderOptions(width=W, height=H, spp=SPP))
    text = '\n'.join(desc.warnings)
    for name in ('does_not_exist.usda', 'looks.mtlx', 'missing_prop.usd'):
        assert name in text, text
    img = render(desc, RenderOptions(width=W, height=H, spp=SPP)).image
    assert img.std() > 1e-3
