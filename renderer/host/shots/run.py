"""Render a shot: frames (and sample ranges of frames) as tasks, in this process or on Dask.

`run_shot` reads the shot's first frame once (the probe task: options resolved, kernels loaded or
compiled), skips frames already written when resuming, cuts the rest into tasks (`plan`), runs
them - one after another in this process, or on a Dask cluster (`cluster`) - and writes every
frame atomically as soon as it is complete.  Ctrl-C cancels the tasks still queued or running;
the frames written so far stay (`ShotInterrupted`).  Every failure a user can cause becomes a
`ShotError` whose message names what failed.
"""
from __future__ import annotations

import contextlib
import logging
import os
import pickle
import signal
import statistics
import sys
import threading
import time as _time
import uuid
from dataclasses import dataclass, field

import numpy as np

from .. import film as film_mod
from ..progress import _sig3
from . import worker
from .frames import ShotError, output_name
from .events import Report, Tally
from .plan import FrameAssembly, Split, Task, grid, plan, split_for

CONNECT_TIMEOUT = 10.0               # seconds to reach a scheduler
# local workers: no MALLOC_TRIM_THRESHOLD_=65536 (Dask's default for its workers made read_stage cost
# 1.8x the CPU time of one process) and no statistical profiler sampling the render thread every 10 ms
# (both together: 8.1 vs 8.0 ms CPU per frame read in a worker and in this process; 15.7 ms with Dask's defaults)
LOCAL_WORKER_CONFIG = {
    'distributed.nanny.pre-spawn-environ': {'OMP_NUM_THREADS': 1, 'MKL_NUM_THREADS': 1, 'OPENBLAS_NUM_THREADS': 1},
    'distributed.worker.profile.enabled': False,
}
WORKERS_TIMEOUT = 60.0               # seconds for a scheduler to have a worker


class ShotInterrupted(Exception):
    """Ctrl-C (or SIGTERM): the tasks were cancelled; `result` says what was written."""

    def __init__(self, result):
        super().__init__('interrupted')
        self.result = result


@dataclass
class ShotResult:
    frames: int = 0                    # frames asked for
    written: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    workers: int = 1
    tasks: int = 0
    split: int = 1                     # sample ranges per frame (per tile of a tiled frame)
    tiles: int = 1                     # tiles per frame (1: not tiled)
    width: int = 0
    height: int = 0
    spp: int = 0
    wall_seconds: float = 0.0          # the whole shot: cluster start, probe, frames
    probe_seconds: float = 0.0         # the first read of the scene and the kernels (compiled once)
    cpu_seconds: float = 0.0           # all tasks (their processes' CPU time, every thread)
    rays: int = 0
    samples: int = 0
    load_seconds: list = field(default_factory=list)     # per frame read (stage at a time code)
    build_seconds: list = field(default_factory=list)
    reused: dict = field(default_factory=dict)           # 'none' / 'prototypes' / 'frame' -> count
    by_worker: dict = field(default_factory=dict)        # worker address -> tasks done
    bytes_to_worker: list = field(default_factory=list)  # pickled task arguments
    bytes_from_worker: list = field(default_factory=list)  # result arrays
    events: int = 0                    # progress reports received from running tasks
    dashboard: str | None = None
    warnings: list = field(default_factory=list)

    def summary(self) -> str:
        n = len(self.written)
        frames_wall = max(self.wall_seconds - self.probe_seconds, 1e-9)
        rate = self.rays / frames_wall / 1e6
        per = f'{frames_wall / n:.3g} s wall and {self.cpu_seconds / n:.3g} s CPU per frame, ' if n else ''
        skipped = f' ({len(self.skipped)} already written)' if self.skipped else ''
        return (f'rendered {n} of {self.frames} frames{skipped} ({self.width}x{self.height}, {self.spp} spp) '
                f'in {self.wall_seconds:.2f} s (first read and kernels {self.probe_seconds:.2f} s) '
                f'on {self.workers} worker{"s" if self.workers != 1 else ""}{self._pieces()}: '
                f'{per}{_sig3(self.rays / 1e6)} M rays, {_sig3(rate)} Mrays/s')

    def _pieces(self) -> str:
        """' (16 tasks: 4 tiles x 2 sample ranges per frame)', or '' for whole frames."""
        cuts = ([f'{self.tiles} tiles'] if self.tiles > 1 else []) + \
            ([f'{self.split} sample ranges'] if self.split > 1 else [])
        return f' ({self.tasks} tasks: {" x ".join(cuts)} per frame)' if cuts else ''


