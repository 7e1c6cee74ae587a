"""Public entry points: compile a course XML scene to an in-memory USD stage or to files.

    stage, diagnostics = compile_to_stage("scene.xml", width=640, height=480)
    diagnostics = compile_file("scene.xml", "out/scene.usda", spp=64)

Both raise `CompileError` (with `.diagnostics`) when the input has errors; otherwise they return
the warnings.  `compile_file` never leaves a partial output: everything is written into a
temporary directory beside the output and moved into place only when complete (the side-asset
folder first, the main file last).
"""
from __future__ import annotations

import contextlib
import gc
import hashlib
import math
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from pxr import Usd

from . import envmap
from .bounds import check_transforms, world_bounds
from .diagnostics import CompileError, Diagnostic, Diagnostics
from .obj import ObjError, ObjMesh, load_obj
from .scene import MeshFile, Scene
from .usd_writer import AssetPlan, CompileOptions, WrittenScene, write_scene
from .xml_reader import read_scene

#: Sizes and sample counts are written as USD ints; what can be rendered is the renderer's to decide
#: (rtc.renderer.options), against the stage's render settings and its own command line.
MAX_INT = 2 ** 31 - 1
DEFAULT_WIDTH = 512
OUTPUT_SUFFIXES = (".usda", ".usdc", ".usd")
ENVIRONMENT_FILE = "environment_latlong.exr"


