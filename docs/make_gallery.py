"""Render the README gallery: every scene in scenes/ and a contact sheet of the course's own scenes.

    python docs/make_gallery.py [--spp 64] [--width 320] [--height 240]
    python docs/make_gallery.py --integrator path --spp 256        # docs/gallery/path/: the path tracer's view

Each image goes through the real command line (`rtc render scene.xml -o docs/gallery/NAME.png`),
so the gallery is also an end-to-end check that every example scene compiles and renders.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / 'docs' / 'gallery'
COURSE = Path(os.environ.get('RTC_SHARED', ROOT.parent / 'shared')) / 'corpus' / 'course'


def render(scene: Path, out: Path, width: int, height: int, spp: int, *extra: str) -> float:
    cmd = [sys.executable, '-m', 'rtc.cli', 'render', str(scene), '-o', str(out), '--width', str(width),
           '--height', str(height), '--spp', str(spp), '-q', *extra]
    subprocess.run(cmd, check=True)
    return out.stat().st_size


def contact_sheet(images: list[Path], out: Path, columns: int) -> None:
    tiles = [oiio.ImageBuf(str(p)).get_pixels(oiio.FLOAT)[..., :3] for p in images]
    h, w = tiles[0].shape[:2]
    rows = -(-len(tiles) // columns)
    sheet = np.zeros((rows * h, columns * w, 3), np.float32)
    for k, t in enumerate(tiles):
        r, c = divmod(k, columns)
        sheet[r * h:(r + 1) * h, c * w:(c + 1) * w] = t[:h, :w]
    oiio.ImageBuf(np.ascontiguousarray(sheet)).write(str(out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--course', action='store_true', help='also render the course scenes (contact sheet)')
    ap.add_argument('--integrator', choices=['cook', 'path'], default=None,
                    help='path: every scene with the path tracer, sRGB-encoded, into docs/gallery/path/')
    ap.add_argument('--course-look', action='store_true',
                    help='only the "course look" row: course scenes as rtc renders them by default (the '
                         "course's linear 8-bit encoding and light semantics) beside sRGB-encoded")
    a = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    if a.course_look:
        course_look(a.spp)
        return
    out_dir, extra = OUT, ()
    if a.integrator == 'path':
        out_dir, extra = OUT / 'path', ('--integrator', 'path', '--encoding', 'srgb')
        out_dir.mkdir(exist_ok=True)
    scenes = sorted((ROOT / 'scenes').glob('*.xml'))
    if a.integrator == 'path':                   # USD examples of what only the path tracer computes
        scenes += sorted((ROOT / 'scenes').glob('*.usda'))
    for scene in scenes:
        out = out_dir / f'{scene.stem}.png'
        print(f'{scene.name} -> {out.relative_to(ROOT)} ({render(scene, out, a.width, a.height, a.spp, *extra)} bytes)')
    if a.integrator == 'path':
        return
    if a.course and COURSE.exists():
        tmp = OUT / 'course'
        tmp.mkdir(exist_ok=True)
        done = []
        for scene in sorted(COURSE.glob('scenes_*/*.xml')):
            out = tmp / f'{scene.stem}.png'
            render(scene, out, 160, 120, max(4, a.spp // 4))
            done.append(out)
        contact_sheet(done, OUT / 'course-scenes.png', columns=6)
        for p in done:
            p.unlink()
        tmp.rmdir()
        print(f'{len(done)} course scenes -> docs/gallery/course-scenes.png')


COURSE_LOOK = ('scenes_B/threeEggs.xml', 'scenes_B/areaLight.xml', 'scenes_A/simpleTwoSpheres.xml')


def course_look(spp: int) -> None:
    """docs/gallery/course-look.png: per course scene (a row), rtc's default render (linear 8-bit
    values, course light semantics in cook) and the same render sRGB-encoded."""
    tmp = OUT / 'course-look'
    tmp.mkdir(exist_ok=True)
    done = []
    for rel in COURSE_LOOK:
        scene = COURSE / rel
        for look, extra in (('course', ()), ('srgb', ('--encoding', 'srgb'))):
            out = tmp / f'{scene.stem}-{look}.png'
            render(scene, out, 240, 180, spp, *extra)
            done.append(out)
    contact_sheet(done, OUT / 'course-look.png', columns=2)
    for p in done:
        p.unlink()
    tmp.rmdir()
    print(f'{len(COURSE_LOOK)} course scenes -> docs/gallery/course-look.png')


if __name__ == '__main__':
    main()
