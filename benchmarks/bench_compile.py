"""Compiler benchmarks: OBJ parsing (rtc's vectorised parser vs trimesh) and compile time / output
size for generated scenes of 10^3, 10^4, 10^5 placements of one 100k-triangle mesh.

    python benchmarks/bench_compile.py [--counts 1000 10000 100000] [--repeat 3] [--split]

Prints Markdown tables for benchmarks/RESULTS.md ("Compiler"); `--split` adds where the time goes
(read = XML parse, schema check and typed reading; prepare = OBJ load, transform checks, bounds;
author = building the USD layers; write = exporting them).  The mesh is the course's
dragon (100,000 triangles) when shared/corpus is beside the repo, else a generated 100k-triangle
grid.  Each placement has its own translate / rotateY / scale / rotateX, like the course dragons.
"""
from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numpy as np
from pxr import Sdf

REPO = Path(__file__).resolve().parents[1]

from rtc.compiler import api  # noqa: E402
from rtc.compiler.api import compile_file  # noqa: E402
from rtc.compiler.bounds import check_transforms, world_bounds  # noqa: E402
from rtc.compiler.diagnostics import Diagnostics  # noqa: E402
from rtc.compiler.obj import load_obj  # noqa: E402
from rtc.compiler.usd_writer import AssetPlan, CompileOptions, write_scene  # noqa: E402
from rtc.compiler.xml_reader import read_scene  # noqa: E402

DRAGON = REPO.parent / "shared" / "corpus" / "course" / "scenes_B" / "objFiles" / "dragon.obj"


def mesh_file(work: Path) -> Path:
    if DRAGON.is_file():
        return DRAGON
    n = 224                                     # 224 x 224 quads x 2 = 100,352 triangles
    path = work / "grid.obj"
    u = np.linspace(-1, 1, n + 1)
    x, z = np.meshgrid(u, u)
    y = 0.1 * np.sin(4 * x) * np.cos(4 * z)
    lines = [f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in zip(x.ravel(), y.ravel(), z.ravel())]
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1) + 1
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    lines += [f"f {p} {q} {r}\nf {p} {r} {s}" for p, q, r, s in zip(a, b, c, d)]
    path.write_text("\n".join(lines) + "\n")
    return path


