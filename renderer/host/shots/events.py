"""Progress of running tasks, from the workers to the `rtc render` process, while they render.

A task calls its `report(samples, rays)` after each pass with what it has rendered so far (samples:
pixel samples, so that tiles and sample ranges add up).  On Dask, `Report` sends that as a Dask
event (`Worker.log_event` on the shot's own topic); the scheduler forwards it to the client, which
subscribed with `Client.subscribe_topic` and hands it to `Tally.event`.  In this process the report
goes to the `Tally` directly.  A report is at most one small message per `Report.interval` per
task (0.25 s; Renderer passes last about a second each): benchmarks/bench_shot.py `events` measures
what one costs.

`Tally` keeps the latest figures per task key: a task rerun elsewhere (its worker died) starts
again from zero under the same key, and its final result replaces whatever it reported (a report
that arrives after the result is ignored).
"""
from __future__ import annotations

import threading
import time as _time


class Report:
    """A task's progress reports as Dask events on `topic` (picklable: sent with the task)."""

    interval = 0.25

    def __init__(self, topic: str, key: str):
        self.topic, self.key = topic, key
        self.last = 0.0

    def __call__(self, samples: int, rays: int) -> None:
        now = _time.monotonic()
        if now - self.last < self.interval:
            return
        self.last = now
        try:
            from distributed import get_worker
            worker = get_worker()
        except (ImportError, ValueError):          # not on a Dask worker (called directly)
            return
        worker.log_event(self.topic, {'key': self.key, 'samples': int(samples), 'rays': int(rays)})


class Tally:
    """Samples and rays of every task of a shot, as last reported or finished; `changed()` is called
    (outside the lock) after each change."""

    def __init__(self, changed=lambda: None):
        self._lock = threading.Lock()
        self._live: dict[str, tuple[int, int]] = {}
        self._finished: set[str] = set()
        self.changed = changed
        self.events = 0

    def set(self, key: str, samples: int, rays: int) -> None:
        """What a running task reported."""
        with self._lock:
            if key in self._finished:
                return
            self._live[key] = (int(samples), int(rays))
        self.changed()

    def finish(self, key: str, samples: int, rays: int) -> None:
        """What a task's result says it did (final)."""
        with self._lock:
            self._finished.add(key)
            self._live[key] = (int(samples), int(rays))
        self.changed()

    def event(self, event) -> None:
        """A Dask event `(timestamp, {'key', 'samples', 'rays'})` (the subscription's handler)."""
        _, msg = event
        self.events += 1
        self.set(msg['key'], msg['samples'], msg['rays'])

    def reporter(self, key: str):
        """The report function of a task run in this process."""
        return lambda samples, rays: self.set(key, samples, rays)

    def totals(self) -> tuple[int, int]:
        with self._lock:
            return sum(v[0] for v in self._live.values()), sum(v[1] for v in self._live.values())
