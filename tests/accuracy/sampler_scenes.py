"""Four small hand-built scenes, each isolating one integrand the samplers should stratify, and the
measurement of their convergence slopes (used by test_sampler_quality.py and for the table in
benchmarks/RESULTS.md, "Speed against error"):

* soft_shadow   - penumbra of a straight occluder edge under a square area light (2D light sample);
* depth_of_field - a defocused emissive edge (4D: pixel x lens, coupled);
* glossy        - the course's glossy reflection (2D square perturbation) of an emissive edge;
* aa_edges      - antialiased silhouette of a black ellipsoid on white (2D pixel sample).

    /work/venv/bin/python tests/accuracy/sampler_scenes.py [--max-spp 256 --seeds 4 --size 32]
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np


from rtc.renderer import description as D  # noqa: E402
from rtc.renderer.host.converge import SAMPLERS, measure, render_reference, slopes, spp_sequence, summarize  # noqa: E402
from rtc.renderer.host.render import RenderOptions, Renderer                   # noqa: E402

from tests.renderer.handmade import look_at, ortho_down, quad, rect_light, scene, static_instances, translate  # noqa: E402

GLOW = D.Material('/glow', model=D.PREVIEW_SURFACE, diffuse=(0, 0, 0), emission=(1.0, 1.0, 1.0))
LAMBERT = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.7, 0.7, 0.7))
BLACK = D.Material('/black', model=D.LAMBERTIAN, diffuse=(0.0, 0.0, 0.0))


def _rect(x0, x1, z0, z1, y, material, path):
    pts = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return D.Mesh(path, points=pts, triangles=np.array([[0, 2, 1], [0, 3, 2]], np.int32), material=material)


def soft_shadow(n):
    """Plane y=0 lit by a 1x1 light at y=3; a half-plane occluder (x<0.2) at y=2 casts a penumbra across
    the view; the camera looks down from y=1, below the occluder, so only the penumbra varies."""
    occ = _rect(-20, 0.2, -20, 20, 2.0, 0, '/occ')
    return scene([D.Container('/', meshes=[quad(40.0), occ])], [LAMBERT],
                 [rect_light((0, 3, 0), 1.0, 1.0, (3, 3, 3))], ortho_down(y=1.0, width=2.5), width=n, height=n)


def depth_of_field(n):
    """An emissive half-plane with a diagonal edge, far behind the plane of focus."""
    pts = np.array([[-50, -50, -12], [50, -50, -12], [-50, 50, -12]], float)
    tri = D.Mesh('/edge', points=pts, triangles=np.array([[0, 1, 2]], np.int32), material=0)
    cam = D.Camera('/cam', matrix=look_at((0, 0, 0), (0, 0, -1)), focal_length=1.0, horizontal_aperture=1.0,
                   vertical_aperture=1.0, lens_radius=0.4, focus_distance=3.0)
    return scene([D.Container('/', meshes=[tri])], [GLOW], [], cam, width=n, height=n)


def glossy(n):
    """A glossy (course Blinn-Phong mirrored, roughness 0.3) floor reflecting an emissive wall whose
    bright half ends at an edge; seen from above at 45 degrees."""
    gl = D.Material('/glossy', model=D.BLINN_PHONG_MIRRORED, diffuse=(0, 0, 0), mirror_coef=1.0, roughness=0.3)
    floor = quad(40.0, material=0, path='/floor')
    wall = D.Mesh('/wall', points=np.array([[-20, 0, -2], [0.3, 0, -2], [0.3, 6, -2], [-20, 6, -2]], float),
                  triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=1)
    cam = D.Camera('/cam', matrix=look_at((0, 1.5, 1.5), (0, 0, 0)), focal_length=1.0, horizontal_aperture=0.8,
                   vertical_aperture=0.8)
    return scene([D.Container('/', meshes=[floor, wall])], [gl, GLOW], [], cam, width=n, height=n)


def aa_edges(n):
    """Black ellipsoid on white, orthographic: only the pixel integral has edges."""
    m = np.array([[0.5, 0, 0, 0], [0, 1.5, 0, 1.5], [0, 0, 1, -4], [0, 0, 0, 1]], float)
    cont = D.Container('/proto', spheres=[D.Sphere('/proto/s', 1.0, np.eye(4), material=0)])
    cam = D.Camera('/cam', matrix=translate(0, 1.5, 10), projection='orthographic', horizontal_aperture=3.2,
                   vertical_aperture=3.2)
    return scene([cont], [BLACK], [], cam, instances=static_instances(matrices=[m]), width=n, height=n,
                 background=(1, 1, 1))


SCENES = {'soft_shadow': soft_shadow, 'depth_of_field': depth_of_field, 'glossy': glossy, 'aa_edges': aa_edges}


def measure_scene(name, size=32, max_spp=64, min_spp=4, seeds=4, samplers=SAMPLERS, ref_factor=16):
    """-> (summary rows, {sampler: (slope vs spp, slope vs seconds)}) with a box filter (the pixel
    integral is then exactly the pixel area, which keeps the pixel dimensions' edges sharp)."""
    base = RenderOptions(filter='box', pass_seconds=1e9)
    with Renderer(SCENES[name](size)) as r:
        ref = render_reference(r, base, ref_factor * max_spp, chunks=8)
        pts = measure(r, ref, base, samplers, spp_sequence(max_spp, min_spp), seeds)
    summ = summarize(pts)
    return summ, slopes(summ, 'rmse', min_spp)


def main(argv=None):
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--max-spp', type=int, default=256)
    ap.add_argument('--min-spp', type=int, default=4)
    ap.add_argument('--seeds', type=int, default=4)
    ap.add_argument('--size', type=int, default=32)
    a = ap.parse_args(argv)
    rows = {}
    for name in SCENES:
        summ, fit = measure_scene(name, a.size, a.max_spp, a.min_spp, a.seeds)
        rows[name] = (summ, fit)
        print(name, {k: round(v[0], 3) for k, v in fit.items()}, flush=True)
    print(f'\n| scene | ' + ' | '.join(SAMPLERS) + ' |')
    print('|---|' + '---|' * len(SAMPLERS))
    for name, (summ, fit) in rows.items():
        cells = []
        for s in SAMPLERS:
            last = [x for x in summ if x.sampler == s][-1]
            cells.append(f'{fit[s][0]:+.2f} ({last.rmse:.2e})')
        print(f'| {name} | ' + ' | '.join(cells) + ' |')
    print(f'\nslope of RMSE vs spp over {a.min_spp}..{a.max_spp} spp (RMSE at {a.max_spp} spp), '
          f'{a.size}x{a.size}, {a.seeds} seeds, box filter, reference 16 x max spp (sobol, 8 seeds)')


if __name__ == '__main__':
    main()