def scene_file(work: Path, mesh: Path, count: int) -> Path:
    rng = np.random.default_rng(count)
    side = math.ceil(math.sqrt(count))
    parts = [f"""<?xml version="1.0" encoding="UTF-8" ?>
<scene bgColor="0.2 0.2 0.2">
  <camera name="main" type="perspective"><position>0 {side} {side * 2}</position>
    <lookatPoint>0 0 0</lookatPoint><focalLength>0.4</focalLength><imagePlaneWidth>0.5</imagePlaneWidth></camera>
  <light type="point"><position>0 {side * 3} 0</position><intensity>1 1 1</intensity></light>
  <shader name="blue" type="Lambertian"><diffuse>0.2 0.3 0.9</diffuse></shader>
  <instance name="model" type="mesh"><file>{mesh}</file><shader ref="blue"/></instance>
"""]
    for i in range(count):
        tx, tz = 3.0 * (i % side - side / 2), 3.0 * (i // side - side / 2)
        s = rng.uniform(0.5, 1.5)
        parts.append(f'<shape name="m{i}" type="instance" id="model"><transform>'
                     f'<translate>{tx:.3f} {s:.3f} {tz:.3f}</translate><rotate axis="Y">{rng.uniform(0, 360):.2f}</rotate>'
                     f'<scale>{s:.3f} {s:.3f} {s:.3f}</scale><rotate axis="X">-90</rotate></transform></shape>\n')
    parts.append("</scene>\n")
    path = work / f"placements_{count}.xml"
    path.write_text("".join(parts))
    return path


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def phase_times(xml: Path, out: Path) -> dict[str, float]:
    """compile_file's steps, timed one by one (same calls, cyclic GC off as in compile_file)."""
    times, start = {}, time.perf_counter()

    def lap(name):
        nonlocal start
        now = time.perf_counter()
        times[name], start = now - start, now

    with api._no_cyclic_gc():
        diags = Diagnostics(str(xml))
        scene = read_scene(xml, diags)
        lap("read")
        meshes = api._load_meshes(scene, diags)
        check_transforms(scene, diags)
        bounds = world_bounds(scene, meshes)
        lap("prepare")
        plan = AssetPlan(anchor=out.parent, side_dir=f"{out.stem}_assets", meshes_inline=out.suffix != ".usda")
        written = write_scene(scene, meshes, CompileOptions(), plan, bounds,
                              placements_as_text=out.suffix == ".usda")
        lap("author")
        api._export(written, out, out.parent / plan.side_dir)
        lap("write")
    return times


def output_size(out: Path) -> int:
    files = [out] + sorted((out.parent / f"{out.stem}_assets").glob("*"))
    return sum(f.stat().st_size for f in files if f.is_file())


def mesh_prims(out: Path) -> int:
    """Mesh prims with points across the output's layers (must be 1: the mesh is written once)."""
    count = 0
    for path in [out, *sorted((out.parent / f"{out.stem}_assets").glob("*.usdc"))]:
        layer = Sdf.Layer.FindOrOpen(str(path))
        stack = [layer.pseudoRoot]
        while stack:
            spec = stack.pop()
            stack.extend(spec.nameChildren)
            if "points" in getattr(spec, "attributes", {}):
                count += 1
    return count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[1000, 10000, 100000])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--split", action="store_true", help="also time read / prepare / author / write")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, {platform.processor() or '?'}, Python {platform.python_version()}, "
          f"{platform.system()} {platform.release()}; date {date.today()}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        mesh = mesh_file(work)
        tri = len(load_obj(mesh).triangles)
        print(f"\nOBJ parsing, {mesh.name} ({tri} triangles), median of {max(args.repeat, 5)}:")
        ours = median_time(lambda: load_obj(mesh), max(args.repeat, 5))
        try:
            import trimesh
            theirs = median_time(lambda: trimesh.load(str(mesh), process=False, force="mesh"),
                                 max(args.repeat, 5))
            print(f"| parser | time (s) |\n|---|---|\n| compiler.obj (numpy) | {ours:.3f} |\n"
                  f"| trimesh {trimesh.__version__} (process=False) | {theirs:.3f} |")
        except ImportError:
            print(f"| compiler.obj (numpy) | {ours:.3f} |")
        print(f"\nCompile, {mesh.name} x N placements, median of {args.repeat}:")
        print("| placements | XML (MB) | .usda + .usdc mesh: time (s) | size (MB) | .usdc: time (s) | size (MB) | mesh prims |")
        print("|---|---|---|---|---|---|---|")
        for n in args.counts:
            xml = scene_file(work, mesh, n)
            row = [f"{n:,}", f"{xml.stat().st_size / 1e6:.1f}"]
            prims = None
            for suffix in (".usda", ".usdc"):
                out = work / f"out_{n}{suffix}"
                t = median_time(lambda: compile_file(xml, out), args.repeat)
                row += [f"{t:.2f}", f"{output_size(out) / 1e6:.1f}"]
                prims = mesh_prims(out) if prims is None else prims
            print("| " + " | ".join(row + [str(prims)]) + " |", flush=True)
        if args.split:
            print(f"\nWhere the time goes (s), median of {args.repeat}:")
            print("| placements | output | read | prepare | author | write |\n|---|---|---|---|---|---|")
            for n in args.counts:
                xml = work / f"placements_{n}.xml"
                for suffix in (".usda", ".usdc"):
                    runs = [phase_times(xml, work / f"split_{n}{suffix}") for _ in range(args.repeat)]
                    cells = [f"{statistics.median(r[k] for r in runs):.2f}" for k in runs[0]]
                    print(f"| {n:,} | {suffix} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
