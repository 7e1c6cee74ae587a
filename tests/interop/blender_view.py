"""What Blender's USD importer shows of a stage, gprim by gprim, against usd-core (issue 14).

`compare(usd_path)` imports the file with Blender 5 (`blender_import.py` in a child process, scene
instancing on as Blender's default) and pairs every gprim usd-core composes (instance proxies
included) with the Blender mesh that shows it: a plain gprim with the mesh named after it (or
at its world matrix); a gprim inside an instance with the mesh of the collection that the
instance's empty (named after the instance) instances.  It returns, per gprim, the diffuse colour of the material usd-core says is
bound (its UsdPreviewSurface `diffuseColor`; None when a texture drives it) and Blender's base
colour, and the background colour against Blender's world colour.

The Python that has `bpy` is the current one, or `RTC_BLENDER_PYTHON` (bpy 5 pins numpy < 2, so
it usually lives in its own virtual environment).
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom, UsdLux, UsdShade

HERE = Path(__file__).parent
Y_UP_TO_Z_UP = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
TOLERANCE = 1e-5


def blender_python() -> str | None:
    """The interpreter to run Blender's importer in, or None when there is none."""
    other = os.environ.get('RTC_BLENDER_PYTHON')
    if other:
        return other if Path(other).is_file() else None
    return sys.executable if importlib.util.find_spec('bpy') is not None else None


def blender_import(usd: Path, instancing: bool) -> dict:
    r = subprocess.run([blender_python(), str(HERE / 'blender_import.py'), str(usd), '1' if instancing else '0'],
                       capture_output=True, text=True, timeout=900)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith('JSON')]
    assert r.returncode == 0 and lines, r.stderr[-3000:]
    data = json.loads(lines[0][4:])
    assert data['result'] == ['FINISHED']
    return data


def world(prim) -> np.ndarray:
    """USD world matrix in column-vector form, converted to Blender's Z-up world."""
    return Y_UP_TO_Z_UP @ np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T


def bound_diffuse(prim) -> tuple | None:
    """The diffuseColor of the UsdPreviewSurface of the material bound to `prim` (None: textured)."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not material:
        return ('unbound',)
    shader = material.ComputeSurfaceSource()[0]
    colour = shader.GetInput('diffuseColor')
    if colour and colour.HasConnectedSource():
        return None
    value = colour.Get() if colour else None
    return tuple(float(x) for x in (value if value is not None else (0.18, 0.18, 0.18)))


def background(stage) -> tuple | None:
    """The colour of the constant DomeLight (course background), or None."""
    for prim in stage.Traverse():
        if prim.IsA(UsdLux.DomeLight) and not UsdLux.DomeLight(prim).GetTextureFileAttr().Get():
            light = UsdLux.DomeLight(prim)
            return tuple(float(c) * float(light.GetIntensityAttr().Get()) for c in light.GetColorAttr().Get())
    return None


def _named(objects: list[dict], name: str, matrix: np.ndarray) -> dict | None:
    """The object Blender named after the prim (its importer keeps prim names; compiled stages
    have unique ones), else the one at the same world matrix.  Not by matrix first: Blender's
    objects have no shear, so a sheared placement (rotate, non-uniform scale, rotate) shows at
    another matrix (see README.md, "Using rtc with other USD tools")."""
    same = [o for o in objects if o['name'] == name]
    return same[0] if len(same) == 1 else _nearest(objects, matrix)


def _nearest(objects: list[dict], matrix: np.ndarray) -> dict | None:
    if not objects:
        return None
    errors = [np.abs(np.asarray(o['matrix']) - matrix).max() for o in objects]
    k = int(np.argmin(errors))
    return objects[k] if errors[k] < 1e-4 else None


def _instance_of(prim):
    while prim and not prim.IsInstance():
        prim = prim.GetParent()
    return prim


def compare(usd: Path) -> dict:
    """{'gprims': [(path, usd colour, blender colour)], 'background': (usd, blender)}."""
    stage = Usd.Stage.Open(str(usd))
    data = blender_import(usd, instancing=True)
    objects, colours = data['objects'], data['materials']
    empties = [o for o in objects if o['instance_type'] == 'COLLECTION']
    plain = [o for o in objects if o['type'] == 'MESH' and 'Scene Collection' in o['collections']]
    rows = []
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()):
        if not prim.IsA(UsdGeom.Gprim):
            continue
        if prim.IsInstanceProxy():
            instance = _instance_of(prim)
            empty = _named(empties, instance.GetName(), world(instance))
            meshes = [o for o in objects if o['type'] == 'MESH' and empty and
                      empty['instance_collection'] in o['collections']]
            shown = meshes[0] if len(meshes) == 1 else None
        else:
            shown = _named(plain, prim.GetName(), world(prim))
        got = None
        if shown is not None and shown['materials'] and shown['materials'][0]:
            got = colours.get(shown['materials'][0])
        rows.append((str(prim.GetPath()), bound_diffuse(prim), None if got is None else tuple(got),
                     shown is not None))
    return dict(gprims=rows, background=(background(stage), data['world']))


def agrees(want, got) -> bool:
    if want is None or got is None:
        return want is None and got is None
    return len(want) == len(got) and max(abs(a - b) for a, b in zip(want, got)) <= TOLERANCE
