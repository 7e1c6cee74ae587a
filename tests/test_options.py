"""Render options are resolved once (rtc.renderer.options.resolve): asked > stage render settings >
defaults, one set of limits, the same for a course XML scene and the same scene compiled to USD."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from rtc.cli import main
from rtc.scene_input import load_scene
from rtc.renderer import options as O
from rtc.renderer.description import RenderSettings
from rtc.renderer.errors import RenderError
from rtc.renderer.kernel.filters import FILTER_NAMES
from rtc.renderer.kernel.samplers import SAMPLER_NAMES
from rtc.renderer.options import RenderOptions, resolve

SCENES = Path(__file__).resolve().parents[1] / 'scenes'


# ----------------------------------------------------------------------------- precedence
def test_asked_values_win_over_the_stage_and_the_defaults():
    o = resolve(RenderOptions(width=300, height=100, spp=7, sampler='cmj', seed=5),
                RenderSettings(width=640, height=480, samples_per_pixel=64))
    assert (o.width, o.height, o.spp, o.sampler, o.seed) == (300, 100, 7, 'cmj', 5)


def test_the_stage_settings_win_over_the_defaults():
    o = resolve(RenderOptions(), RenderSettings(width=320, height=200, samples_per_pixel=64))
    assert (o.width, o.height, o.spp) == (320, 200, 64)


def test_defaults_fill_what_nobody_says():
    o = resolve(None, RenderSettings())
    assert (o.width, o.height) == O.DEFAULT_SIZE and o.spp == O.DEFAULT_SPP
    assert all(getattr(o, k) == v for k, v in O.DEFAULTS.items())
    assert o.threads is None                    # all cores


@pytest.mark.parametrize('asked, size', [((48, None), (48, 36)), ((None, 36), (48, 36)), ((641, None), (641, 481)),
                                         ((None, 1), (1, 1)), ((1, None), (1, 1))])
def test_one_side_keeps_the_stage_aspect(asked, size):
    o = resolve(RenderOptions(width=asked[0], height=asked[1]), RenderSettings(width=640, height=480))
    assert (o.width, o.height) == size


def test_resolving_complete_options_changes_nothing():
    once = resolve(RenderOptions(width=48, spp=3), RenderSettings(width=640, height=480, samples_per_pixel=9))
    assert resolve(once, RenderSettings(width=100, height=1000, samples_per_pixel=1)) == once


# ----------------------------------------------------------------------------- limits
@pytest.mark.parametrize('asked, message', [
    (dict(width=0), 'image width 0 is out of range'),
    (dict(height=O.MAX_SIDE + 1), f'image height {O.MAX_SIDE + 1} is out of range'),
    (dict(width=O.MAX_SIDE, height=O.MAX_SIDE), f'at most {O.MAX_PIXELS} pixels'),
    (dict(spp=0), 'samples per pixel 0 is out of range'),
    (dict(spp=O.MAX_SPP + 1), f'samples per pixel {O.MAX_SPP + 1} is out of range'),
    (dict(sampler='halton'), "unknown sampler 'halton' (choose from " + ', '.join(SAMPLER_NAMES) + ')'),
    (dict(filter='mitchell'), "unknown filter 'mitchell' (choose from " + ', '.join(FILTER_NAMES) + ')'),
    (dict(max_depth=-1), 'max depth -1 is out of range'),
    (dict(max_depth=O.MAX_DEPTH + 1), f'max depth {O.MAX_DEPTH + 1} is out of range'),
    (dict(seed=2 ** 32), f'seed {2 ** 32} is out of range'),
    (dict(threads=0), 'threads 0 is out of range'),
    (dict(threads=O.MAX_THREADS + 1), f'threads {O.MAX_THREADS + 1} is out of range'),
])
def test_limits(asked, message):
    with pytest.raises(RenderError, match=message.replace('(', r'\(').replace(')', r'\)')):
        resolve(RenderOptions(**asked), RenderSettings(width=64, height=64))


def test_the_largest_accepted_values():
    o = resolve(RenderOptions(width=O.MAX_SIDE, height=O.MAX_PIXELS // O.MAX_SIDE, spp=O.MAX_SPP, seed=O.MAX_SEED,
                              max_depth=O.MAX_DEPTH, threads=O.MAX_THREADS))
    assert (o.width * o.height, o.spp) == (O.MAX_PIXELS, O.MAX_SPP)


def test_values_from_the_stage_are_checked_and_named():
    with pytest.raises(RenderError, match=r'^/Render/Settings: image size 100000x10 is out of range'):
        resolve(RenderOptions(), RenderSettings(width=100000, height=10, path='/Render/Settings'))
    with pytest.raises(RenderError, match=r'^/Render/Settings rtc:samplesPerPixel: samples per pixel'):
        resolve(RenderOptions(), RenderSettings(samples_per_pixel=O.MAX_SPP * 2, path='/Render/Settings'))
    # asked values replace the stage's bad ones
    o = resolve(RenderOptions(width=8, height=8, spp=1),
                RenderSettings(width=100000, height=10, samples_per_pixel=O.MAX_SPP * 2))
    assert (o.width, o.height, o.spp) == (8, 8, 1)


def test_cli_choices_and_defaults_are_the_renderers():
    for command in ('render', 'converge'):
        result = CliRunner().invoke(main, [command, '--help'])          # fills them in
        assert result.exit_code == 0, result.output
    params = {p.name: p for p in main.commands['render'].params}
    assert list(params['sampler'].type.choices) == list(SAMPLER_NAMES)
    assert list(params['filter'].type.choices) == list(FILTER_NAMES)
    assert [params[k].default for k in ('sampler', 'filter', 'seed')] == \
           [O.DEFAULTS[k] for k in ('sampler', 'filter', 'seed')]
    assert 'max_depth' not in O.DEFAULTS        # no CLI default: the integrator's own (pbrt's 8 for path, 4 for cook)
    assert [O.resolve(O.RenderOptions(integrator=k), RenderSettings()).max_depth for k in ('path', 'cook')] == [8, 4]
    assert list(params['integrator'].type.choices) == list(O.INTEGRATORS)
    conv = {p.name: p for p in main.commands['converge'].params}
    assert conv['samplers'].default == ','.join(SAMPLER_NAMES)
    assert list(conv['filter_'].type.choices) == list(FILTER_NAMES)
    assert list(conv['reference_sampler'].type.choices) == list(SAMPLER_NAMES)


def test_compiling_never_imports_the_renderer():
    """`rtc compile` and `rtc --help` do not pay for numba (the renderer's registries are read only by
    the commands that render)."""
    code = ('import sys; from rtc.cli import main\n'
            'try:\n    main(["--help"])\nexcept SystemExit:\n    pass\n'
            'print(sorted(m for m in sys.modules if m.split(".")[0] == "numba" or m.startswith("rtc.renderer.")))')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip().endswith('[]'), out.stdout + out.stderr


# ----------------------------------------------------------------------------- XML and USD alike
@pytest.fixture(scope='module')
def compiled(tmp_path_factory):
    usd = tmp_path_factory.mktemp('options') / 'dof.usda'
    result = CliRunner().invoke(main, ['compile', str(SCENES / 'dof.xml'), '-o', str(usd)])
    assert result.exit_code == 0, result.output
    return usd


@pytest.mark.parametrize('asked', [RenderOptions(), RenderOptions(spp=100000), RenderOptions(width=96),
                                   RenderOptions(width=120, height=40, spp=3), RenderOptions(height=30)])
def test_xml_and_its_usd_resolve_and_frame_the_same(asked, compiled):
    from_xml = load_scene(str(SCENES / 'dof.xml'), options=asked, quiet=True)
    from_usd = load_scene(str(compiled), options=asked, quiet=True)
    assert from_xml.options == from_usd.options
    assert from_xml.options.spp == (asked.spp or O.DEFAULT_SPP)
    cx, cu = from_xml.camera, from_usd.camera
    assert (cx.horizontal_aperture, cx.vertical_aperture, cx.lens_radius) == \
           (cu.horizontal_aperture, cu.vertical_aperture, cu.lens_radius)
    # the course camera keeps the image plane width W whatever the aspect: H = W * ny / nx
    o = from_xml.options
    assert cx.vertical_aperture == pytest.approx(cx.horizontal_aperture * o.height / o.width, rel=1e-6)


@pytest.mark.parametrize('args, message', [
    (['--spp', '0'], 'samples per pixel 0 is out of range'),
    (['--width', '0'], 'image width 0 is out of range'),
    (['--width', '60000', '--height', '60000'], 'image size 60000x60000 is out of range'),
    (['--spp', str(O.MAX_SPP + 1)], f'samples per pixel {O.MAX_SPP + 1} is out of range'),
    (['--seed', '-1'], 'seed -1 is out of range'),
    (['--sampler', 'halton'], "Invalid value for '--sampler'"),
])
@pytest.mark.parametrize('scene', ['xml', 'usd'])
def test_bad_values_exit_2_with_a_clear_message(args, message, scene, compiled, tmp_path):
    path = SCENES / 'dof.xml' if scene == 'xml' else compiled
    result = CliRunner().invoke(main, ['render', str(path), '-o', str(tmp_path / 'out.png'), *args])
    assert result.exit_code == 2 and message in result.output, result.output
    assert 'Traceback' not in result.output and not (tmp_path / 'out.png').exists()