class _Progress:
    """One bar over the shot on a terminal: it moves with the samples rendered, as the running tasks
    report them (events.py), and shows frames done / total and Mrays/s over all workers.
    `watch(frames, samples, rays)`: called on every change (tests)."""

    def __init__(self, frames: int, samples: int, quiet: bool, watch=None):
        self.frames, self.done = frames, 0
        self.t0 = _time.perf_counter()
        self.watch = watch
        self.lock = threading.Lock()
        self.tally = Tally(self.refresh)
        self.bar = None
        if not quiet and sys.stderr.isatty():
            from tqdm import tqdm
            self.bar = tqdm(total=samples, unit='sample', unit_scale=True, file=sys.stderr, dynamic_ncols=True,
                            leave=False, desc=self._desc())

    def _desc(self) -> str:
        return f'frames {self.done}/{self.frames}'

    def frame_done(self, n: int = 1) -> None:
        self.done += n
        self.refresh()

    def refresh(self) -> None:
        samples, rays = self.tally.totals()
        with self.lock:
            if self.watch is not None:
                self.watch(self.done, samples, rays)
            if self.bar is not None:
                dt = max(_time.perf_counter() - self.t0, 1e-9)
                self.bar.set_description_str(self._desc(), refresh=False)
                self.bar.set_postfix_str(f'{_sig3(rays / dt / 1e6)} Mrays/s', refresh=False)
                self.bar.n = samples
                self.bar.refresh()

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _frame_meta(o, job, frame, rays, seconds) -> dict:
    return {'rtc:spp': o.spp, 'rtc:sampler': o.sampler, 'rtc:filter': o.filter, 'rtc:seed': o.seed,
            'rtc:maxDepth': o.max_depth, 'rtc:rays': int(rays), 'rtc:seconds': round(seconds, 4),
            'rtc:interrupted': 0, 'rtc:frame': frame if frame is not None else '', 'rtc:scene': job.scene}


def _already_written(path: str, o) -> bool:
    """--resume: is `path` a frame rendered with these options?  (ShotError if it is another's.)"""
    if not os.path.exists(path):
        return False
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise ShotError(f'--resume: {path} exists but cannot be read ({oiio.geterror()}): delete it')
    try:
        spec = inp.spec()
        found = {'width': spec.width, 'height': spec.height}
        for k in ('spp', 'seed', 'sampler', 'filter', 'maxDepth'):
            v = spec.getattribute(f'rtc:{k}')
            if v is not None:
                found[k] = v
    finally:
        inp.close()
    want = {'width': o.width, 'height': o.height, 'spp': o.spp, 'seed': o.seed, 'sampler': o.sampler,
            'filter': o.filter, 'maxDepth': o.max_depth}
    for k, v in found.items():
        if str(v) != str(want[k]):
            raise ShotError(f'--resume: {path} was rendered with {k}={v}, not {want[k]}: delete it to re-render')
    return True


@contextlib.contextmanager
def cluster(workers: int | None = None, scheduler: str | None = None, quiet: bool = False):
    """A Dask client: of an existing scheduler at `scheduler`, or of a local cluster of `workers`
    processes (one thread each: a render uses the process's cores through its own render threads)."""
    from distributed import Client, LocalCluster
    if scheduler:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as e:
            raise ShotError(f'cannot reach the Dask scheduler at {scheduler}: {e}') from None
        try:
            try:
                client.wait_for_workers(1, timeout=WORKERS_TIMEOUT)
            except (TimeoutError, OSError):
                raise ShotError(f'the Dask scheduler at {scheduler} has no workers '
                                f'(start some: dask worker {scheduler} --nthreads 1)') from None
            yield client
        finally:
            client.close()
        return
    import dask
    dashboard = '127.0.0.1:0' if _has_bokeh() else None
    # the worker processes start with SIGINT ignored (inherited): Ctrl-C in a terminal signals the
    # whole process group, and only this process should act on it (cancel, keep the frames, exit)
    main_thread = threading.current_thread() is threading.main_thread()
    with dask.config.set(LOCAL_WORKER_CONFIG):     # for the cluster's life: restarted workers too
        old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
        try:
            lc = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host='127.0.0.1',
                              dashboard_address=dashboard, silence_logs=logging.CRITICAL)
        finally:
            if main_thread:
                signal.signal(signal.SIGINT, old)
        with lc, Client(lc) as client:
            yield client


def _has_bokeh() -> bool:
    try:
        import bokeh  # noqa: F401
        return True
    except ImportError:
        return False


