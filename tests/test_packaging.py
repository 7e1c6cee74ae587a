"""The distribution installs one import namespace, `rtc`: the CLI, rtc.compiler (compiler/),
rtc.renderer (renderer/) and the XML schema (schemas/scene.xsd), nothing else."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MAPPED = {'rtc': 'rtc', 'compiler': 'rtc/compiler', 'renderer': 'rtc/renderer'}


@pytest.fixture(scope='module')
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of the source tree without build products (a stale `build/` of an
    earlier wheel would add the files it still holds)."""
    out = tmp_path_factory.mktemp('wheel')
    src = tmp_path_factory.mktemp('src') / 'rtc'
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns('build', '*.egg-info', '.venv', '.git', '.identity',
                                                             '__pycache__', '.pytest_cache', '.hypothesis'))
    r = subprocess.run([sys.executable, '-m', 'pip', 'wheel', str(src), '--no-deps', '-q', '-w', str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    (path,) = out.glob('rtc-*.whl')
    return path


def test_the_wheel_holds_only_rtc_and_every_source(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split('/')[0] for n in names}
    assert tops == {'rtc', f'{wheel.name.split("-")[0]}-{wheel.name.split("-")[1]}.dist-info'}, tops
    expected = {f'{MAPPED[folder]}/{p.relative_to(REPO / folder).as_posix()}'
                for folder in MAPPED for p in (REPO / folder).rglob('*.py') if '__pycache__' not in p.parts}
    expected.add('rtc/schemas/scene.xsd')          # package data: the compiler validates against it
    expected |= {'rtc/schemas/plugInfo.json', 'rtc/schemas/generatedSchema.usda'}   # rtc's USD schemas
    assert expected <= set(names), sorted(expected - set(names))
    assert not [n for n in names if n.startswith('rtc/') and n not in expected], 'unexpected files in the wheel'


def _run(args, cwd, env=None, timeout=900):
    r = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)
    return r.returncode, r.stdout + r.stderr


@pytest.mark.slow
def test_a_fresh_install_imports_rtc_only(wheel, tmp_path):
    """A real fresh venv (no system site-packages), the wheel installed with its dependencies (pip's
    cache), run from a directory outside the source tree."""
    venv = tmp_path / 'venv'
    code, out = _run([sys.executable, '-m', 'venv', str(venv)], tmp_path)
    assert code == 0, out
    py, rtc = venv / 'bin' / 'python', venv / 'bin' / 'rtc'
    code, out = _run([str(py), '-m', 'pip', 'install', '-q', str(wheel)], tmp_path)
    assert code == 0, out[-3000:]
    env = {k: v for k, v in os.environ.items() if k not in ('PYTHONPATH', 'VIRTUAL_ENV')}
    code, out = _run([str(py), '-c', 'import compiler'], tmp_path, env)
    assert code != 0 and "No module named 'compiler'" in out, out
    code, out = _run([str(py), '-c', 'import renderer'], tmp_path, env)
    assert code != 0 and "No module named 'renderer'" in out, out
    code, out = _run([str(py), '-c', 'import rtc.compiler, rtc.renderer, rtc.renderer.host.render, rtc.cli; '
                                     'print(rtc.compiler.__file__)'], tmp_path, env)
    assert code == 0 and str(venv) in out, out
    code, out = _run([str(rtc), '--help'], tmp_path, env)
    assert code == 0 and 'compile' in out and 'render' in out, out
    # the schema is package data: a compile validates against it
    code, out = _run([str(rtc), 'compile', str(REPO / 'scenes' / 'dof.xml'), '-o', str(tmp_path / 'dof.usda')],
                     tmp_path, env)
    assert code == 0 and (tmp_path / 'dof.usda').is_file(), out
