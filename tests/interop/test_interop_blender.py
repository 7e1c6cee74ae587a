"""Our compiled USD in Blender's USD importer (issues #6 and 14; optional: `pytest -m interop`, needs
Blender as a Python module, `bpy` 5, here or in the Python that RTC_BLENDER_PYTHON names).

Blender imports in a child process (blender_import.py).  Against the composed stage read with
usd-core, we check: the same number of mesh objects as gprims (instance proxies expanded) with the
same world transforms; with Blender's scene instancing, one collection-instance empty per USD
instance with the instance's world transform and one collection per prototype; the same lights
and cameras at the same places; and, for Mesh gprims, the bound material.  Blender converts the
Y-up stage to Z-up by rotating the root +90 degrees about X, so Blender's matrix_world equals
``Rx(90) @ M_usd`` (column-vector form).  Pitfalls found are described in README.md ("Using rtc with other USD tools").
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Usd, UsdGeom, UsdLux, UsdShade

from rtc.compiler.cli import compile_cmd

from tests.interop.blender_view import agrees, blender_import, blender_python, compare, world
from tests.interop.interop_helpers import COURSE_CORPUS, REPO

pytestmark = [pytest.mark.interop,
              pytest.mark.skipif(blender_python() is None, reason="needs Blender's bpy (or RTC_BLENDER_PYTHON)")]


def match(expected: list[np.ndarray], found: list[np.ndarray], what: str):
    """Same count, and a one-to-one pairing with equal matrices (greedy; tolerance 1e-4)."""
    assert len(found) == len(expected), f'{what}: {len(found)} in Blender, {len(expected)} in USD'
    left = list(found)
    for m in expected:
        errors = [np.abs(np.asarray(f) - m).max() for f in left]
        k = int(np.argmin(errors))
        assert errors[k] < 1e-4, f'{what}: no Blender object at\n{np.round(m, 4)}'
        left.pop(k)


@pytest.fixture(scope='module', params=['bunnies', 'gallery'])
def compiled(request, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp('blender') / f'{request.param}.usda'
    r = CliRunner().invoke(compile_cmd, [str(REPO / 'scenes' / f'{request.param}.xml'), '-o', str(out)],
                           catch_exceptions=False)
    assert r.exit_code == 0, r.output
    return out


def usd_census(path: Path) -> dict:
    stage = Usd.Stage.Open(str(path))
    prims = list(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
    gprims = [p for p in prims if p.IsA(UsdGeom.Gprim)]
    return dict(
        stage=stage,
        gprims=gprims,
        plain_gprims=[p for p in gprims if not p.IsInstanceProxy()],
        instances=[p for p in prims if p.IsInstance()],
        prototypes=stage.GetPrototypes(),
        lights=[p for p in prims if p.HasAPI(UsdLux.LightAPI)],
        cameras=[p for p in prims if p.IsA(UsdGeom.Camera)])


def test_expanded_import_matches(compiled):
    """support_scene_instancing=False: every gprim (instances expanded) is a mesh object."""
    usd, data = usd_census(compiled), blender_import(compiled, instancing=False)
    objs = data['objects']
    meshes = [o for o in objs if o['type'] == 'MESH']
    match([world(p) for p in usd['gprims']], [o['matrix'] for o in meshes], 'meshes')
    # a constant DomeLight (the course background) becomes Blender's world, not a light object
    lights = [p for p in usd['lights'] if not p.IsA(UsdLux.DomeLight)]
    match([world(p) for p in lights], [o['matrix'] for o in objs if o['type'] == 'LIGHT'], 'lights')
    match([world(p) for p in usd['cameras']], [o['matrix'] for o in objs if o['type'] == 'CAMERA'], 'cameras')
    # every gprim is a Mesh (course spheres, boxes and cylinders too: Blender drops bindings on
    # implicit shapes), so every one comes in with its material
    assert all(p.IsA(UsdGeom.Mesh) for p in usd['gprims'])
    want = sorted(UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()[0].GetPrim().GetName()
                  for p in usd['gprims'])
    got = sorted(m for o in meshes for m in o['materials'] if m)
    assert got == want


def test_instanced_import_matches(compiled):
    """Blender's default (support_scene_instancing=True): USD instances -> collection instances."""
    usd, data = usd_census(compiled), blender_import(compiled, instancing=True)
    objs = data['objects']
    empties = [o for o in objs if o['instance_type'] == 'COLLECTION']
    match([world(p) for p in usd['instances']], [o['matrix'] for o in empties], 'instances')
    assert len({o['instance_collection'] for o in empties}) == len(usd['prototypes'])
    in_scene = [o for o in objs if o['type'] == 'MESH' and 'Scene Collection' in o['collections']]
    match([world(p) for p in usd['plain_gprims']], [o['matrix'] for o in in_scene], 'plain meshes')


def _compile(source: Path, out: Path) -> Path:
    r = CliRunner().invoke(compile_cmd, [str(source), '-o', str(out)], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    return out


VIEW_SCENES = ['scenes/gallery.xml', 'scenes/ellipsoids.xml', 'scenes/shaders.xml', 'scenes/cylinder.xml',
               'corpus:scenes_B/threeEggs.xml', 'corpus:scenes_A/mirrorScene01.xml']


@pytest.mark.parametrize('scene', VIEW_SCENES)
def test_blender_shows_each_gprims_bound_colour_and_the_background(scene, tmp_path):
    """Per gprim (instance proxies included): Blender's base colour equals the diffuse colour of
    the material usd-core says is bound (placements that override their prototype's shader
    included); Blender's world colour equals the course background."""
    source = COURSE_CORPUS / scene[7:] if scene.startswith('corpus:') else REPO / scene
    if not source.is_file():
        pytest.skip(f'{source} not found (set RTC_SHARED)')
    view = compare(_compile(source, tmp_path / 'scene.usda'))
    wrong = [row for row in view['gprims'] if not (row[3] and agrees(row[1], row[2]))]
    assert view['gprims'] and wrong == []
    want, got = view['background']
    assert want is not None and agrees(want, got)
