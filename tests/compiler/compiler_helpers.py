"""Helpers for the compiler tests: paths, a usdchecker stand-in, a CLI runner, scene snippets."""
from __future__ import annotations

import os
from pathlib import Path

from click.testing import CliRunner
from pxr import UsdValidation

from rtc.compiler.cli import compile_cmd

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"
# the shared folder beside the repository, or wherever RTC_SHARED points (as in tests/interop)
CORPUS = Path(os.environ.get("RTC_SHARED", REPO.parent / "shared")) / "corpus"


def validation_errors(stage) -> list[str]:
    """UsdValidation with every registered validator (the usdchecker equivalent): errors only."""
    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    return [f"{e.GetName()}: {e.GetMessage()}" for e in context.Validate(stage)
            if e.GetType() == UsdValidation.ValidationErrorType.Error]


def run_compile(*args: str):
    """Invoke `rtc compile` in-process; returns click's Result (exit_code, stderr)."""
    return CliRunner().invoke(compile_cmd, [str(a) for a in args], catch_exceptions=False)


def write_scene(tmp_path: Path, body: str, name: str = "scene.xml", root_attrs: str = "") -> Path:
    """A scene file with a standard camera and light around `body`."""
    text = f"""<?xml version="1.0" encoding="UTF-8" ?>
<scene{root_attrs}>
  <camera name="main" type="perspective">
    <position>0 1 5</position>
    <viewDir>0 0 -1</viewDir>
    <focalLength>0.4</focalLength>
    <imagePlaneWidth>0.5</imagePlaneWidth>
  </camera>
  <light type="point"><position>0 10 0</position><intensity>1 1 1</intensity></light>
  <shader name="grey" type="Lambertian"><diffuse>0.5 0.5 0.5</diffuse></shader>
{body}
</scene>
"""
    path = tmp_path / name
    path.write_text(text)
    return path
