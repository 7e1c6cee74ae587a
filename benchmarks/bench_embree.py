"""Bare Embree throughput through the renderer's ray queries (benchmarks/embree_loops.py): the baseline the renderer is compared with.

Scene: one instance array of 400 instances (20 x 20 grid, random yaw, scale 0.4) of a 64 770-triangle
UV sphere - the scene of /work/shared/embree.md section 8.  Ray sets:
  primary  640x480 pinhole camera, rays in 4x4 pixel tiles (coherent; row order within a tile)
  random   origins uniform in the scene box, uniform directions (incoherent)
  shadow   from the primary hits to a point light, tfar = distance (occlusion only)
Both a ROBUST (the renderer's default) and a non-robust build are measured.
Every (scene, kernel, ray set) is timed once per round, rounds interleaved; medians of Mrays/s reported.
Numba start-up: fresh processes with an empty NUMBA_CACHE_DIR (cold: compile) and again with the
filled cache (warm: load), time from process start to the first traced batch of each kernel.

    python benchmarks/bench_embree.py [--rounds 11] [--jit-runs 3]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

KERNELS = ("trace_rays", "trace_packets", "occlude_rays", "occlude_packets")


def run_kernel(loops, kernel: str, handle: int, rays: tuple, out: tuple) -> None:
    """Call the `embree_loops` kernel named `kernel` on rays (origins, dirs, tnear, tfar, time): the packet
    loops take them as one tuple, the single-ray loops one by one."""
    fn = getattr(loops, kernel)
    if kernel.endswith("packets"):
        fn(handle, rays, *out)
    else:
        fn(handle, *rays, *out)


def uv_sphere(n: int):
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 2 * n), indexing="ij")
    v = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    a = (np.arange(n - 1)[:, None] * 2 * n + np.arange(2 * n - 1)[None, :]).ravel()
    b, c = a + 1, a + 2 * n
    return v.astype(np.float32), np.concatenate([np.stack([a, b, c], 1), np.stack([b, c + 1, c], 1)]).astype(np.uint32)


def build_scene(device, rng, robust):
    from rtc.renderer.host.embree import InstanceGroup
    proto = device.prototype_scene([uv_sphere(128)], [], robust=robust)
    gx, gz = np.meshgrid(np.arange(-10, 10), np.arange(-10, 10), indexing="ij")
    yaw = rng.uniform(0, 2 * np.pi, gx.size)
    c, s = np.cos(yaw) * 0.4, np.sin(yaw) * 0.4
    transforms = np.zeros((1, gx.size, 3, 4), np.float32)
    transforms[0, :, 0, 0], transforms[0, :, 0, 2], transforms[0, :, 1, 1] = c, s, 0.4
    transforms[0, :, 2, 0], transforms[0, :, 2, 2] = -s, c
    transforms[0, :, 0, 3], transforms[0, :, 2, 3] = gx.ravel() + 0.5, gz.ravel() + 0.5
    top = device.top_scene([proto], [InstanceGroup(np.zeros(gx.size, np.uint32), transforms)], robust=robust)
    return proto, top


def rays(origins, dirs, tfar=None):
    n = len(origins)
    tfar = np.full(n, np.inf, np.float32) if tfar is None else tfar.astype(np.float32)
    return (np.ascontiguousarray(origins, np.float32), np.ascontiguousarray(dirs, np.float32),
            np.zeros(n, np.float32), tfar, np.zeros(n, np.float32))


def primary_rays(width=640, height=480, tile=4):
    ty, tx, y, x = np.meshgrid(np.arange(height // tile), np.arange(width // tile), np.arange(tile),
                               np.arange(tile), indexing="ij")
    px, py = (tx * tile + x).ravel() + 0.5, (ty * tile + y).ravel() + 0.5
    d = np.stack([(px - width / 2) / width * 1.6, -(py - height / 2) / width * 1.6 - 0.5, -np.ones_like(px)], 1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return rays(np.tile([0.0, 6.0, 14.0], (len(d), 1)), d)


def random_rays(rng, lower, upper, n):
    d = rng.normal(size=(n, 3))
    return rays(rng.uniform(lower, upper, (n, 3)), d / np.linalg.norm(d, axis=1, keepdims=True))


def shadow_rays(primary, t, light=(3.0, 8.0, 2.0)):
    hit = np.isfinite(t)
    p = primary[0][hit] + t[hit, None] * primary[1][hit]
    to_light = np.asarray(light) - p
    dist = np.linalg.norm(to_light, axis=1)
    n = np.count_nonzero(hit)
    return rays(p + to_light / dist[:, None] * 1e-3, to_light / dist[:, None], dist * (1 - 1e-4)), n


def throughput(rounds: int):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # one module name for numba's cache: the tests'
    from benchmarks import embree_loops as trace
    from rtc.renderer.host.embree import Device
    rng = np.random.default_rng(0)
    with Device() as device:
        scenes = {robust: build_scene(device, rng, robust) for robust in (True, False)}
        lower, upper = scenes[True][1].bounds()
        sets = {"primary": primary_rays(), "random": random_rays(rng, lower, upper, 640 * 480)}
        n = len(sets["primary"][0])
        t, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
        trace.trace_rays(scenes[True][1].handle, *sets["primary"], t, ids)
        sets["shadow"], n_shadow = shadow_rays(sets["primary"], np.where(ids[:, 1] != 0xFFFFFFFF, t, np.inf))
        cases = [(k, s, r) for r in scenes for k in KERNELS for s in sets if not (k.startswith("trace") and s == "shadow")]
        outputs = {s: (np.empty(len(r[0]), np.float32), np.empty((len(r[0]), 4), np.uint32), np.empty(len(r[0]), bool))
                   for s, r in sets.items()}
        times = {case: [] for case in cases}
        for _ in range(rounds + 1):                       # round 0 = warm-up (JIT / cache load)
            for kernel, name, robust in cases:
                out_t, out_ids, out_occ = outputs[name]
                args = (out_t, out_ids) if kernel.startswith("trace") else (out_occ,)
                start = time.perf_counter()
                run_kernel(trace, kernel, scenes[robust][1].handle, sets[name], args)
                times[(kernel, name, robust)].append(time.perf_counter() - start)
        print(f"scene: 400 instances x 64770 triangles; {n} primary / random rays, {n_shadow} shadow rays; "
              f"{rounds} interleaved rounds, median Mrays/s")
        for robust in scenes:
            print(f"{'ROBUST' if robust else 'non-robust':16s}" + "".join(f"{s:>10s}" for s in sets))
            for kernel in KERNELS:
                row = ""
                for name in sets:
                    samples = times.get((kernel, name, robust))
                    row += f"{len(sets[name][0]) / np.median(samples[1:]) / 1e6:10.2f}" if samples else f"{'-':>10s}"
                print(f"  {kernel:14s}{row}")
        for proto, top in scenes.values():
            top.close()
            proto.close()


JIT_PROBE = """
import time, sys
start = time.perf_counter()
import numpy as np
from benchmarks import embree_loops as trace   # `python -c` run in the repository root
from rtc.renderer.host.embree import Device, InstanceGroup
imported = time.perf_counter()
with Device() as dev:
    proto = dev.prototype_scene([], [np.array([[0, 0, 0, 1]], np.float32)])
    top = dev.top_scene([proto], [InstanceGroup(np.zeros(1, np.uint32), np.eye(3, 4, dtype=np.float32)[None, None])])
    o, d = np.array([[0, 0, 5]], np.float32), np.array([[0, 0, -1]], np.float32)
    z = np.zeros(1, np.float32)
    t, ids, occ = np.empty(1, np.float32), np.empty((1, 4), np.uint32), np.empty(1, bool)
    first = {{}}
    for name in {kernels!r}:
        a = time.perf_counter()
        rays = (o, d, z, z + np.inf, z)
        out = (t, ids) if name.startswith("trace") else (occ,)
        fn = getattr(trace, name)
        fn(top.handle, rays, *out) if name.endswith("packets") else fn(top.handle, *rays, *out)
        first[name] = time.perf_counter() - a
    top.close()
print(imported - start, *first.values(), time.perf_counter() - start)
"""


def jit_startup(runs: int):
    script = JIT_PROBE.format(root=ROOT, kernels=KERNELS)
    results = {"cold": [], "warm": []}
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            for kind in ("cold", "warm"):
                out = subprocess.run([sys.executable, "-c", script], env=env, check=True, cwd=ROOT,
                                     capture_output=True, text=True).stdout
                results[kind].append([float(v) for v in out.split()])
    print(f"numba start-up, fresh processes, median of {runs} (seconds): "
          "import | first call of " + ", ".join(KERNELS) + " | process total to last first-call")
    for kind, samples in results.items():
        print(f"  {kind}: " + " ".join(f"{v:6.2f}" for v in np.median(samples, axis=0)))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=11)
    parser.add_argument("--jit-runs", type=int, default=3)
    args = parser.parse_args()
    jit_startup(args.jit_runs)
    throughput(args.rounds)


if __name__ == "__main__":
    main()
