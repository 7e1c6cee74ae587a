"""Hostile input (issue #6, compiler share): entities, external files, absurd render parameters."""
from __future__ import annotations

import pytest

from tests.compiler.compiler_helpers import run_compile, write_scene

DOCTYPE_ERROR = ("2: error: a <!DOCTYPE> is not allowed in a scene file (entity declarations could expand "
                 "without bound or read other files)")

XXE = """<?xml version="1.0"?>
<!DOCTYPE scene [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<scene bgColor="&secret;"/>
"""

BOMB = """<?xml version="1.0"?>
<!DOCTYPE scene [
 <!ENTITY a "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa">
 <!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">
 <!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">
 <!ENTITY d "&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;">
 <!ENTITY e "&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;">
 <!ENTITY f "&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;">
 <!ENTITY g "&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;">
]>
<scene><sceneParameters><envMapPrefix>&g;</envMapPrefix></sceneParameters></scene>
"""


@pytest.mark.parametrize("text", [XXE, BOMB], ids=["xxe", "entity-bomb"])
def test_entities_are_refused(text, tmp_path):
    scene = tmp_path / "scene.xml"
    scene.write_text(text)
    result = run_compile(scene, "-o", tmp_path / "out.usda")
    assert (result.exit_code, result.stderr) == (2, f"{scene}:{DOCTYPE_ERROR}\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.xml"]


@pytest.mark.parametrize("args, message", [
    # the compiler only refuses values a stage cannot hold; what can be rendered is the renderer's
    # to decide (tests/test_options.py)
    (["--width", "3000000000", "--height", "8"], "command line: error: --width 3000000000 is out of range (1 to 2147483647)"),
    (["--spp", "0"], "command line: error: --spp 0 is out of range (1 to 2147483647)"),
    (["--width", "0"], "command line: error: --width 0 is out of range (1 to 2147483647)\n"
                       "command line: error: --height 0 is out of range (1 to 2147483647)"),
    (["--focus-distance", "nan"], "command line: error: --focus-distance must be a positive number, got nan"),
    (["--lens-radius", "-1"], "command line: error: --lens-radius must be a number >= 0, got -1.0"),
])
def test_absurd_render_parameters_are_rejected(args, message, tmp_path):
    scene = write_scene(tmp_path, "")
    result = run_compile(scene, "-o", tmp_path / "out.usda", *args)
    assert (result.exit_code, result.stderr) == (2, message + "\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.xml"]


def test_wrong_output_suffix(tmp_path):
    scene = write_scene(tmp_path, "")
    result = run_compile(scene, "-o", tmp_path / "out.png")
    assert (result.exit_code, result.stderr) == (
        2, f"{tmp_path}/out.png: error: the output must end in .usda, .usdc, .usd\n")
