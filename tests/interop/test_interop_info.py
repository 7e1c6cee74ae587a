"""`rtc info` (issue #6): what the renderer sees, with exact numbers, on corpus files and on a
compiled course scene.  The expected numbers were checked independently: placements and
triangles by walking the composed stage with instance proxies (and `ComputeMaskAtTime` for the
point instancer), the bunny by counting the OBJ's faces."""
from __future__ import annotations

import pytest
from click.testing import CliRunner

from rtc.cli import main

from tests.interop.interop_helpers import REPO, USD_CORPUS

TESTENV = 'openusd/pxr/usdImaging/usdImagingGL/testenv/'
NO_CAMERA = 'no camera in the stage: using a default camera framing the scene bounds'
NO_LIGHTS = 'no lights in the stage: added a default DistantLight headlight'


def info(path) -> list[str]:
    result = CliRunner().invoke(main, ['info', str(path)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return [line.strip() for line in result.output.splitlines()]


def assert_lines(lines: list[str], *expected: str):
    for e in expected:
        assert any(line.startswith(e) for line in lines), f'{e!r} not in:\n' + '\n'.join(lines)


CASES = {
    # nested native instancing: 12 cube instances through two levels of prototypes
    TESTENV + 'testUsdImagingGLInstancing/nestedInstancedCubes.usda': [
        'up axis Z (description is Y-up), metersPerUnit 0.01',
        'prototypes (containers): 1, placements: 12, motion samples: 1',
        'triangles: 12 unique, 144 instanced; spheres: 0 unique, 0 instanced',
        'lights: 2 (distant 1, dome 1)',
        'materials: 1 (previewSurface 1), material sets: 1',
        'warnings: 2', NO_CAMERA, NO_LIGHTS, 'skipped: 0'],
    # point instancer with 5 instances, one deactivated by inactiveIds
    TESTENV + 'testUsdImagingGLPointInstancer/pi_masking.usda': [
        'prototypes (containers): 1, placements: 4,',
        'triangles: 12 unique, 48 instanced',
        'PI:/Instancer/Protos/Proto1: 1 meshes (12 triangles), 0 spheres, placed 4x'],
    # a point instancer inside a native prototype; one of its prototypes does not exist
    TESTENV + 'testUsdImagingGLInstancing/ni_pi.usda': [
        'prototypes (containers): 1, placements: 50,',
        'triangles: 0 unique, 0 instanced; spheres: 1 unique, 50 instanced',
        '/__Prototype_1/Instancer: prototype /__Prototype_1/Instancer/Dumb/Dumber is missing or not defined'],
    # one prototype, two instances with different material overrides
    TESTENV + 'testUsdImagingGLInstancingWithMaterials/ni_2instances_shaded_overrides.usda': [
        'prototypes (containers): 1, placements: 2,',
        'triangles: 12 unique, 24 instanced',
        'materials: 3 (previewSurface 3), material sets: 2'],
    # seven containers (plain gprims + six point-instancer prototypes), a real camera
    TESTENV + 'testUsdImagingGLVelocityMotion/scene.usda': [
        'up axis Y (description is Y-up), metersPerUnit 0.01',
        'prototypes (containers): 7, placements: 7,',
        'triangles: 60 unique, 60 instanced',
        'camera: /World/main_cam perspective, focal length 2.4,',
        'materials: 2 (previewSurface 2), material sets: 3',
        'warnings: 1', NO_LIGHTS],
}


@pytest.mark.parametrize('rel', list(CASES), ids=lambda r: r.rsplit('/', 1)[-1])
def test_info_on_corpus_files(rel, usd_corpus):
    assert_lines(info(USD_CORPUS / rel), *CASES[rel])


def test_info_on_curves_lists_them(usd_corpus):
    """usdGeomExamples/basisCurves.usda: ten BasisCurves of 7 points - linear (6 segments each) and cubic bezier (2
    segments each), constant, varying and vertex widths, five with normals (ribbons); nothing to warn of but the
    missing camera and lights."""
    lines = info(USD_CORPUS / 'openusd/extras/usd/examples/usdGeomExamples/basisCurves.usda')
    assert_lines(lines, 'prototypes (containers): 1, placements: 1,',
                 'triangles: 0 unique, 0 instanced; spheres: 0 unique, 0 instanced; '
                 'curve segments: 36 unique, 36 instanced',
                 '/: 0 meshes (0 triangles), 0 spheres, 10 curves (36 segments), placed 1x', 'skipped: 0',
                 'warnings: 2')


def test_info_on_a_compiled_scene(tmp_path):
    """bunnies.xml: a 69,451-triangle OBJ bunny placed 7 times (one prototype) and a box floor;
    one area light, the course camera, five course shaders."""
    obj = REPO / 'scenes' / 'objFiles' / 'bunny.obj'
    faces = sum(1 for line in obj.read_text().splitlines() if line.startswith('f '))
    assert faces == 69451
    usd = tmp_path / 'bunnies.usda'
    result = CliRunner().invoke(main, ['compile', str(REPO / 'scenes' / 'bunnies.xml'), '-o', str(usd)],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert_lines(info(usd),
                 'up axis Y (description is Y-up), metersPerUnit 1',
                 # one prototype per (object, shader) pair: the bunny placed with 4 shaders is 4 prototypes
                 'prototypes (containers): 5, placements: 8, motion samples: 1',
                 f'triangles: {4 * faces + 12} unique, {7 * faces + 12} instanced; spheres: 0 unique, 0 instanced',
                 f'/: 1 meshes (12 triangles), 0 spheres, placed 1x',
                 'lights: 1 (rect 1)',
                 'camera: /World/Camera perspective, focal length 0.45, aperture 0.5 x 0.5, lens radius 0',
                 'image 512 x 512',
                 'materials: 5 (blinnPhong 1, blinnPhongMirrored 1, dielectric 1, glaze 2), material sets: 5',
                 'warnings: 0', 'skipped: 0')
    # the bunny prototypes are the other containers, placed seven times in all
    placed = [int(line.rsplit(' ', 1)[1][:-1]) for line in info(usd) if line.endswith('x') and
              f'1 meshes ({faces} triangles)' in line]
    assert sorted(placed) == [1, 2, 2, 2]


def test_info_counts_the_shaped_lights():
    """scenes/lights.usda: its spotlight and its sconce are shaped (ShapingAPI), the sconce by an IES profile; its
    sign has an image (an 8-bit PNG, kept as its bytes); its bar has inputs:specular 0."""
    lines = info(REPO / 'scenes' / 'lights.usda')
    assert_lines(lines, 'lights: 5 (cylinder 1, rect 2, sphere 2); shaped 2 (1 by an IES profile); 1 with an image; '
                 '1 with diffuse / specular gains', 'warnings: 0')
    assert any(line.endswith('sign.png (126 x 66, 3 channels, 8-bit, kept as bytes)') for line in lines), lines
