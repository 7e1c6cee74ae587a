"""Shots on Dask: a local cluster of 2 worker processes and an external scheduler with a worker,
all on 127.0.0.1 and stopped by the tests.  Frames (whole or split into sample ranges) are
bit-identical to one-process renders, also when a worker is SIGKILLed mid-render; an interrupted
shot keeps its finished frames and resumes; unreachable schedulers and unreadable scenes are
clear errors."""
import logging
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.host.shots.run import run_shot
from rtc.renderer.host.shots.worker import Job
from rtc.renderer.usd.stage import read_stage

from .conftest import same_bits

distributed = pytest.importorskip('distributed')


@pytest.fixture(scope='module')
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1',
                                  dashboard_address=None, silence_logs=logging.CRITICAL) as lc, \
            distributed.Client(lc) as c:
        yield c


def _job(path, spp=None):
    return Job(shot='', scene=path, options=RenderOptions(seed=3, spp=spp), threads=1)


def test_frames_on_two_workers_are_bit_identical(client, shot_path, reference, tmp_path):
    res = run_shot(_job(shot_path), [1, 2, 3, 4], str(tmp_path / 'd.####.exr'), client=client)
    assert res.workers == 2 and res.split == 1 and sorted(res.written) == [1, 2, 3, 4]
    assert len(res.by_worker) == 2                        # both workers rendered frames
    for f in (1, 2, 3, 4):
        assert same_bits(tmp_path / f'd.{f:04d}.exr', reference(f)), f
    assert all(b < 4096 for b in res.bytes_to_worker)    # a task is its options, not the scene


def test_one_frame_split_over_two_workers_is_bit_identical(client, shot_path, reference, tmp_path):
    res = run_shot(_job(shot_path), [3], str(tmp_path / 'one.exr'), client=client)
    assert res.split == 4 and res.tasks == 4             # about two sample ranges per worker
    assert same_bits(tmp_path / 'one.exr', reference(3))


