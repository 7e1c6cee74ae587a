"""The generated benchmark scenes are what they claim to be (a benchmark of an invisible scene measures
nothing): the PointInstancer of benchmarks/gen_instancing.py stands its tori upright on the ground,
turned about +y only, and they are seen and lit."""
import sys
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom

from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.usd.stage import read_stage

from benchmarks import gen_instancing


def test_point_instancer_tori_stand_upright_and_are_visible(tmp_path):
    path = str(tmp_path / 'pim.usda')
    gen_instancing.write_point_instancer_mesh(16, path, tris=400)
    stage = Usd.Stage.Open(path)
    pi = UsdGeom.PointInstancer(stage.GetPrimAtPath('/World/Scatter'))
    xf = np.array(pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default()))
    s = 0.35 * 200.0 / 4.0
    assert xf.shape == (16, 4, 4)
    assert np.allclose(xf[:, 1, :3], [0.0, s, 0.0], rtol=1e-6)            # y axis kept: upright, no flip
    assert np.allclose(np.linalg.det(xf[:, :3, :3]), s ** 3, rtol=1e-5)     # rotations, no mirror
    desc = read_stage(path)
    img = render(desc, RenderOptions(width=48, height=36, spp=2)).image
    red = (img[..., 0] > 1.5 * img[..., 1]) & (img[..., 0] > 0.05)          # the red tori, lit
    assert 0.05 < red.mean() < 0.95


def test_the_rect_image_stages_are_lit_by_their_imaged_rects(tmp_path):
    """benchmarks/bench_rect_images.py's stages: each rect light has its image and faces the scene (the first draft
    of the window faced away, and both of its variants measured the dome alone): the image is brighter with the
    rects than without them, several times over."""
    from benchmarks import bench_rect_images
    from rtc.renderer import description as D
    for name in ('window', 'sign', 'panels'):
        desc = read_stage(str(bench_rect_images.stage(tmp_path, name)))
        rects = [light for light in desc.lights if light.type == D.RECT]
        assert rects and all(light.texture >= 0 for light in rects), name
        lit = render(desc, RenderOptions(width=40, height=30, spp=4, integrator='path', max_depth=2)).image.mean()
        for light in rects:
            light.radiance = (0.0, 0.0, 0.0)
        dark = render(desc, RenderOptions(width=40, height=30, spp=4, integrator='path', max_depth=2)).image.mean()
        assert lit > 3.0 * dark + 1e-3, (name, lit, dark)
