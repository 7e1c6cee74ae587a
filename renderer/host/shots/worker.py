"""What a worker does for a shot: read the stage at a frame's time code, build (or update) the
Embree scene, render a whole frame or a range of its samples.

The same functions run in-process for a shot without Dask and inside Dask workers; they return
plain dicts of numpy arrays and numbers (what crosses the network).  Per process, a worker keeps
the open stage of the shot and the last frame's Renderer:

* a new frame reads the stage at its time code, but static gprims (no time-varying attribute)
  are converted once per shot (`usd.geometry_cache.GeometryCache`);
* a frame read again (another sample range of it) reuses the built scene as it is;
* a new frame whose containers (prototype meshes and spheres) equal the last frame's takes over
  its prototype BVHs and builds only the top level (`build(..., reuse=)`): only placements, the
  camera, lights and materials moved.

Renders inside one process run one at a time (a lock): each render already uses the process's
cores (`job.threads` render threads).
"""
from __future__ import annotations

import threading
import time as _time
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ...errors import RenderError, SceneError
from ...options import RenderOptions, resolve
from ..film import Film
from ..render import Renderer, check_window


@dataclass(frozen=True)
class Job:
    """A shot as every worker needs it: which scene, which options (small: sent with every task)."""
    shot: str                          # unique per run of a shot: worker caches never outlive it
    scene: str                         # path of the stage (or course XML) as the workers see it
    options: RenderOptions             # as asked: resolved against the stage's render settings per frame
    opener: Optional[Callable] = None  # path -> Usd.Stage (e.g. the course XML compiler); None: USD
    camera: Optional[str] = None
    threads: Optional[int] = None      # render / Embree threads of a render (None: numba's thread count)
    reuse: bool = True                 # reuse prototype BVHs across frames when only placements move
    reuse_reads: bool = True           # convert static gprims once per shot (usd.geometry_cache)


class TaskFailed(Exception):
    """A task could not do its work; the message names the worker, the frame and the cause."""


_lock = threading.Lock()
_state: dict = {}                      # shot, stage; time, desc, renderer of the last frame


def where() -> str:
    """This process as a worker address ('tcp://host:port'), or 'this process' outside Dask."""
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):
        return 'this process'


def _open_usd(path: str):
    """The stage at `path`, with read_stage's own checks and messages (SceneError)."""
    from pxr import Tf
    from ...usd.stage import _first_line, _open
    try:
        return _open(path)[0]
    except Tf.ErrorException as e:
        raise SceneError(f'{path}: {_first_line(e)}') from None


def _stage(job: Job):
    if _state.get('shot') != job.shot:
        from ...usd.geometry_cache import GeometryCache
        close()
        stage = job.opener(job.scene) if job.opener is not None else _open_usd(job.scene)
        _state.update(shot=job.shot, stage=stage, geometry=GeometryCache() if job.reuse_reads else None)
    return _state['stage']


def same_containers(a, b) -> bool:
    """Do two descriptions hold the same containers (mesh, sphere and curve geometry, bit for bit)?"""
    if len(a.containers) != len(b.containers):
        return False
    for ca, cb in zip(a.containers, b.containers):
        if len(ca.meshes) != len(cb.meshes) or len(ca.spheres) != len(cb.spheres) or len(ca.curves) != len(cb.curves):
            return False
        for ma, mb in zip(ca.meshes, cb.meshes):
            for x, y in ((ma.points, mb.points), (ma.triangles, mb.triangles)):
                if x is not y and not np.array_equal(x, y):      # the same arrays: a kept static gprim
                    return False
        for sa, sb in zip(ca.spheres, cb.spheres):
            if not (np.array_equal(sa.matrix, sb.matrix) and np.array_equal(sa.balls(), sb.balls())):   # (radii too)
                return False
        for xa, xb in zip(ca.curves, cb.curves):         # (a ribbon's normals are in its BVH too)
            if xa.linear != xb.linear or (xa.normals is None) != (xb.normals is None) or not (
                    np.array_equal(xa.vertices, xb.vertices) and np.array_equal(xa.segments, xb.segments)
                    and (xa.normals is None or np.array_equal(xa.normals, xb.normals))):
                return False
    return True


def _renderer(job: Job, time) -> tuple[Renderer, dict]:
    """The Renderer of the frame at `time` and what it cost: load (stage read) and build seconds."""
    from ...usd.stage import read_stage
    stage = _stage(job)
    if _state.get('time') == time and _state.get('renderer') is not None:
        return _state['renderer'], {'load_seconds': 0.0, 'build_seconds': 0.0, 'reused': 'frame'}
    t0 = _time.perf_counter()
    desc = read_stage(stage, time=time, camera_path=job.camera, options=job.options, geometry=_state['geometry'])
    load = _time.perf_counter() - t0
    previous = _state.get('renderer')
    reuse = previous if job.reuse and previous is not None and same_containers(_state['desc'], desc) else None
    if previous is not None and reuse is None:
        previous.close()
    _state.update(time=time, desc=None, renderer=None)
    r = Renderer(desc, threads=job.threads, reuse=reuse)
    _state.update(time=time, desc=desc, renderer=r)
    return r, {'load_seconds': load, 'build_seconds': r.build_seconds,
               'reused': 'prototypes' if reuse is not None else 'none'}


def close() -> None:
    """Release this process's cached scene (the end of a shot, or a new one)."""
    r = _state.get('renderer')
    if r is not None:
        r.close()
    _state.clear()