@contextlib.contextmanager
def _no_cyclic_gc():
    """A compile allocates hundreds of thousands of long-lived objects and frees them together at
    the end; CPython's cyclic collector would rescan them again and again (half the time of a
    10^5-placement compile).  Reference counting still frees everything."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@dataclass
class _Compiled:
    scene: Scene
    meshes: dict[Path, ObjMesh]
    options: CompileOptions
    bounds: object
    diags: Diagnostics


@_no_cyclic_gc()
def compile_to_stage(xml_path, *, width: Optional[int] = None, height: Optional[int] = None,
                     spp: Optional[int] = None, focus_distance: Optional[float] = None,
                     lens_radius: Optional[float] = None) -> tuple[Usd.Stage, list[Diagnostic]]:
    """Compile to a stage on an anonymous layer; asset paths are absolute, meshes inline."""
    c = _front_end(Path(xml_path), width, height, spp, focus_distance, lens_radius)
    env = None
    if c.scene.environment is not None:
        env = _cached_environment(c)
    plan = AssetPlan(anchor=None, side_dir="", meshes_inline=True)
    written = write_scene(c.scene, c.meshes, c.options, plan, c.bounds, env)
    stage = Usd.Stage.Open(written.root)
    return stage, c.diags.as_list()


@_no_cyclic_gc()
def compile_file(xml_path, out_path, *, width: Optional[int] = None, height: Optional[int] = None,
                 spp: Optional[int] = None, focus_distance: Optional[float] = None,
                 lens_radius: Optional[float] = None, strict: bool = False) -> list[Diagnostic]:
    """Compile to `out_path` (.usda, .usdc or .usd), atomically.  With a text (.usda) output each
    OBJ mesh goes to a .usdc beside it in `<stem>_assets/`; a converted environment map goes there
    too.  `strict`: warnings also fail (CompileError without errors) and nothing is written."""
    out = Path(out_path)
    if out.suffix not in OUTPUT_SUFFIXES:
        diags = Diagnostics(str(out))
        diags.error(f"the output must end in {', '.join(OUTPUT_SUFFIXES)}")
        raise CompileError(diags.as_list())
    c = _front_end(Path(xml_path), width, height, spp, focus_distance, lens_radius)
    if strict and len(c.diags):
        raise CompileError(c.diags.as_list())
    out = out.absolute()
    side_dir = f"{out.stem}_assets"
    plan = AssetPlan(anchor=out.parent, side_dir=side_dir, meshes_inline=out.suffix != ".usda")
    work = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        staged_assets = work / "assets"
        env = None
        if c.scene.environment is not None:
            staged_assets.mkdir()
            _convert_environment(c, staged_assets / ENVIRONMENT_FILE)
            env = plan.side_path(ENVIRONMENT_FILE)
        written = write_scene(c.scene, c.meshes, c.options, plan, c.bounds, env,
                              placements_as_text=out.suffix == ".usda")
        _export(written, work / out.name, staged_assets)
        _commit(work, out, staged_assets, out.parent / side_dir)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return c.diags.as_list()


@_no_cyclic_gc()
def check(xml_path, *, width: Optional[int] = None, height: Optional[int] = None,
          spp: Optional[int] = None, focus_distance: Optional[float] = None,
          lens_radius: Optional[float] = None) -> list[Diagnostic]:
    """Everything `compile_file` checks (scene, meshes, transforms, options) without writing."""
    return _front_end(Path(xml_path), width, height, spp, focus_distance, lens_radius).diags.as_list()


# ----------------------------------------------------------------------------- front end
def _front_end(path: Path, width, height, spp, focus_distance, lens_radius) -> _Compiled:
    options = _compile_options(width, height, spp, focus_distance, lens_radius)
    diags = Diagnostics(str(path))
    scene = read_scene(path, diags)
    meshes = _load_meshes(scene, diags)
    check_transforms(scene, diags)
    diags.raise_if_errors()
    return _Compiled(scene, meshes, options, world_bounds(scene, meshes), diags)


def _compile_options(width, height, spp, focus_distance, lens_radius) -> CompileOptions:
    diags = Diagnostics("command line")
    if width is None and height is None:
        width = height = DEFAULT_WIDTH
    width = width if width is not None else height          # course: height defaults to width
    height = height if height is not None else width
    for flag, value in (("--width", width), ("--height", height), ("--spp", spp)):
        if value is not None and not 1 <= value <= MAX_INT:
            diags.error(f"{flag} {value} is out of range (1 to {MAX_INT})")
    if focus_distance is not None and not (math.isfinite(focus_distance) and focus_distance > 0):
        diags.error(f"--focus-distance must be a positive number, got {focus_distance}")
    if lens_radius is not None and not (math.isfinite(lens_radius) and lens_radius >= 0):
        diags.error(f"--lens-radius must be a number >= 0, got {lens_radius}")
    diags.raise_if_errors()
    return CompileOptions(width, height, spp, focus_distance, lens_radius)


def _load_meshes(scene: Scene, diags: Diagnostics) -> dict[Path, ObjMesh]:
    """Each OBJ file once, however many shapes and prototypes use it."""
    uses = [s.geometry for s in scene.shapes] + [p.geometry for p in scene.used_prototypes()]
    meshes: dict[Path, ObjMesh] = {}
    for geometry in uses:
        if not isinstance(geometry, MeshFile) or geometry.path in meshes:
            continue
        try:
            mesh = load_obj(geometry.path)
        except ObjError as exc:
            where = f"{geometry.path.name}:{exc.line}" if exc.line else geometry.path.name
            diags.error(f"{where}: {exc.message}", geometry.line, "file")
            continue
        except OSError as exc:
            diags.error(f"cannot read {geometry.path}: {exc.strerror or exc}", geometry.line, "file")
            continue
        for line, message in mesh.warnings:
            diags.warning(f"{geometry.path.name}:{line}: {message}", geometry.line, "file")
        meshes[geometry.path] = mesh
    return meshes


# ----------------------------------------------------------------------------- environment
def _convert_environment(c: _Compiled, target: Path) -> None:
    try:
        envmap.write_latlong(c.scene.environment.faces, target)
    except envmap.CubeMapError as exc:
        c.diags.error(str(exc), None, "envMapPrefix")
        raise CompileError(c.diags.as_list()) from None


def _cached_environment(c: _Compiled) -> str:
    """In-memory stages need the lat-long image on disk too: convert once into a cache folder
    keyed by the faces' paths, sizes and modification times."""
    key = hashlib.sha256()
    for p in c.scene.environment.faces.values():
        st = p.stat()
        key.update(f"{p}|{st.st_size}|{st.st_mtime_ns}".encode())
    cache = Path(tempfile.gettempdir()) / "rtc-environment-cache"
    cache.mkdir(exist_ok=True)
    target = cache / f"{key.hexdigest()[:24]}.exr"
    if not target.is_file():
        partial = cache / f".{target.name}.{os.getpid()}.exr"
        _convert_environment(c, partial)
        os.replace(partial, target)
    return target.as_posix()


# ----------------------------------------------------------------------------- output
def _export(written: WrittenScene, main: Path, assets: Path) -> None:
    if written.side_layers:
        assets.mkdir(exist_ok=True)
    for name, layer in written.side_layers.items():
        _checked_export(layer, assets / name)
    if written.placements_text is None:
        _checked_export(written.root, main)
    else:
        main.write_text(written.root_text(), encoding="utf-8")


def _checked_export(layer, path: Path) -> None:
    if not layer.Export(str(path)):
        raise OSError(f"could not write {path}")


def _commit(work: Path, out: Path, staged_assets: Path, final_assets: Path) -> None:
    """Move the finished files into place: the asset folder (replacing the previous one), then the
    main file with os.replace, so a reader never sees a main file whose assets are missing."""
    if staged_assets.is_dir():
        if final_assets.exists():
            os.replace(final_assets, work / "previous-assets")
        os.replace(staged_assets, final_assets)
    os.replace(work / out.name, out)
