"""Every course scene and every gallery scene compiles without errors and validates clean."""
from __future__ import annotations

import pytest
from pxr import Usd

from rtc.compiler.api import compile_file, compile_to_stage

from tests.compiler.compiler_helpers import SCENES, validation_errors

GALLERY = sorted(SCENES.glob("*.xml"))


def test_gallery_is_complete():
    names = {p.stem for p in GALLERY}
    assert {"gallery", "bunnies", "ellipsoids", "dof", "motion", "orthographic", "shaders", "cylinder",
            "envmap"} <= names


def test_course_scenes_compile_and_validate(course_scenes):
    assert len(course_scenes) == 24
    for path in course_scenes:
        stage, diagnostics = compile_to_stage(path)
        assert not [d for d in diagnostics if d.is_error]
        assert validation_errors(stage) == [], path.name


@pytest.mark.parametrize("path", GALLERY, ids=[p.stem for p in GALLERY])
@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_gallery_scene_compiles_to_files_and_validates(path, suffix, tmp_path):
    out = tmp_path / f"{path.stem}{suffix}"
    diagnostics = compile_file(path, out)
    assert diagnostics == []
    stage = Usd.Stage.Open(str(out))
    assert validation_errors(stage) == []
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert leftovers == []
