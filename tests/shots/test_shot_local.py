"""Shots in one process (no Dask): frames at their time codes, bit-identical to single renders;
prototype BVHs reused across frames; split frames; resume; the command's errors."""
import os
import subprocess
import sys

import numpy as np
import pytest

from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.host.shots.frames import ShotError
from rtc.renderer.host.shots.run import run_shot
from rtc.renderer.host.shots.worker import Job
from rtc.renderer.usd.stage import read_stage

from .conftest import FRAMES, H, SPP, W, same_bits


def _job(path, **kw):
    return Job(shot='', scene=path, options=RenderOptions(seed=3), **kw)


def test_frames_are_the_stage_at_their_time_codes(shot_path, reference, tmp_path):
    res = run_shot(_job(shot_path), [1, 2, 3], str(tmp_path / 'f.####.exr'))
    assert res.written == [1, 2, 3] and (res.width, res.height, res.spp) == (W, H, SPP)
    for f in (1, 2, 3):
        assert same_bits(tmp_path / f'f.{f:04d}.exr', reference(f)), f
    assert not np.array_equal(reference(1), reference(2))          # the shot moves
    # frames 2 and 3 only moved placements and the camera: the prototype BVHs were kept
    assert res.reused == {'frame': 1, 'prototypes': 2}
    assert res.samples == 3 * W * H * SPP and res.rays > res.samples


def test_without_reuse_the_frames_are_the_same(shot_path, reference, tmp_path):
    res = run_shot(_job(shot_path, reuse=False), [2, 3], str(tmp_path / 'f.%02d.exr'))
    assert res.reused == {'none': 1, 'frame': 1, 'prototypes': 0} or res.reused.get('prototypes', 0) == 0
    for f in (2, 3):
        assert same_bits(tmp_path / f'f.{f:02d}.exr', reference(f))


def test_a_frame_split_into_sample_ranges_is_bit_identical(shot_path, reference, tmp_path):
    res = run_shot(_job(shot_path), [2], str(tmp_path / 'one.exr'), split=3)
    assert res.tasks == 3 and res.split == 3
    assert same_bits(tmp_path / 'one.exr', reference(2))


def test_resume_skips_frames_written_with_the_same_options(shot_path, reference, tmp_path):
    pattern = str(tmp_path / 'r.####.exr')
    run_shot(_job(shot_path), [1, 3], pattern)
    before = os.stat(tmp_path / 'r.0001.exr').st_mtime_ns
    res = run_shot(_job(shot_path), [1, 2, 3, 4], pattern, resume=True)
    assert res.skipped == [1, 3] and res.written == [2, 4]
    assert os.stat(tmp_path / 'r.0001.exr').st_mtime_ns == before
    for f in range(1, FRAMES + 1):
        assert same_bits(tmp_path / f'r.{f:04d}.exr', reference(f))
    other = Job(shot='', scene=shot_path, options=RenderOptions(seed=4))
    with pytest.raises(ShotError, match='seed=3, not 4'):
        run_shot(other, [1, 2], pattern, resume=True)


def test_an_unreadable_scene_names_the_file(tmp_path):
    bad = tmp_path / 'bad.usda'
    bad.write_text('#usda 1.0\n( garbage')
    with pytest.raises(ShotError, match='bad.usda'):
        run_shot(_job(str(bad)), [1], str(tmp_path / 'x.####.exr'))
    assert os.listdir(tmp_path) == ['bad.usda']


