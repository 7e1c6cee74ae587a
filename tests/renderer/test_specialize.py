"""Specialised kernels (kernel/features.py, kernel/specialize.py, host/features.py): a render compiles
only the code its scene and options can reach, and computes exactly what the general kernel computes.

* what a feature set prunes is pruned before numba types anything (the typed functions of a Sobol'-only
  sampler call none of the other samplers' code; the general one calls all of them);
* a scene's features are read from its tables (which models, lights, textures, ... it has);
* a specialised render is bit-identical to the general kernel's (default suite: a course scene with
  cook, a UsdPreviewSurface scene with path; slow: every gallery scene with both integrators, every
  sampler).
"""
from __future__ import annotations

import os
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core import types
from numba.core.registry import CPUDispatcher

from rtc.renderer import description as D
from rtc.renderer.host import features as host_features
from rtc.renderer.host.render import RenderOptions, Renderer
from rtc.renderer.options import resolve
from rtc.renderer.kernel import features as F
from rtc.renderer.kernel import samplers
from rtc.renderer.kernel.specialize import callees, depends, specialize
from tests.renderer.handmade import look_at, quad, scene, translate

ROOT = Path(__file__).resolve().parents[2]
KERNEL = ROOT / 'renderer' / 'kernel'


def _called(disp) -> set:
    """Names of the kernel functions the typed code of `disp` (its first signature) calls.  Typed again
    from its Python function, uncached: an overload loaded from the disk cache keeps no typing."""
    fresh = numba.njit(**{k: v for k, v in disp.targetoptions.items() if k != 'nopython'})(disp.py_func)
    fresh.compile(next(iter(disp.overloads)))
    cres = next(iter(fresh.overloads.values()))
    return {t.dispatcher.py_func.__name__ for t in cres.type_annotation.typemap.values()
            if isinstance(t, types.Dispatcher)}


def _only(**kw) -> F.Features:
    return F.Features(**{**F.ALL.__dict__, **kw})


def test_a_pruned_feature_is_never_typed():
    sobol = specialize(samplers.sample_2d, _only(samplers=F.B_SOBOL))
    assert sobol is not samplers.sample_2d and sobol.py_func.__code__ is samplers.sample_2d.py_func.__code__
    args = (samplers.SOBOL, 7, 3, 5, 16, 4)
    assert sobol(*args) == samplers.sample_2d(*args)
    assert _called(sobol) == {'sobol_sample_2d'}
    samplers.sample_2d(*args)
    general = _called(samplers.sample_2d)
    assert {'sobol_sample_2d', 'cmj', 'stratified_sample_2d', 'independent_sample_2d', '_pattern'} <= general
    cmj = specialize(samplers.sample_2d, _only(samplers=F.B_CMJ))
    assert cmj(samplers.CMJ, 7, 3, 5, 16, 4) == samplers.sample_2d(samplers.CMJ, 7, 3, 5, 16, 4)
    assert _called(cmj) == {'_pattern', 'cmj'}


def test_functions_that_test_no_feature_are_shared():
    assert not depends(samplers.sobol_sample_2d)
    assert specialize(samplers.sobol_sample_2d, _only(samplers=F.B_SOBOL)) is samplers.sobol_sample_2d
    assert specialize(samplers.sample_2d, F.ALL) is samplers.sample_2d
    assert specialize(samplers.sample_2d, None) is samplers.sample_2d
    twin = specialize(samplers.sample_2d, _only(samplers=F.B_SOBOL))
    assert twin is specialize(samplers.sample_2d, _only(samplers=F.B_SOBOL))          # made once
    shared = twin.py_func.__globals__['sobol_sample_2d']                 # one twin for every feature set,
    assert shared.py_func.__code__ is samplers.sobol_sample_2d.py_func.__code__      # without a Python entry
    assert shared is specialize(samplers.sample_2d, _only(samplers=F.B_SOBOL, lens=False)).py_func.__globals__[
        'sobol_sample_2d']
    assert shared.targetoptions.get('no_cpython_wrapper') and not twin.targetoptions.get('no_cpython_wrapper')
    assert twin.py_func.__qualname__.startswith('sample_2d__')


def test_kernel_modules_call_kernel_functions_by_name():
    """specialize() follows the globals a function names: no kernel module may reach kernel functions
    through another kernel module's attribute (`samplers.sample_2d(...)`)."""
    import importlib
    kernel_modules = {}
    for path in sorted(KERNEL.glob('*.py')):
        kernel_modules[path.stem] = importlib.import_module(f'rtc.renderer.kernel.{path.stem}')
    mods = set(map(id, kernel_modules.values()))
    for name, mod in kernel_modules.items():
        bad = [k for k, v in vars(mod).items() if id(v) in mods and v is not mod]
        assert not bad, f'{name} imports kernel modules {bad}'
    from rtc.renderer.kernel.integrator import render_tiles
    from rtc.renderer.kernel.path import render_tiles_path
    for entry in (render_tiles, render_tiles_path):
        assert depends(entry) and callees(entry)
        assert all(isinstance(c, CPUDispatcher) for c in callees(entry).values())


