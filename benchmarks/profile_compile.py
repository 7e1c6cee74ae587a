"""Where a cold compile of the render kernels goes, per numba function.

    XDG_CACHE_HOME=$(mktemp -d) python benchmarks/profile_compile.py scenes/gallery.xml

Compiles the scene's kernels from an empty cache (the first render of a fresh machine) and prints
the wall and CPU seconds, the time numba held its LLVM lock (in all, and per function), and the self time (exclusive of nested
compiles) and number of specialisations of every function numba compiled (functions inlined at numba
IR level are part of their caller's time).  CPU seconds are the figure to compare on a shared machine.
"""
import sys
import time
from collections import defaultdict

import numba.core.event as ev

from rtc.compiler.api import compile_to_stage
from rtc.renderer.host.render import Renderer, RenderOptions
from rtc.renderer.usd.stage import read_stage


class Prof(ev.Listener):
    def __init__(self):
        self.stack = []
        self.self_time = defaultdict(float)
        self.count = defaultdict(int)
        self.llvm = 0.0
        self.llvm_self = defaultdict(float)
        self._llvm_t = None

    def on_start(self, event):
        if event.kind == 'numba:compile':
            d = event.data['dispatcher']
            self.stack.append([d.py_func.__module__.split('.')[-1] + '.' + d.py_func.__qualname__, time.perf_counter(), 0.0])
        elif event.kind == 'numba:llvm_lock':
            self._llvm_t = time.perf_counter()

    def on_end(self, event):
        if event.kind == 'numba:compile':
            name, t0, child = self.stack.pop()
            dt = time.perf_counter() - t0
            self.self_time[name] += dt - child
            self.count[name] += 1
            if self.stack:
                self.stack[-1][2] += dt
        elif event.kind == 'numba:llvm_lock' and self._llvm_t is not None:
            dt = time.perf_counter() - self._llvm_t
            self.llvm += dt
            if self.stack:
                self.llvm_self[self.stack[-1][0]] += dt
            self._llvm_t = None


prof = Prof()
ev.register('numba:compile', prof)
ev.register('numba:llvm_lock', prof)
stage, _ = compile_to_stage(sys.argv[1])
desc = read_stage(stage)
with Renderer(desc) as r:
    w0, c0 = time.perf_counter(), time.process_time()
    res = r.render(RenderOptions(width=32, height=24, spp=1, integrator=(sys.argv[2] if len(sys.argv) > 2 else None)))
    print(f'kernel {res.stats.kernel_seconds:.1f} s wall; {time.process_time() - c0:.1f} s cpu; '
          f'llvm (lock held) {prof.llvm:.1f} s')
tot = sum(prof.self_time.values())
print(f'sum of self times {tot:.1f} s over {len(prof.self_time)} functions')
for name, t in sorted(prof.self_time.items(), key=lambda kv: -kv[1])[:40]:
    print(f'{t:7.2f} s  x{prof.count[name]}  {name}  (llvm {prof.llvm_self[name]:.2f} s)')
