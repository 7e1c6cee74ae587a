"""Which integrator renders what: compiled course stages record rtc:integrator = cook, any other USD
renders with path, --integrator overrides, an unknown one is a usage error."""
import subprocess
import sys

import pytest
from pxr import Usd

from rtc.renderer.errors import RenderError
from rtc.renderer.options import DEFAULT_DEPTH, RenderOptions, resolve
from rtc.renderer import description as D
from rtc.renderer.usd.camera import read_render_settings


def _rtc(*args):
    return subprocess.run([sys.executable, '-m', 'rtc.cli', *args], capture_output=True, text=True)


def test_unknown_integrator_is_a_usage_error(tmp_path):
    p = _rtc('render', 'nothing.usda', '-o', str(tmp_path / 'x.exr'), '--integrator', 'whitted')
    assert p.returncode == 2
    assert "whitted" in p.stderr and 'Traceback' not in p.stderr


def test_defaults_resolve_per_integrator():
    s = D.RenderSettings()
    assert resolve(RenderOptions(), s).integrator == 'cook'           # hand-made descriptions
    assert resolve(RenderOptions(), s).max_depth == DEFAULT_DEPTH['cook'] == 4
    s.integrator = 'path'
    o = resolve(RenderOptions(), s)
    assert (o.integrator, o.max_depth) == ('path', 8)
    assert resolve(RenderOptions(integrator='cook'), s).integrator == 'cook'
    assert resolve(RenderOptions(max_depth=2), s).max_depth == 2
    s.integrator = 'whitted'                                         # an odd stage value: path
    assert resolve(RenderOptions(), s).integrator == 'path'
    with pytest.raises(RenderError, match='unknown light strategy'):
        resolve(RenderOptions(strategy='x'), s)
    with pytest.raises(RenderError, match='unknown integrator'):
        resolve(RenderOptions(integrator='x'), s)


def test_a_usd_stage_without_rtc_integrator_renders_with_path():
    assert read_render_settings(None, Usd.TimeCode.Default())[0].integrator == 'path'


def test_compiled_xml_records_cook(tmp_path):
    import os
    from pathlib import Path
    shared = Path(os.environ.get('RTC_SHARED', '/work/shared'))
    xml = shared / 'corpus' / 'course' / 'scenes_A' / 'boxSphereTest.xml'
    if not xml.exists():
        pytest.skip('course corpus not available')
    out = tmp_path / 'scene.usda'
    p = _rtc('compile', str(xml), '-o', str(out))
    assert p.returncode == 0, p.stderr
    stage = Usd.Stage.Open(str(out))
    prim = stage.GetPrimAtPath('/Render/Settings')
    assert prim.GetAttribute('rtc:integrator').Get() == 'cook'
    assert read_render_settings(prim, Usd.TimeCode.Default())[0].integrator == 'cook'