def _dashboard(client, remote: bool) -> str | None:
    """The dashboard's address: a remote scheduler's if it serves one, a local cluster's if bokeh
    (which draws it) is installed."""
    if not remote and not _has_bokeh():
        return None
    try:
        services = client.scheduler_info().get('services', {})
        return client.dashboard_link if 'dashboard' in services else None
    except Exception:                          # the dashboard is an extra, never a reason to fail
        return None


def _thread_split(client) -> int:
    """Render threads per render (`Renderer(threads=)`) on a local cluster: the machine's cores shared by
    its workers."""
    n = len(client.scheduler_info()['workers'])
    return max(1, (len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count() or 1) // n)


class _Shot:
    """The state of one run: tasks, assemblies of split frames, what was written."""

    def __init__(self, job, frames, pattern, result, progress, options, split: Split):
        self.job, self.frames, self.pattern, self.result, self.progress = job, frames, pattern, result, progress
        self.o = options
        self.split = split
        self.assembly: dict = {}
        self.rays: dict = {}
        self.t0 = _time.perf_counter()

    def task_pixels(self, task: Task) -> int:
        x0, y0, x1, y1 = task.box if task.box is not None else (0, 0, self.o.width, self.o.height)
        return (x1 - x0) * (y1 - y0)

    def take(self, task: Task, out: dict) -> None:
        """A task's result: account for it; write its frame when the frame is complete."""
        r = self.result
        r.cpu_seconds += out['cpu_seconds']
        r.rays += out['rays']
        self.rays[task.frame] = self.rays.get(task.frame, 0) + out['rays']
        r.reused[out['reused']] = r.reused.get(out['reused'], 0) + 1
        r.by_worker[out['worker']] = r.by_worker.get(out['worker'], 0) + 1
        if out['reused'] != 'frame':
            r.load_seconds.append(out['load_seconds'])
            r.build_seconds.append(out['build_seconds'])
        o = self.o
        samples = self.task_pixels(task) * (task.s1 - task.s0)
        r.samples += samples
        self.progress.tally.finish(task.key, samples, out['rays'])
        r.bytes_from_worker.append(out['image'].nbytes if task.whole else out['samples'].nbytes)
        if task.whole and task.box is None:
            # an array of its own: one Dask received can be a view into a larger message buffer,
            # which OpenImageIO's writer refused ('buffer is wrong size') for 8x6 frames
            image = np.array(out['image'], dtype=np.float32, order='C', copy=True)
        else:
            a = self.assembly.get(task.frame)
            if a is None:
                a = self.assembly[task.frame] = FrameAssembly(o.width, o.height, o.spp, self.split.tiles)
            a.add(task, out)
            if not a.complete:
                return
            image = self.assembly.pop(task.frame).image()
        path = output_name(self.pattern, task.frame)
        try:
            film_mod.write_image(path, image, _frame_meta(o, self.job, task.frame, self.rays.pop(task.frame),
                                                          _time.perf_counter() - self.t0),
                                 warn=self.result.warnings.append)
        except film_mod.FilmError as e:
            raise ShotError(str(e)) from None
        r.written.append(task.frame)
        self.progress.frame_done()


def _call(task: Task, job, o, should_stop=lambda: False, report=None):
    """The worker function and arguments of a task."""
    report = report if report is not None else worker._no_report
    if task.box is not None:
        return worker.render_tile, (job, task.frame, task.frame, o, task.box, task.s0, task.s1), \
            {'should_stop': should_stop, 'report': report}
    if task.whole:
        return worker.render_frame, (job, task.frame, task.frame, o), {'should_stop': should_stop, 'report': report}
    return worker.render_samples, (job, task.frame, task.frame, o, task.s0, task.s1), {'report': report}


def _run_local(shot: _Shot, tasks: list[Task]) -> None:
    stop = {'now': False}

    def handler(signum, frame):
        stop['now'] = True
    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        for t in tasks:
            if stop['now']:
                raise ShotInterrupted(shot.result)
            fn, args, kw = _call(t, shot.job, shot.o, should_stop=lambda: stop['now'],
                                 report=shot.progress.tally.reporter(t.key))
            try:
                out = fn(*args, **kw)
            except worker.TaskFailed as e:
                raise ShotError(str(e)) from None
            if out.get('interrupted'):
                raise ShotInterrupted(shot.result)
            shot.take(t, out)
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _run_dask(shot: _Shot, tasks: list[Task], client) -> None:
    from distributed import as_completed
    from distributed.scheduler import KilledWorker
    job, o = shot.job, shot.o
    topic = f'rtc-progress-{job.shot}'
    client.subscribe_topic(topic, shot.progress.tally.event)
    futures = {}
    for i, t in enumerate(tasks):
        fn, args, kw = _call(t, job, o, report=Report(topic, t.key))
        kw.pop('should_stop', None)                    # a cluster's tasks are cancelled instead
        shot.result.bytes_to_worker.append(len(pickle.dumps((args, kw))))
        futures[client.submit(fn, *args, **kw, key=f'{t.key}-{job.shot}', priority=-i, pure=False)] = t

    def on_term(signum, frame):
        raise KeyboardInterrupt
    old = signal.signal(signal.SIGTERM, on_term)
    try:
        for fut in as_completed(list(futures)):
            t = futures.pop(fut)
            try:
                out = fut.result()
            except worker.TaskFailed as e:
                raise ShotError(str(e)) from None
            except KilledWorker as e:
                raise ShotError(f'frame {t.frame}: the workers running it died repeatedly ({e})') from None
            fut.release()
            shot.take(t, out)
    except KeyboardInterrupt:
        raise ShotInterrupted(shot.result) from None
    finally:
        signal.signal(signal.SIGTERM, old)
        if futures:
            client.cancel(list(futures), force=True)
        client.unsubscribe_topic(topic)
        shot.result.events = shot.progress.tally.events


def _probe(client, job, first, result) -> dict:
    """`worker.probe` of the first frame, here or as the shot's first Dask task (Ctrl-C: interrupted)."""
    try:
        if client is None:
            return worker.probe(job, first, first)
        return client.submit(worker.probe, job, first, first, key=f'rtc-probe-{job.shot}', pure=False).result()
    except worker.TaskFailed as e:
        raise ShotError(str(e)) from None
    except KeyboardInterrupt:
        raise ShotInterrupted(result) from None


def run_shot(job, frames: list, pattern: str, *, workers: int | None = None, scheduler: str | None = None,
             client=None, resume: bool = False, quiet: bool = False, split: int | None = None,
             tiles: int | None = None, echo=lambda message: None, watch=None) -> ShotResult:
    """Render `frames` of `job` to `pattern` (see frames.output_name); in this process when neither
    `workers`, `scheduler` nor `client` is given.  `split` / `tiles`: sample ranges per tile and
    tiles per frame (None: plan.split_for's choice, which keeps the workers busy).  `echo(message)`
    receives the user-facing notes (dashboard, warnings); `watch(frames, samples, rays)` every
    change of the progress."""
    t0 = _time.perf_counter()
    job = job if job.shot else worker.Job(**{**job.__dict__, 'shot': uuid.uuid4().hex[:12]})
    result = ShotResult(frames=len(frames))
    with contextlib.ExitStack() as stack:
        if client is None and (workers or scheduler):
            client = stack.enter_context(cluster(workers, scheduler, quiet))
        if client is not None and job.threads is None and not scheduler:
            job = worker.Job(**{**job.__dict__, 'threads': _thread_split(client)})
        if client is not None:
            result.workers = len(client.scheduler_info()['workers'])
            result.dashboard = _dashboard(client, remote=bool(scheduler))
            if result.dashboard:
                echo(f'rtc: Dask dashboard at {result.dashboard}')
        first = frames[0]
        info = _probe(client, job, first, result)
        o = info['options']
        result.probe_seconds = _time.perf_counter() - t0
        result.width, result.height, result.spp, result.warnings = o.width, o.height, o.spp, info['warnings']
        todo = []
        for f in frames:
            (result.skipped if resume and _already_written(output_name(pattern, f), o) else todo).append(f)
        how = split_for(len(todo), result.workers, o.width, o.height, o.spp, cluster=client is not None)
        if tiles is not None:
            how = Split(grid(o.width, o.height, tiles) if tiles > 1 else (None,), how.ranges)
        if split is not None:
            how = Split(how.tiles, split)
        tasks = plan(todo, o.spp, how)
        result.split, result.tiles, result.tasks = how.ranges, len(how.tiles), len(tasks)
        progress = _Progress(len(frames), len(todo) * o.width * o.height * o.spp, quiet, watch)
        progress.frame_done(len(result.skipped))
        shot = _Shot(job, todo, pattern, result, progress, o, how)
        try:
            if client is None:
                _run_local(shot, tasks)
            else:
                _run_dask(shot, tasks, client)
        finally:
            progress.close()
            result.wall_seconds = _time.perf_counter() - t0
            if client is None:
                worker.close()
    return result


def median(values) -> float:
    return statistics.median(values) if values else 0.0
