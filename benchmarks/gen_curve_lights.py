"""Stages lit by emissive curves, for measuring curve segments as lights of the path integrator (`ab_noise.py`
against a revision where they were found by BSDF rays alone):

* ``tube.usda``: one thick, tapering, wavy cubic tube (widths 0.1-0.8) above a diffuse floor under a dim dome;
* ``neon.usda``: a thin cubic tube (width 0.06) before a diffuse wall, over a rough metal floor (roughness 0.25);
* ``wire.usda``, ``zigzag.usda``: the same two with linear curves (Embree's round linear curves: cones with round
  joints and ends) through a zigzag of six points;
* ``beads.usda``: a string of beads, a linear curve through nine points along an arc whose widths alternate 0.4 and
  0.08 (short cones between large round joints: the joints, lights of their own, are most of its light; over a rough
  metal floor: ``beads_metal.usda``).

    python benchmarks/gen_curve_lights.py OUT_DIR
    python benchmarks/ab_noise.py OUT_DIR/tube.usda OUT_DIR/neon.usda --base REV --integrator path \\
        --width 160 --height 120 --spp 16 --ref-spp 256 --seeds 3 --max-depth 4
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

WAVY = [(-1.5, 0.8, 0.0), (-0.5, 1.6, 0.5), (0.5, 0.3, -0.5), (1.5, 1.0, 0.2)]
NEON = [(-1.5, 0.3, -1.0), (-0.5, 1.8, -1.0), (0.5, 0.2, -1.0), (1.5, 1.5, -1.0)]
ZIGZAG = [(-1.5, 0.5, 0.2), (-0.9, 1.1, -0.3), (-0.3, 0.4, 0.3), (0.3, 1.15, -0.2), (0.9, 0.45, 0.4), (1.5, 1.0, 0.0)]


def _material(st, path: str, **inputs) -> UsdShade.Material:
    mat = UsdShade.Material.Define(st, path)
    sh = UsdShade.Shader.Define(st, path + '/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    for name, value in inputs.items():
        sh.CreateInput(name, Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else
                       Sdf.ValueTypeNames.Float).Set(value)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _quad(st, path: str, points, material) -> None:
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def stage(points, widths, floor: dict, wall: bool, kind: str = 'cubic') -> Usd.Stage:
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    _quad(st, '/World/Floor', [(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)],
          _material(st, '/World/FloorMat', **floor))
    if wall:
        _quad(st, '/World/Wall', [(-4, 0, -1.3), (-4, 4, -1.3), (4, 4, -1.3), (4, 0, -1.3)],
              _material(st, '/World/WallMat', diffuseColor=(0.7, 0.7, 0.7), roughness=0.9))
    tube = UsdGeom.BasisCurves.Define(st, '/World/Tube')
    tube.CreateTypeAttr(kind)
    tube.CreateBasisAttr('bezier')
    tube.CreatePointsAttr(points)
    tube.CreateCurveVertexCountsAttr([len(points)])
    tube.CreateWidthsAttr(widths)
    tube.SetWidthsInterpolation(UsdGeom.Tokens.vertex if len(widths) > 1 else UsdGeom.Tokens.constant)
    UsdShade.MaterialBindingAPI.Apply(tube.GetPrim()).Bind(
        _material(st, '/World/Glow', diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(4.0, 3.0, 2.0)))
    UsdLux.DomeLight.Define(st, '/World/Sky').CreateIntensityAttr(0.05)
    cam = UsdGeom.Camera.Define(st, '/World/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 3, 5))
    cam.AddRotateXOp().Set(-30.0)
    return st


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('out', type=Path)
    out = ap.parse_args().out
    out.mkdir(parents=True, exist_ok=True)
    stage(WAVY, [0.1, 0.6, 0.3, 0.8], dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.9), False).Export(
        str(out / 'tube.usda'))
    stage(NEON, [0.06], dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.25, metallic=1.0), True).Export(
        str(out / 'neon.usda'))
    stage(ZIGZAG, [0.1, 0.5, 0.2, 0.6, 0.3, 0.15], dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.9), False,
          'linear').Export(str(out / 'wire.usda'))
    stage([(x, y, -1.0) for x, y, _ in ZIGZAG], [0.06], dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.25,
                                                             metallic=1.0), True, 'linear').Export(
        str(out / 'zigzag.usda'))
    arc = [(1.6 * math.sin(a), 0.9 + 0.5 * math.cos(a), 0.3 * math.sin(2 * a)) for a in np.linspace(-1.2, 1.2, 9)]
    beads = [0.4 if k % 2 == 0 else 0.08 for k in range(9)]
    stage(arc, beads, dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.9), False, 'linear').Export(
        str(out / 'beads.usda'))
    stage(arc, beads, dict(diffuseColor=(0.7, 0.7, 0.7), roughness=0.25, metallic=1.0), False, 'linear').Export(
        str(out / 'beads_metal.usda'))
    names = ("tube.usda", "neon.usda", "wire.usda", "zigzag.usda", "beads.usda", "beads_metal.usda")
    print(f'wrote {", ".join(str(out / n) for n in names)}')


if __name__ == '__main__':
    main()
