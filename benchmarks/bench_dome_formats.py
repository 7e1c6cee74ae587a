"""What reading a dome image in another layout costs: the resampling into a lat-long image (`usd/dome_formats.py`),
against reading the stage with the same environment already stored as that lat-long image.

    python benchmarks/bench_dome_formats.py --rounds 5

For each layout and size an EXR is written (a smooth environment with a few bright spots, so that the files are not
constant), then, alternating in one process: `read_stage` of a stage whose DomeLight names it with its
`inputs:texture:format`, and of the same stage naming the lat-long image it is resampled into (written beforehand,
its size the resampled one's).  Printed: median seconds of each, their difference (the resampling), and the
resampled image's size and memory.
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
from pxr import Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer.usd import dome_formats
from rtc.renderer.usd.stage import read_stage

CASES = (('mirroredBall', (1024, 1024)), ('mirroredBall', (2048, 2048)), ('angular', (1024, 1024)),
         ('cubeMapVerticalCross', (2048, 1536)))


def _write(path: Path, pixels: np.ndarray) -> None:
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.HALF))
    out.write_image(np.ascontiguousarray(pixels, np.float32))
    out.close()


def _image(shape: tuple, rng: np.random.Generator) -> np.ndarray:
    h, w = shape
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    img = np.stack([1.0 + 0.5 * np.sin(7 * x), 1.0 + 0.5 * np.cos(5 * y), 0.8 + 0.2 * x * y], -1)
    for _ in range(5):
        cy, cx = rng.random(2)
        img += 50.0 * np.exp(-((y - cy) ** 2 + (x - cx) ** 2) * 4000.0)[..., None]
    return img.astype(np.float32)


def _stage(path: Path, fmt: str) -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Sphere.Define(stage, '/World/Ball')
    dome = UsdLux.DomeLight.Define(stage, '/World/Sky')
    dome.CreateTextureFileAttr(Sdf.AssetPath(str(path)))
    dome.CreateTextureFormatAttr(fmt)
    UsdGeom.Camera.Define(stage, '/World/Cam').AddTranslateOp().Set((0.0, 0.0, 5.0))
    return stage


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--rounds', type=int, default=5)
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, shape in CASES:
            src = Path(tmp) / f'{fmt}_{shape[1]}x{shape[0]}.exr'
            _write(src, _image(shape, rng))
            latlong = Path(tmp) / f'latlong_{fmt}_{shape[1]}x{shape[0]}.exr'
            h, w = dome_formats.latlong_size(shape, fmt)
            _write(latlong, _image((h, w), rng))
            times = {fmt: [], 'latlong': []}
            for _ in range(args.rounds):
                for name, path in ((fmt, src), ('latlong', latlong)):
                    t0 = time.perf_counter()
                    desc = read_stage(_stage(path, name))
                    times[name].append(time.perf_counter() - t0)
                    assert desc.textures[desc.lights[0].texture].pixels.shape[:2] == (h, w), name
            a, b = statistics.median(times[fmt]), statistics.median(times['latlong'])
            print(f'{fmt:22s} {shape[1]:5d} x {shape[0]:5d} -> lat-long {w} x {h} ({w * h * 12 / 2**20:.0f} MiB): '
                  f'read_stage {a:.3f} s, the lat-long file {b:.3f} s, resampling {a - b:.3f} s')


if __name__ == '__main__':
    main()
