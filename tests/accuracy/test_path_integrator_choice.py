"""Which integrator renders what: compiled course stages record rtc:integrator = cook, any other USD
renders with path, --integrator overrides, an unknown one is a usage error."""
import subprocess
import sys

import numpy as np
import pytest
from pxr import Usd, UsdGeom, UsdLux

from rtc.renderer.host.render import DEFAULT_DEPTH, RenderError, RenderOptions
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
    assert RenderOptions().resolved(s).integrator == 'cook'           # hand-made descriptions
    assert RenderOptions().resolved(s).max_depth == DEFAULT_DEPTH['cook'] == 4
    s.integrator = 'path'
    o = RenderOptions().resolved(s)
    assert (o.integrator, o.max_depth) == ('path', 8)
    assert RenderOptions(integrator='cook').resolved(s).integrator == 'cook'
    with pytest.raises(RenderError, match='unknown light strategy'):
        RenderOptions(strategy='x').resolved(s)


def test_usd_stage_defaults_to_path_and_compiled_course_stage_to_cook(tmp_path):
    stage = Usd.Stage.CreateInMemory()
    assert read_render_settings(None, Usd.TimeCode.Default())[0].integrator == 'path'
    from rtc.compiler import usd_writer
    src = [p for p in usd_writer.__dict__ if p == '_render_settings']
    assert src, 'the compiler writes render settings'


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
