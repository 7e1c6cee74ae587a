"""Fuzzing the stage reader: valid USD with odd values renders, or fails cleanly.

Sources: the USD corpus (shared/corpus/usd: Pixar's test files and other tools'; below 200 kB, usdz aside) and the
product's gallery (scenes/*.usda). Each case mutates a source's root layer (`usd_mutations.mutate`: odd values of an
attribute's own type, blocked values, time samples, retyped prims, deactivated prims, flipped instancing, retargeted
relationships and connections, bad xformOpOrders, schema attributes of the wrong type), writes it as a new layer
beside the source's own files (in a mirror of the tree made of symlinks, so its references, sublayers and textures
resolve as before) and renders it through `rtc render`'s click command at 8 x 6, 1 spp, with either integrator
(`catch_exceptions=False`: any exception fails the test with the mutations that caused it). The outcome must be exit
0 with an image (EXR) without NaN, or exit 2 with rtc's own message naming the file or a prim of the stage, no
traceback and no image.

Cases are drawn by `random.Random(seed)` (hypothesis' draws favour the simplest values, and a fuzzer wants the
others too): 200 seeds in the default run, 5,000 more in the slow run (`-m fuzz`: both).  They run in child processes
(this module as a script, 50 or 500 seeds each: `run_cases`), so that a crash of the renderer fails one test and names
its seed, with the command that runs it alone, instead of ending the test run.  (On 2026-12-06 two CI runs, all in one
process, died of a segmentation fault in the 5,000 without a seed to show; run so, it named seeds 2730 and 3394: a
light of infinite height or length, whose NaN shadow rays crashed Embree.  Fixed at both ends: `lights.py` reads
every input, `trace.traceable`.)
"""
from __future__ import annotations

import itertools
import json
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Sdf, Usd

from rtc.cli import main
from rtc.renderer.images import read_pixels

from tests.interop.interop_helpers import REPO, USD_CORPUS
from tests.interop.usd_mutations import mutate

ROOTS = {'corpus': USD_CORPUS, 'scenes': REPO / 'scenes'}
SOURCES = sorted((name, str(p.relative_to(root))) for name, root in ROOTS.items() if root.is_dir()
                 for p in root.rglob('*.usd*') if p.suffix in ('.usd', '.usda', '.usdc') and p.stat().st_size < 200_000)


_NUMBERS = itertools.count()


@pytest.fixture(scope='module')
def mirror(tmp_path_factory) -> Path:
    """A copy of each source tree whose directories are real and whose files are symlinks to the sources'."""
    if not SOURCES:
        pytest.skip('no USD sources')
    top = tmp_path_factory.mktemp('usd_fuzz')
    for name, root in ROOTS.items():
        for directory, _, files in os.walk(root):
            here = top / name / Path(directory).relative_to(root)
            here.mkdir(parents=True, exist_ok=True)
            for f in files:
                os.symlink(Path(directory) / f, here / f)
    return top


def check_outcome(mirror: Path, source: tuple[str, str], rng, integrator: str):
    path = mirror / source[0] / source[1]
    mutant = path.parent / f'_mutant{next(_NUMBERS)}.usda'       # a new layer each case: the source's is not edited
    layer = Sdf.Layer.CreateNew(str(mutant))
    layer.TransferContent(Sdf.Layer.FindOrOpen(str(path)))
    stage = Usd.Stage.Open(layer)
    log = mutate(rng, stage, rng.randint(1, 3))
    out = mirror / '_mutant.exr'                       # float: a NaN would show
    layer.Save()
    prims = {str(p.GetPath()) for p in stage.Traverse(Usd.PrimAllPrimsPredicate)}
    what = '\n'.join([f'{source[1]}, {integrator}:', *log])
    try:
        try:
            result = CliRunner().invoke(main, ['render', str(mutant), '-o', str(out), '--width', '8', '--height',
                                               '6', '--spp', '1', '--integrator', integrator], catch_exceptions=False)
        except Exception as exc:
            raise AssertionError(f'{what}\nraised {type(exc).__name__}: {exc}') from exc
        if result.exit_code == 0:
            pixels, _ = read_pixels(out)
            assert pixels.shape[:2] == (6, 8) and not np.isnan(pixels).any(), (what, pixels)
        else:
            assert result.exit_code == 2, (what, result.exit_code, result.output)
            message = result.output
            assert 'rtc: error:' in message and 'Traceback' not in message, (what, message)
            assert 'cannot open' not in message, (what, message)          # the mutant is valid USD
            assert mutant.name in message or any(p in message for p in prims if p != '/'), (what, message)
            assert not out.exists(), what
    finally:
        mutant.unlink(missing_ok=True)
        out.unlink(missing_ok=True)


def case(mirror: Path, seed: int):
    """Case `seed`: its source, mutations and integrator drawn by `random.Random(seed)`."""
    rng = random.Random(seed)
    check_outcome(mirror, rng.choice(SOURCES), rng, rng.choice(['path', 'cook']))


def run_cases(mirror: Path, first: int, stop: int) -> list[str]:
    """Cases [first, stop) in a child process (this module run as a script), so that a crash of the renderer names
    its seed and does not take the test run down with it; -> the failures' messages."""
    child = subprocess.run([sys.executable, '-m', 'tests.interop.test_usd_fuzz', str(mirror), str(first), str(stop)],
                           cwd=REPO, capture_output=True, text=True, timeout=3600)
    lines = child.stdout.splitlines()
    failures = [json.loads(line[5:]) for line in lines if line.startswith('fail ')]
    if child.returncode != 0:
        started = [int(line.split()[1]) for line in lines if line.startswith('case ')]
        seed = started[-1] if started else first
        failures.append(f'seed {seed}: the child process died (exit status {child.returncode}); alone: python -m '
                        f'tests.interop.test_usd_fuzz {mirror} {seed} {seed + 1}\n{child.stderr[-4000:]}')
    return failures


@pytest.mark.fuzz
@pytest.mark.parametrize('first', range(0, 200, 50))
def test_odd_values_render_or_fail_cleanly(mirror, first):
    failures = run_cases(mirror, first, first + 50)
    assert not failures, f'{len(failures)} of 50 cases failed:\n' + '\n\n'.join(failures[:3])


@pytest.mark.slow
@pytest.mark.fuzz
@pytest.mark.parametrize('first', range(200, 5200, 500))
def test_odd_values_render_or_fail_cleanly_5000(mirror, first):
    failures = run_cases(mirror, first, first + 500)
    assert not failures, f'{len(failures)} of 500 cases failed; the first:\n' + '\n\n'.join(failures[:3])


if __name__ == '__main__':                # the child of `run_cases`: mirror, first seed, stop
    os.environ.setdefault('RTC_KERNELS', 'general')          # as the test suite renders (tests/conftest.py)
    top, start, end = Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    for number in range(start, end):
        print(f'case {number}', flush=True)
        try:
            case(top, number)
        except AssertionError as exc:
            print('fail ' + json.dumps(f'seed {number}: {exc}'), flush=True)
