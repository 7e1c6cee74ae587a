"""The path integrator's light tree alone: ns per `choose_lights` (a path vertex's walk, side samples
included) and per block of `importances`, in numba loops over the kernel's own functions.

    python benchmarks/bench_light_tree.py [STAGE ...] [--points 200000] [--rounds 7]

STAGE: USD files (default: the bright and the dominant stages of `bench_many_lights.py`: 1,000 lights
besides the main one).
The walks start at `--points` random points of the floor (y = 0, normal +y, x and z in [-12, 12]), each with
its own random u; the blocks' loop computes the importances of the tree's blocks in turn at such points,
into an array of float32 (as the walks do) and of doubles (as they did before 2026-12-05: LLVM vectorised
the loop half as wide).
Reported: the median of `--rounds` timed loops, the side samples a walk takes, and a checksum of the chosen
lights' probabilities (equal between two versions of the kernel when their choices are). To compare two
versions, run the script at each (`git stash` / `git checkout REV -- renderer/kernel`): the loops time the
kernel's functions alone, so the host's drift between runs is the noise; alternate the runs.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


@nb.njit(cache=False)
def _walks(L, P, U, choose_lights):
    s, sides = 0.0, 0
    for i in range(P.shape[0]):
        a, b, c = choose_lights(L, (P[i, 0], P[i, 1], P[i, 2]), (0.0, 1.0, 0.0), U[i])
        s += a[1]
        sides += (b[0] >= 0) + (c[0] >= 0)
    return s, sides


@nb.njit(cache=False)
def _blocks(tf, P, w, importances):
    s = 0.0
    nb_ = tf.shape[0]
    for i in range(P.shape[0]):
        importances(tf, i % nb_, (P[i, 0], P[i, 1], P[i, 2]), (0.0, 1.0, 0.0), w)
        s += w[i % w.shape[0]]
    return s


def _timed(fn, rounds: int) -> tuple[float, object]:
    out, ts = None, []
    for _ in range(rounds):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts), out


def measure(source, name: str, points: int, rounds: int) -> None:
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.kernel.light_tree import choose_lights, importances
    from rtc.renderer.kernel.tables import TREE_SLOTS
    from rtc.renderer.usd.stage import read_stage
    desc = read_stage(source)
    built = build(desc)
    try:
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
        rng = np.random.default_rng(1)
        P = np.column_stack([rng.uniform(-12, 12, points), np.zeros(points), rng.uniform(-12, 12, points)]) - built.origin
        U = rng.random(points)
        _walks(L, P[:8], U[:8], choose_lights)
        tw, (check, sides) = _timed(lambda: _walks(L, P, U, choose_lights), rounds)
        blocks = []
        for dtype in (np.float32, np.float64):        # (the kernels' walks store float32: `light_tree._stack_floats`)
            w = np.zeros(TREE_SLOTS, dtype)
            _blocks(L.tree_f, P[:8], w, importances)
            blocks.append(_timed(lambda: _blocks(L.tree_f, P, w, importances), rounds)[0] / points * 1e9)
        print(f'{name}: {L.n_bounded} lights in the tree, {L.tree_f.shape[0]} blocks; choose_lights '
              f'{tw / points * 1e9:.1f} ns a call ({sides / points:.3f} side samples a call, checksum {check:.9g}); '
              f'importances {blocks[0]:.1f} ns a block into float32, {blocks[1]:.1f} into doubles (medians of {rounds})')
    finally:
        built.close()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('stages', nargs='*')
    ap.add_argument('--points', type=int, default=200_000)
    ap.add_argument('--rounds', type=int, default=7)
    a = ap.parse_args(argv)
    if a.stages:
        for s in a.stages:
            measure(s, Path(s).name, a.points, a.rounds)
    else:
        from benchmarks.bench_many_lights import stage
        measure(stage(1000, 1.0), 'bright (1,000 lights)', a.points, a.rounds)
        measure(stage(1000, 0.02), 'dominant (1,000 lights)', a.points, a.rounds)
    return 0


if __name__ == '__main__':
    sys.exit(main())
