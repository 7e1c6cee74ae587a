"""Bit-identity of rendered images between two revisions of rtc (a structural change must not move a pixel).

    python benchmarks/identity.py --rev 7f10cee            # render at REV and at the working tree, compare
    python benchmarks/identity.py --rev 7f10cee --quick    # 2 scenes, 2 samplers

Every scene of the gallery (`scenes/*.xml`) and a sample of the shared course corpus is rendered through
each revision's own command line (`rtc render`, float32 EXR), for every sampler, with 1 and 2 threads, and
the pixels are compared bit for bit.  REV is exported with `git archive` to a temporary folder and run
from there (PYTHONPATH names that folder, so its own packages are imported, whatever their layout);
its images are cached under `benchmarks/.identity/REV/` so that later runs render only the working tree.
Exit status 0 when every image is identical, 1 otherwise.
`--snapshot` renders a copy of the working tree taken at start (laid out as the installed `rtc`
package), so that the sources can be edited while the comparison runs.
"""
from __future__ import annotations

import argparse
import itertools
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

ROOT = Path(__file__).resolve().parents[1]
SAMPLERS = ('independent', 'stratified', 'cmj', 'sobol')
THREADS = (1, 2)
CORPUS_SAMPLE = ('scenes_A/mirrorScene01.xml', 'scenes_A/boxSphereTest.xml', 'scenes_A/PhongExp.xml',
                 'scenes_B')     # scenes_B: its first scene in name order


def shared_dir() -> Path | None:
    for cand in (os.environ.get('RTC_SHARED'), ROOT.parent / 'shared', ROOT.parent.parent / 'shared'):
        if cand and (Path(cand) / 'corpus' / 'course').is_dir():
            return Path(cand)
    return None


def scenes(quick: bool) -> list[Path]:
    out = sorted((ROOT / 'scenes').glob('*.xml'))
    shared = shared_dir()
    if shared is not None:
        course = shared / 'corpus' / 'course'
        for item in CORPUS_SAMPLE:
            p = course / item
            if p.is_dir():
                p = sorted(p.glob('*.xml'))[0]
            if p.exists():
                out.append(p)
    return out[:2] if quick else out


def export(rev: str, dest: Path) -> Path:
    """REV's sources, importable from the returned folder.  Since the one-namespace layout (rtc/ beside
    compiler/ and renderer/, mapped into `rtc` by pyproject.toml) they are laid out as installed: with the
    raw tree on PYTHONPATH, `rtc` would come from it but `rtc.renderer` from the editable install's finder,
    i.e. from the working tree, and the comparison would compare the working tree with itself."""
    tree = dest / 'tree'
    if not tree.is_dir():
        tree.mkdir(parents=True)
        data = subprocess.run(['git', '-C', str(ROOT), 'archive', rev], check=True, capture_output=True).stdout
        with tempfile.TemporaryFile() as f:
            f.write(data)
            f.seek(0)
            tarfile.open(fileobj=f).extractall(tree, filter='data')
    if (tree / 'rtc' / '__init__.py').exists() and not (tree / 'rtc' / 'renderer').exists():
        laid = dest / 'installed'
        if not laid.is_dir():
            snapshot(laid, tree)
        return laid
    return tree


def snapshot(dest: Path, src: Path = ROOT) -> Path:
    """A copy of a source tree's packages laid out as installed: rtc/, rtc/compiler, rtc/renderer."""
    ignore = shutil.ignore_patterns('__pycache__', '*.pyc')
    shutil.copytree(src / 'rtc', dest / 'rtc', ignore=ignore)
    shutil.copytree(src / 'compiler', dest / 'rtc' / 'compiler', ignore=ignore)
    shutil.copytree(src / 'renderer', dest / 'rtc' / 'renderer', ignore=ignore)
    if (src / 'schemas').is_dir():             # compiler/schema.py finds them next to its package
        shutil.copytree(src / 'schemas', dest / 'rtc' / 'schemas')
    return dest


def render(tree: Path | None, scene: Path, sampler: str, threads: int, out: Path, size: int, spp: int):
    env = dict(os.environ)
    if tree is not None:
        env['PYTHONPATH'] = str(tree)
    # the renderer imported must be the tree's (a check that the comparison compares two versions)
    check = ''
    if tree is not None:
        mod = 'rtc.renderer' if (tree / 'rtc' / 'renderer').is_dir() else 'renderer'
        check = f'import os, {mod} as m; assert m.__file__.startswith({str(tree)!r}), m.__file__; '
    cmd = [sys.executable, '-c', check + 'import sys; from rtc.cli import main; sys.exit(main())', 'render', str(scene),
           '-o', str(out), '--width', str(size), '--spp', str(spp), '--sampler', sampler,
           '--threads', str(threads), '--seed', '7', '-q']
    if '--encoding' in subprocess.run(cmd[:3] + ['render', '--help'], env=env, capture_output=True,
                                      text=True).stdout:
        cmd += ['--encoding', 'linear']
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=str(tree or ROOT))
    if r.returncode != 0:
        raise RuntimeError(f'{scene.name} ({sampler}, {threads} threads) failed at {tree or "HEAD"}:\n{r.stderr}')


def pixels(path: Path) -> np.ndarray:
    img = oiio.ImageInput.open(str(path))
    a = img.read_image(oiio.FLOAT)
    img.close()
    return a


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--rev', required=True, help='the git revision to compare the working tree against')
    ap.add_argument('--quick', action='store_true')
    ap.add_argument('--size', type=int, default=64, help='image width (height keeps the aspect)')
    ap.add_argument('--spp', type=int, default=8)
    ap.add_argument('--rev-only', action='store_true', help='only render (and cache) the images of REV')
    ap.add_argument('--snapshot', action='store_true', help='render a copy of the working tree taken at start')
    a = ap.parse_args()
    sha = subprocess.run(['git', '-C', str(ROOT), 'rev-parse', '--short', a.rev], check=True,
                         capture_output=True, text=True).stdout.strip()
    cache = ROOT / 'benchmarks' / '.identity' / sha
    tree = export(sha, cache)
    samplers = SAMPLERS[-2:] if a.quick else SAMPLERS
    bad = n = 0
    with tempfile.TemporaryDirectory() as tmp:
        work = snapshot(Path(tmp) / 'snapshot') if a.snapshot else None
        for scene, sampler, threads in itertools.product(scenes(a.quick), samplers, THREADS):
            name = f'{scene.stem}-{sampler}-{threads}t-{a.size}-{a.spp}.exr'
            old = cache / name
            if not old.exists():
                render(tree, scene, sampler, threads, old, a.size, a.spp)
            if a.rev_only:
                continue
            new = Path(tmp) / name
            render(work, scene, sampler, threads, new, a.size, a.spp)
            po, pn = pixels(old), pixels(new)
            same = po.shape == pn.shape and np.array_equal(po.view(np.uint32), pn.view(np.uint32))
            n += 1
            if not same:
                bad += 1
                diff = float(np.abs(po - pn).max()) if po.shape == pn.shape else float('nan')
                print(f'DIFFERENT {name}: max |diff| {diff:.3g}')
    if a.rev_only:
        print(f'images of {sha} cached in {cache}')
        return 0
    print(f'{n - bad} of {n} images bit-identical to {sha}')
    return 0 if bad == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