def _run(what: str, frame, fn):
    """Run `fn()` under the process lock; failures become TaskFailed naming the worker and frame."""
    with _lock:
        cpu0, t0 = _time.process_time(), _time.perf_counter()
        try:
            out = fn()
        except (SceneError, RenderError) as e:
            raise TaskFailed(f'{where()}: {what} of frame {frame}: {e}') from None
        except TaskFailed:
            raise
        except Exception as e:                    # Embree or I/O failures on the worker
            raise TaskFailed(f'{where()}: {what} of frame {frame}: {type(e).__name__}: {e}') from None
        out.update(cpu_seconds=_time.process_time() - cpu0, wall_seconds=_time.perf_counter() - t0,
                   worker=where(), frame=frame)
        return out


def probe(job: Job, frame, time) -> dict:
    """Read the frame's stage, resolve the options and load (or compile) the kernels: the shot's
    first task, so that the workers after it find the kernels in the cache.  (A tile task runs the
    same kernels: a window is a field of the pass's parameters.)"""
    def work():
        r, cost = _renderer(job, time)
        o = r.desc.options                                      # resolved by the reader
        film = Film(o.width, o.height)
        res = r.render(o, film=film, should_stop=lambda: True)     # no samples: the kernels only
        return {'options': o, 'warnings': list(r.desc.warnings), 'kernel_seconds': res.stats.kernel_seconds,
                **cost}
    return _run('reading the scene', frame, work)


def _no_report(samples, rays):
    pass


def _pixels(r: Renderer, o: RenderOptions, box, should_stop, report) -> dict:
    """All samples of the pixels of `box` (None: the frame), as `Renderer.render` gives them: float32
    (h, w, 3), the frame's image there bit for bit."""
    def on_pass(res):
        report(res.film.width * res.film.height * res.film.spp, res.stats.rays)
    res = r.render(o, should_stop=should_stop, on_pass=on_pass, window=box)
    return {'image': res.image, 'spp': res.film.spp, 'rays': res.stats.rays, 'interrupted': res.interrupted,
            'render_seconds': res.stats.seconds}


def _single_samples(r: Renderer, o: RenderOptions, box, s0: int, s1: int, report) -> dict:
    """Samples [s0, s1) of the pixels of `box` (None: the frame), one film per sample: float64
    (s1 - s0, h, w, 3).  Each is a render of one pass (film continued at sample s, stopped after it),
    its sums starting from zero."""
    x0, y0, x1, y1 = check_window(box, o.width, o.height)
    w, h = x1 - x0, y1 - y0
    out = np.empty((s1 - s0, h, w, 3), np.float64)
    rays = 0
    t0 = _time.perf_counter()
    for s in range(s0, s1):
        film = Film(w, h)
        film.count[...] = s                      # the render continues at sample s ...
        res = r.render(o, film=film, should_stop=lambda: film.count[0, 0] > s, window=box)   # ... for one pass
        if film.count[0, 0] != s + 1:
            raise RenderError(f'sample {s} was not rendered')
        out[s - s0] = film.sum
        rays += res.stats.rays
        report(w * h * (s + 1 - s0), rays)
    return {'samples': out, 's0': s0, 's1': s1, 'rays': rays, 'render_seconds': _time.perf_counter() - t0}


def render_frame(job: Job, frame, time, options: RenderOptions, should_stop=lambda: False,
                 report=_no_report) -> dict:
    """All samples of a frame: its image (float32, h x w x 3) exactly as one process renders it.
    `report(samples, rays)` after every pass (events.py)."""
    def work():
        r, cost = _renderer(job, time)
        return {**_pixels(r, options, None, should_stop, report), **cost}
    return _run('rendering', frame, work)


def render_samples(job: Job, frame, time, options: RenderOptions, s0: int, s1: int, report=_no_report) -> dict:
    """Samples [s0, s1) of a frame, one film per sample: float64 (s1 - s0, h, w, 3).

    A local render adds each pixel's samples to its sum one by one in sample order, so partial sums
    of sample ranges would not add up to the same bits; single samples, added in order by the
    client (`plan.FrameAssembly`), do."""
    def work():
        r, cost = _renderer(job, time)
        return {**_single_samples(r, resolve(options, r.desc.settings), None, s0, s1, report), **cost}
    return _run('rendering', frame, work)


def render_tile(job: Job, frame, time, options: RenderOptions, box, s0: int, s1: int, should_stop=lambda: False,
                report=_no_report) -> dict:
    """Samples [s0, s1) of the pixels of `box` = (x0, y0, x1, y1), a window of the kernels' 8x8 tiles
    (`Renderer.render(window=)`: the worker holds the window's pixels only): with every sample
    (s0 = 0, s1 = spp), its float32 pixels (y1 - y0, x1 - x0, 3) as in the frame's image; else one
    float64 film of the box per sample (s1 - s0, y1 - y0, x1 - x0, 3), as `render_samples`."""
    def work():
        r, cost = _renderer(job, time)
        o = resolve(options, r.desc.settings)
        try:
            check_window(box, o.width, o.height)
        except RenderError:
            ok = False
        else:
            ok = 0 <= s0 < s1 <= o.spp
        if not ok:
            raise RenderError(f'tile {box}, samples [{s0}, {s1}) do not fit a {o.width}x{o.height} frame of '
                              f'{o.spp} spp')
        if s0 == 0 and s1 == o.spp:
            out = _pixels(r, o, box, should_stop, report)
        else:
            out = _single_samples(r, o, box, s0, s1, report)
        return {**out, 'box': box, **cost}
    return _run('rendering', frame, work)
