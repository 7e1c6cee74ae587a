"""The numba kernel cache is keyed on every renderer source file, so an edited callee never leaves a
stale cached kernel behind (numba itself only watches the kernel's own file)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

from rtc import renderer

PACKAGE = Path(renderer.__file__).resolve().parent


def cache_dir_of(package_root: Path, env: dict) -> str:
    code = 'import numba.core.config as c, rtc.renderer; print(c.CACHE_DIR)'
    out = subprocess.run([sys.executable, '-c', code], cwd=package_root, env=env, check=True,
                         capture_output=True, text=True)
    return out.stdout.strip()


def test_cache_directory_follows_the_sources(tmp_path):
    copy = tmp_path / 'tree'
    shutil.copytree(PACKAGE, copy / 'rtc' / 'renderer', ignore=shutil.ignore_patterns('__pycache__'))
    (copy / 'rtc' / '__init__.py').write_text('')
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    env.update(XDG_CACHE_HOME=str(tmp_path / 'cache'), PYTHONPATH=str(copy))
    first = cache_dir_of(copy, env)
    assert first.startswith(str(tmp_path / 'cache' / 'rtc' / 'numba'))
    assert cache_dir_of(copy, env) == first                         # unchanged sources: same cache
    shapes = copy / 'rtc' / 'renderer' / 'kernel' / 'shapes.py'     # a callee, not a kernel's own file
    shapes.write_text(shapes.read_text() + '\n# edited\n')
    assert cache_dir_of(copy, env) != first
    env['NUMBA_CACHE_DIR'] = str(tmp_path / 'explicit')               # an explicit choice wins
    assert cache_dir_of(copy, env) == str(tmp_path / 'explicit')