def _rtc(*args, cwd=None):
    return subprocess.run([sys.executable, '-m', 'rtc.cli', *args], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


@pytest.mark.parametrize('args, words', [
    (['--frames', '5:1'], 'end 1 is before start 5'),
    (['--frames', '1:x'], "end 'x' is not an integer"),
    (['--frames', '1:3', '--frame', '2'], 'not both'),
    (['--frame', 'nan'], 'not a finite time code'),
    (['--frames', '1:2', '--workers', '0'], '--workers must be'),
    (['--frame', '2', '--workers', '2', '--scheduler', 'tcp://127.0.0.1:9'], 'not both'),
    (['--frames', '1:2', '--checkpoint', '5'], '--checkpoint is for single renders'),
])
def test_command_errors_exit_2_without_output(shot_path, tmp_path, args, words):
    p = _rtc('render', shot_path, '-o', str(tmp_path / 's.####.exr'), *args)
    assert p.returncode == 2, p.stderr
    assert words in p.stderr and 'Traceback' not in p.stderr
    assert os.listdir(tmp_path) == []


def test_command_several_frames_need_a_pattern(shot_path, tmp_path):
    p = _rtc('render', shot_path, '-o', str(tmp_path / 'still.exr'), '--frames', '1:2')
    assert p.returncode == 2 and '2 frames need a frame number' in p.stderr
    p = _rtc('render', str(tmp_path / 'missing.usda'), '-o', str(tmp_path / 's.####.exr'), '--frames', '1:2')
    assert p.returncode == 2 and 'missing.usda: no such file' in p.stderr and 'Traceback' not in p.stderr
    assert os.listdir(tmp_path) == []


def test_command_renders_a_shot(shot_path, reference, tmp_path):
    p = _rtc('render', shot_path, '-o', str(tmp_path / 'c.####.exr'), '--frames', '2:4:2', '--seed', '3')
    assert p.returncode == 0, p.stderr
    assert sorted(os.listdir(tmp_path)) == ['c.0002.exr', 'c.0004.exr']
    assert 'rendered 2 of 2 frames (32x24, 4 spp)' in p.stderr
    assert same_bits(tmp_path / 'c.0004.exr', reference(4))


def test_prototypes_are_reused_only_when_their_geometry_is_the_same(shot_path):
    import copy
    from rtc.renderer.host.shots.worker import same_containers
    from rtc.renderer.usd.stage import read_stage
    a, b = read_stage(shot_path, time=1), read_stage(shot_path, time=3)
    assert same_containers(a, b)                                      # only placements moved
    assert not np.array_equal(a.instances.matrices, b.instances.matrices)
    c = copy.deepcopy(b)
    c.containers[0].meshes[0].points[0, 1] += 1e-9                   # one vertex, a hair
    assert not same_containers(a, c)
    d = copy.deepcopy(b)
    d.containers[0].meshes.pop()
    assert not same_containers(a, d)


def test_tiles_in_this_process_with_the_cook_integrator_are_bit_identical(shot_path, tmp_path):
    o = RenderOptions(seed=3, integrator='cook', width=72, height=40)     # tiles end at the image's edges
    ref = render(read_stage(shot_path, time=3, options=o), o).image
    res = run_shot(Job(shot='', scene=shot_path, options=o), [3], str(tmp_path / 'c.exr'), tiles=3)
    assert res.tiles == 3 and res.tasks == 3
    assert same_bits(tmp_path / 'c.exr', ref)
    res = run_shot(Job(shot='', scene=shot_path, options=o), [3], str(tmp_path / 'd.exr'), tiles=2, split=2)
    assert (res.tiles, res.split, res.tasks) == (2, 2, 4)
    assert same_bits(tmp_path / 'd.exr', ref)


def test_a_tile_task_holds_and_returns_its_window_only(shot_path):
    """worker.render_tile renders `Renderer.render(window=)`: the tile's pixels (all samples) or one
    film of the tile per sample, the frame's values there; a box off the 8-pixel grid, or samples
    outside [0, spp), are refused naming the tile."""
    from rtc.renderer.host.shots import worker
    o = RenderOptions(seed=3, integrator='cook', width=72, height=40, spp=3)
    job = Job(shot='tile-task', scene=shot_path, options=o)
    try:
        whole = worker.render_frame(job, 3, 3, o)['image']
        t = worker.render_tile(job, 3, 3, o, (16, 8, 72, 40), 0, 3)
        assert t['image'].shape == (32, 56, 3) and t['box'] == (16, 8, 72, 40)
        assert t['image'].tobytes() == whole[8:40, 16:72].tobytes()
        part = worker.render_tile(job, 3, 3, o, (16, 8, 72, 40), 1, 3)['samples']
        assert part.shape == (2, 32, 56, 3) and part.dtype == np.float64
        for box, s0, s1 in (((4, 8, 72, 40), 0, 3), ((16, 8, 70, 40), 0, 3), ((16, 8, 72, 40), 2, 4)):
            with pytest.raises(worker.TaskFailed, match=r'tile \(.*\), samples \[.*\) do not fit a 72x40 frame'):
                worker.render_tile(job, 3, 3, o, box, s0, s1)
    finally:
        worker.close()


def test_progress_in_this_process_counts_every_sample(shot_path, tmp_path):
    seen = []
    res = run_shot(_job(shot_path), [1, 2], str(tmp_path / 'p.####.exr'),
                   watch=lambda frames, samples, rays: seen.append((frames, samples, rays)))
    assert seen[-1] == (2, 2 * W * H * SPP, res.rays)
    assert [f for f, _, _ in seen] == sorted(f for f, _, _ in seen)
    assert any(f == 0 and 0 < s for f, s, _ in seen)             # a pass reported before the frame was written


def test_reads_reuse_static_gprims_and_change_no_bit(shot_path, reference, tmp_path):
    on = run_shot(_job(shot_path), [1, 2, 3], str(tmp_path / 'on.####.exr'))
    off = run_shot(_job(shot_path, reuse_reads=False), [1, 2, 3], str(tmp_path / 'off.####.exr'))
    for f in (1, 2, 3):
        assert same_bits(tmp_path / f'on.{f:04d}.exr', reference(f))
        assert same_bits(tmp_path / f'off.{f:04d}.exr', reference(f))
