"""Texture memory: the bytes a scene's textures take in the kernels' tables (`SceneData.tex_data` float32 and
`tex_bytes` uint8), with 8-bit images kept as their bytes (`description.BytePixels`) against the same textures as
float32 values (what rtc stored before), and the read + build time of each.

    python benchmarks/bench_texture_memory.py scenes/emitters.usda scenes/lights.usda [--rounds 3]
"""
from __future__ import annotations

import argparse
import statistics
import time

from rtc.renderer.description import BytePixels, float_textures
from rtc.renderer.host.build import build
from rtc.renderer.usd.stage import read_stage


def _table_bytes(desc) -> tuple[int, float]:
    t0 = time.perf_counter()
    built = build(desc)
    seconds = time.perf_counter() - t0
    n = built.data.tex_data.nbytes + built.data.tex_bytes.nbytes + built.data.tex_lut.nbytes
    built.close()
    return n, seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--rounds', type=int, default=3)
    a = ap.parse_args()
    print('| scene | 8-bit textures | texel memory, bytes kept | as float32 | ratio | build, bytes / floats |')
    print('|---|---|---|---|---|---|')
    for scene in a.scenes:
        desc = read_stage(scene)
        eight = sum(isinstance(t.pixels, BytePixels) + sum(isinstance(p, BytePixels) for p in t.tiles)
                    for t in desc.textures)
        floats = float_textures(desc)
        kept, flt, tb, tf = 0, 0, [], []
        for _ in range(a.rounds):                    # alternating, medians
            kept, s = _table_bytes(desc)
            tb.append(s)
            flt, s = _table_bytes(floats)
            tf.append(s)
        print(f'| `{scene}` | {eight} of {len(desc.textures)} (tiles counted) | {kept / 2**20:.2f} MiB | '
              f'{flt / 2**20:.2f} MiB | {kept / flt:.3f}x | {statistics.median(tb):.3f} s / '
              f'{statistics.median(tf):.3f} s |')


if __name__ == '__main__':
    main()
