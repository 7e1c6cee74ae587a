"""Real files in, faithful files out (issue 14): the numbers the README quotes.

    python benchmarks/real_files.py                 # course scenes compiled, foreign USD read
    python benchmarks/real_files.py --blender       # + Blender 5's view of the compiled scenes

* every course scene of the shared corpus (`corpus/course/**/*.xml`) and of the gallery is compiled
  in memory: how many compile, with how many warnings;
* every USD file of `corpus/usd` that usd-core opens is read by rtc's stage reader: how many meshes
  it drops (a `skipped` entry naming a Mesh) and how many messages carry Python's own error text;
* with --blender (bpy 5 in this Python or in RTC_BLENDER_PYTHON): each compiled scene imported by
  Blender, gprim by gprim, Blender's base colour against usd-core's bound diffuse colour, and the
  world colour against the background (tests/interop/blender_view.py).
Prints Markdown tables.
"""
from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYTHON_TEXT = re.compile(r"object|len\(\)|Traceback|Error:|Exception|NoneType|not subscriptable")


def course_scenes(shared: Path) -> list[Path]:
    return sorted((shared / 'corpus' / 'course').rglob('*.xml')) + sorted((ROOT / 'scenes').glob('*.xml'))


def compile_census(scenes: list[Path]) -> list[tuple[str, str, int]]:
    from rtc.compiler.api import compile_to_stage
    from rtc.compiler.diagnostics import CompileError
    rows = []
    for path in scenes:
        try:
            _, diags = compile_to_stage(path, width=64, height=64)
            rows.append((path.name, 'compiled', len(diags)))
        except CompileError as exc:
            rows.append((path.name, 'error: ' + str(exc).splitlines()[0], len(exc.diagnostics)))
    return rows


def usd_census(shared: Path) -> tuple[int, int, int, int]:
    """(files read, files refused, meshes dropped, messages with Python error text)."""
    from pxr import Tf, Usd
    from rtc.renderer.errors import SceneError
    from rtc.renderer.usd.stage import read_stage
    read = refused = dropped = raw = 0
    for path in sorted((shared / 'corpus' / 'usd').rglob('*')):
        if path.suffix not in ('.usd', '.usda', '.usdc', '.usdz'):
            continue
        try:
            if Usd.Stage.Open(str(path)) is None:
                continue
        except Tf.ErrorException:
            continue
        try:
            desc = read_stage(path)
        except SceneError as exc:
            refused += 1
            raw += bool(PYTHON_TEXT.search(str(exc)))
            continue
        read += 1
        dropped += sum('Mesh' in s for s in desc.skipped)
        raw += sum(bool(PYTHON_TEXT.search(m)) for m in desc.skipped + desc.warnings if not m.startswith('USD: '))
    return read, refused, dropped, raw


def blender_census(scenes: list[Path]) -> list[tuple[str, int, int, str]]:
    sys.path.insert(0, str(ROOT))
    from tests.interop.blender_view import agrees, compare
    from rtc.compiler.api import compile_file
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in scenes:
            out = Path(tmp) / f'{path.stem}.usda'
            compile_file(path, out)
            view = compare(out)
            good = sum(1 for _, want, got, shown in view['gprims'] if shown and agrees(want, got))
            want, got = view['background']
            rows.append((path.name, len(view['gprims']), good,
                         'yes' if want is not None and agrees(want, got) else f'no ({want} vs {got})'))
    return rows


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('--shared', type=Path, default=ROOT.parent / 'shared')
    parser.add_argument('--blender', action='store_true')
    args = parser.parse_args()
    import os
    shared = Path(os.environ.get('RTC_SHARED', args.shared))
    scenes = course_scenes(shared)
    rows = compile_census(scenes)
    ok = sum(r[1] == 'compiled' for r in rows)
    print(f'course scenes compiled: {ok} of {len(rows)}')
    for name, status, n in rows:
        if status != 'compiled':
            print(f'  {name}: {status}')
    read, refused, dropped, raw = usd_census(shared)
    print(f'foreign USD: {read} read, {refused} refused, {dropped} meshes dropped, '
          f'{raw} messages with Python error text')
    if args.blender:
        print('\n| scene | gprims | Blender colour = bound colour | world = background |\n|---|---|---|---|')
        total = good = 0
        for name, n, g, bg in blender_census(scenes):
            total, good = total + n, good + g
            print(f'| {name} | {n} | {g} | {bg} |')
        print(f'| all | {total} | {good} | |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