def _kill_a_worker_running(client, prefix, killed):
    """SIGKILL the process of the first worker seen running a task whose key starts with `prefix`."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not killed:
        for addr, keys in client.processing().items():
            if any(str(k).startswith(prefix) for k in keys):
                pid = client.run(os.getpid, workers=[addr])[addr]
                os.kill(pid, signal.SIGKILL)
                killed.update(addr=addr, pid=pid, keys=list(keys))
                return
        time.sleep(0.005)


def test_a_worker_killed_mid_render_costs_only_its_tasks(client, shot_path, tmp_path):
    spp = 96
    killed = {}
    t = threading.Thread(target=_kill_a_worker_running, args=(client, 'rtc-frame-', killed))
    t.start()
    res = run_shot(_job(shot_path, spp), [1, 2, 3, 4], str(tmp_path / 'k.####.exr'), client=client)
    t.join()
    assert killed, 'no task was seen running'
    with pytest.raises(ProcessLookupError):
        os.kill(killed['pid'], 0)
    assert sorted(res.written) == [1, 2, 3, 4]
    for f in (1, 2, 3, 4):
        ref = render(read_stage(shot_path, time=f), RenderOptions(seed=3, spp=spp)).image
        assert same_bits(tmp_path / f'k.{f:04d}.exr', ref), f
    client.wait_for_workers(2, timeout=120)              # the nanny restarted it (for the next tests)


def _rtc(*args, **kw):
    return subprocess.run([sys.executable, '-m', 'rtc.cli', *args], capture_output=True, text=True, timeout=600,
                          **kw)


def test_ctrl_c_keeps_finished_frames_and_resume_completes_the_shot(shot_path, tmp_path):
    out = str(tmp_path / 'i.####.exr')
    args = ['render', shot_path, '-o', out, '--frames', '1:4', '--seed', '3', '--spp', '512', '--workers', '2']
    p = subprocess.Popen([sys.executable, '-m', 'rtc.cli', *args], stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and not any(n.endswith('.exr') and not n.startswith('.')
                                                  for n in os.listdir(tmp_path)):
        time.sleep(0.02)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert 'kept' in err and 'Traceback' not in err
    kept = sorted(n for n in os.listdir(tmp_path))
    assert 1 <= len(kept) < 4 and all(not n.startswith('.') for n in kept), kept      # no temporary files
    r = _rtc(*args[:-2], '--resume')                     # in this process, no cluster
    assert r.returncode == 0, r.stderr
    assert f'skipped {len(kept)} frame(s) already written' in r.stderr
    for f in (1, 2, 3, 4):
        ref = render(read_stage(shot_path, time=f), RenderOptions(seed=3, spp=512)).image
        assert same_bits(tmp_path / f'i.{f:04d}.exr', ref), f


def test_unreachable_scheduler_is_a_clear_error(shot_path, tmp_path):
    p = _rtc('render', shot_path, '-o', str(tmp_path / 'u.####.exr'), '--frames', '1:2',
             '--scheduler', 'tcp://127.0.0.1:9')
    assert p.returncode == 2, p.stderr
    assert 'cannot reach the Dask scheduler at tcp://127.0.0.1:9' in p.stderr and 'Traceback' not in p.stderr
    assert os.listdir(tmp_path) == []


@pytest.fixture(scope='module')
def scheduler(tmp_path_factory):
    """`dask scheduler` and one `dask worker` (started as docs/cluster.md says) as subprocesses, in
    another working directory."""
    d = tmp_path_factory.mktemp('dask')
    dask = os.path.join(os.path.dirname(sys.executable), 'dask')
    info = d / 'scheduler.json'
    procs = [subprocess.Popen([dask, 'scheduler', '--host', '127.0.0.1', '--port', '0', '--no-dashboard',
                               '--scheduler-file', str(info)], cwd=d, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        import json
        time.sleep(0.2)
        address = json.loads(info.read_text())['address']
        env = {**os.environ, 'DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED': 'False'}     # as docs/cluster.md says
        procs.append(subprocess.Popen([dask, 'worker', address, '--nthreads', '1', '--no-nanny', '--no-dashboard'],
                                      cwd=d, stderr=subprocess.DEVNULL, env=env))
        with distributed.Client(address, timeout=30) as c:
            c.wait_for_workers(1, timeout=60)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


def test_an_existing_cluster_renders_the_same_frames(scheduler, shot_path, reference, tmp_path):
    p = _rtc('render', shot_path, '-o', str(tmp_path / 's.####.exr'), '--frames', '3:4', '--seed', '3',
             '--scheduler', scheduler)
    assert p.returncode == 0, p.stderr
    assert 'on 1 worker' in p.stderr
    for f in (3, 4):
        assert same_bits(tmp_path / f's.{f:04d}.exr', reference(f))


def test_a_worker_that_cannot_read_the_scene_is_named(scheduler, tmp_path):
    # a path that exists nowhere: sent as given, the worker reports it
    p = _rtc('render', 'elsewhere/shot.usda', '-o', str(tmp_path / 'w.####.exr'), '--frames', '1:2',
             '--scheduler', scheduler, cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert 'tcp://127.0.0.1:' in p.stderr and 'elsewhere/shot.usda: no such file' in p.stderr
    assert 'Traceback' not in p.stderr
    assert os.listdir(tmp_path) == []


BIG = dict(width=384, height=256, spp=2)                 # 98 304 pixels: 6 tiles of 128x128 fit


@pytest.fixture(scope='module')
def big_reference(shot_path):
    o = RenderOptions(seed=3, **BIG)
    return render(read_stage(shot_path, time=2, options=o), o).image


def test_a_large_frame_is_tiled_over_two_workers_bit_identical(client, shot_path, big_reference, tmp_path):
    res = run_shot(Job(shot='', scene=shot_path, options=RenderOptions(seed=3, **BIG), threads=1), [2],
                   str(tmp_path / 'big.exr'), client=client)
    assert (res.tiles, res.split, res.tasks) == (4, 1, 4)            # tiles, no sample ranges: 2 per worker
    assert len(res.by_worker) == 2
    assert same_bits(tmp_path / 'big.exr', big_reference)
    # back: each tile's float32 pixels, no more than the whole frame's
    assert res.bytes_from_worker == [192 * 128 * 12] * 4               # 192x128 tiles
    assert sum(res.bytes_from_worker) == 384 * 256 * 12
    assert all(b < 4096 for b in res.bytes_to_worker)


def test_tiles_times_sample_ranges_are_bit_identical(client, shot_path, big_reference, tmp_path):
    res = run_shot(Job(shot='', scene=shot_path, options=RenderOptions(seed=3, **BIG), threads=1), [2],
                   str(tmp_path / 'big.exr'), client=client, tiles=6, split=2)
    assert (res.tiles, res.split, res.tasks) == (6, 2, 12)
    assert same_bits(tmp_path / 'big.exr', big_reference)
    # back: one float64 film of the tile per sample (1 sample per range here)
    assert sum(res.bytes_from_worker) == 384 * 256 * 24 * 2


def test_progress_moves_with_samples_while_a_frame_renders(client, shot_path, tmp_path):
    seen = []
    res = run_shot(_job(shot_path, 256), [1], str(tmp_path / 'p.exr'), client=client, tiles=1, split=1,
                   watch=lambda frames, samples, rays: seen.append((frames, samples, rays)))
    total = 32 * 24 * 256
    assert res.tasks == 1 and res.events >= 1
    during = [s for f, s, r in seen if f == 0 and 0 < s < total]      # reported by the running task
    assert during and during == sorted(during)
    assert seen[-1][:2] == (1, total) and seen[-1][2] == res.rays


def test_a_worker_killed_while_rendering_a_tile_costs_only_that_tile(client, shot_path, tmp_path):
    o = RenderOptions(seed=3, width=384, height=256, spp=16)
    killed = {}
    t = threading.Thread(target=_kill_a_worker_running, args=(client, 'rtc-frame-2-tile-', killed))
    t.start()
    res = run_shot(Job(shot='', scene=shot_path, options=o, threads=1), [2], str(tmp_path / 't.exr'), client=client)
    t.join()
    assert killed, 'no tile was seen rendering'
    assert res.tiles == 4 and res.written == [2]
    assert same_bits(tmp_path / 't.exr', render(read_stage(shot_path, time=2, options=o), o).image)
    client.wait_for_workers(2, timeout=120)              # the nanny restarted it (for the next tests)
