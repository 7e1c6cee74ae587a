"""Our compiled USD in Blender's USD importer (issue #6; optional: `pytest -m interop`, needs the
`interop` extra, Blender as a Python module `bpy` 4.5).

Blender imports in a child process (blender_import.py).  Against the composed stage read with
usd-core, we check: the same number of mesh objects as gprims (instance proxies expanded) with the
same world transforms; with Blender's scene instancing, one collection-instance empty per USD
instance with the instance's world transform and one collection per prototype; the same lights
and cameras at the same places; and, for Mesh gprims, the bound material.  Blender converts the
Y-up stage to Z-up by rotating the root +90 degrees about X, so Blender's matrix_world equals
``Rx(90) @ M_usd`` (column-vector form).  Pitfalls found are described in README.md ("Using rtc with other USD tools").
"""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Usd, UsdGeom, UsdLux, UsdShade

from rtc.compiler.cli import compile_cmd

from tests.interop.interop_helpers import REPO

pytestmark = [pytest.mark.interop,
              pytest.mark.skipif(importlib.util.find_spec('bpy') is None, reason="needs the 'interop' extra (bpy)")]
HERE = Path(__file__).parent
Y_UP_TO_Z_UP = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)


def blender_import(usd: Path, instancing: bool) -> dict:
    r = subprocess.run([sys.executable, str(HERE / 'blender_import.py'), str(usd), '1' if instancing else '0'],
                       capture_output=True, text=True, timeout=600)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith('JSON')]
    assert r.returncode == 0 and lines, r.stderr[-3000:]
    data = json.loads(lines[0][4:])
    assert data['result'] == ['FINISHED']
    return data


def world(prim) -> np.ndarray:
    """USD world matrix in column-vector form, converted to Blender's Z-up world."""
    return Y_UP_TO_Z_UP @ np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T


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
    match([world(p) for p in usd['lights']], [o['matrix'] for o in objs if o['type'] == 'LIGHT'], 'lights')
    match([world(p) for p in usd['cameras']], [o['matrix'] for o in objs if o['type'] == 'CAMERA'], 'cameras')
    # materials on Mesh gprims (Blender drops bindings on implicit shapes, see README.md ("Using rtc with other USD tools"))
    want = sorted(UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()[0].GetPrim().GetName()
                  for p in usd['gprims'] if p.IsA(UsdGeom.Mesh))
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