def _rich_path_scene() -> D.SceneDescription:
    """UsdPreviewSurface materials of every kind the path kernel distinguishes (metallic, specular
    workflow, clearcoat, opacity, emission, a texture), a sphere, a textured dome and an area light."""
    tex = np.linspace(0.1, 0.9, 8 * 8 * 3, dtype=np.float32).reshape(8, 8, 3)
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.6, diffuse_texture=0),
            D.Material('/gold', diffuse=(0.9, 0.6, 0.2), metallic=1.0, roughness=0.3, clearcoat=0.5),
            D.Material('/glass', diffuse=(0.2, 0.4, 0.9), opacity=0.4, roughness=0.1),
            D.Material('/glow', diffuse=(0.1, 0.1, 0.1), emission=(2.0, 1.0, 0.5), use_specular_workflow=True,
                       specular=(0.3, 0.3, 0.3))]
    ball = D.Sphere(path='/ball', radius=0.5, matrix=translate(0.0, 0.5, 0.0), material=1)
    panes = [quad(1.0, y=0.8, material=2, path='/pane', center=(0.8, 0.3)),
             quad(0.6, y=0.4, material=3, path='/glow', center=(-0.9, 0.2))]
    rect = np.eye(4)
    rect[:3, 1], rect[:3, 2], rect[:3, 3] = (0, 0, -1), (0, 1, 0), (0.0, 3.0, 0.0)
    lights = [D.Light(path='/rect', type=D.RECT, matrix=rect, radiance=(6.0,) * 3, width=1.0, height=1.0),
              D.Light(path='/sky', type=D.DOME, matrix=np.eye(4), radiance=(0.5,) * 3, texture=1)]
    sky = D.Texture(path='/sky.exr', pixels=np.full((8, 16, 3), 0.4, np.float32), wrap_s='repeat', wrap_t='clamp')
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 2.0, 4.0), (0.0, 0.3, 0.0)))
    return scene([D.Container('/', meshes=[quad(8.0)] + panes, spheres=[ball])], mats, lights, cam, width=24,
                 height=18, textures=(D.Texture(path='/t.png', pixels=tex), sky))


def test_features_are_read_from_the_scene_tables(monkeypatch):
    with Renderer(_rich_path_scene()) as r:
        o = resolve(RenderOptions(spp=1, integrator='path', sampler='cmj', filter='tent'), r.desc.settings)
        monkeypatch.setenv('RTC_KERNELS', 'specialized')
        f = r.setup(o).features
    assert f.samplers == F.B_CMJ and f.filters == F.B_TENT
    assert f.models == F.B_PREVIEW_SURFACE and f.lights == F.B_RECT | F.B_DOME
    assert f.textures and f.opacity and f.emission and f.clearcoat and f.spheres and f.dome_texture
    assert f.light_shapes and f.surface_lights and f.lux_lights and not f.course_lights
    assert not (f.shaping or f.normal_maps or f.normals or f.uvs or f.xf_motion or f.ortho or f.lens or f.time)
    assert not f.rect_texture                          # (the dome has an image, the rect has none)
    assert 'cmj tent previewSurface light:rect light:dome' in f.describe()


def test_a_rect_light_image_is_a_feature_of_its_own(monkeypatch):
    desc = _rich_path_scene()
    desc.lights[0].texture = 0
    with Renderer(desc) as r:
        monkeypatch.setenv('RTC_KERNELS', 'specialized')
        f = r.setup(resolve(RenderOptions(spp=1, integrator='path'), r.desc.settings)).features
    assert f.rect_texture and f.dome_texture


def _images(desc_or_path, opts: dict, monkeypatch) -> tuple:
    """(specialised image, general image) of one render."""
    if isinstance(desc_or_path, (str, Path)):
        from rtc.cli import load_scene
        desc = load_scene(str(desc_or_path), quiet=True)
    else:
        desc = desc_or_path
    out = []
    for mode in ('specialized', 'general'):
        monkeypatch.setenv('RTC_KERNELS', mode)
        with Renderer(desc) as r:
            out.append(r.render(RenderOptions(**opts)).image)
    return tuple(out)


def test_specialised_cook_kernel_gives_the_general_kernels_image(monkeypatch):
    spec, general = _images(ROOT / 'scenes' / 'gallery.xml', dict(width=40, height=30, spp=4), monkeypatch)
    assert spec.max() > 0.05 and np.array_equal(spec, general)


@pytest.mark.slow            # (90 s of kernel compile on 2 cores: the default run keeps the cook kernel's check)
def test_specialised_path_kernel_gives_the_general_kernels_image(monkeypatch):
    spec, general = _images(_rich_path_scene(), dict(spp=8, integrator='path', max_depth=4), monkeypatch)
    assert spec.max() > 0.05 and np.array_equal(spec, general)


GALLERY = sorted(p.name for p in (ROOT / 'scenes').glob('*.xml'))


@pytest.mark.slow
@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('name', GALLERY)
def test_every_gallery_scene_specialised_is_bit_identical(name, integrator, monkeypatch):
    spec, general = _images(ROOT / 'scenes' / name, dict(width=32, height=24, spp=4, integrator=integrator),
                            monkeypatch)
    assert np.array_equal(spec, general)


@pytest.mark.slow
@pytest.mark.parametrize('sampler', ['independent', 'stratified', 'cmj'])
@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_every_sampler_specialised_is_bit_identical(sampler, integrator, monkeypatch):
    spec, general = _images(ROOT / 'scenes' / 'dof.xml', dict(width=32, height=24, spp=5, sampler=sampler,
                                                              filter='box', integrator=integrator), monkeypatch)
    assert np.array_equal(spec, general)


def test_the_suite_runs_the_general_kernel():
    assert os.environ.get('RTC_KERNELS') == 'general' and host_features.general_kernels()
