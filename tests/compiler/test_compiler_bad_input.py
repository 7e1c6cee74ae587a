"""Bad input through `rtc compile`: exact message, exit status, and no output file left behind."""
from __future__ import annotations

import pytest

from tests.compiler.compiler_helpers import run_compile, write_scene

SPHERE = '<shape name="s" type="sphere"><shader ref="grey"/><center>{c}</center><radius>{r}</radius>{x}</shape>'


def sphere(c="0 0 0", r="1", x=""):
    return SPHERE.format(c=c, r=r, x=x)


CASES = {
    "non-numeric": (sphere(c="0 0 x"), 2, ["11: error: <center>: expected 3 numbers, got '0 0 x'"]),
    "wrong arity": (sphere(c="0 0"), 2, ["11: error: <center>: expected 3 numbers, got 2: '0 0'"]),
    "nan": (sphere(r="NaN"), 2, ["11: error: <radius>: NaN and infinity are not allowed: 'NaN'"]),
    "inf": (sphere(c="0 inf 0"), 2, ["11: error: <center>: NaN and infinity are not allowed: '0 inf 0'"]),
    "beyond float": (sphere(r="1e39"), 2, ["11: error: <radius>: '1e39' is beyond the 32-bit float range "
                                           "(magnitude at most 3.402823e+38) in which USD and the renderer hold it"]),
    "beyond float, one of three": (sphere(c="0 -3.5e38 0"), 2,
                                   ["11: error: <center>: '0 -3.5e38 0' is beyond the 32-bit float range "
                                    "(magnitude at most 3.402823e+38) in which USD and the renderer hold it"]),
    "negative radius": (sphere(r="-1"), 2, ["11: error: <radius>: must be positive, got -1"]),
    "dangling shader": (sphere().replace('ref="grey"', 'ref="gray"'), 2,
                        ["11: error: <shader>: unknown shader 'gray' (defined before this point: grey)",
                         "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "dangling prototype": ('<shape name="s" type="instance" id="egg"/>', 2,
                           ["11: error: <shape>: unknown instance prototype 'egg' (defined before this point: "
                            "none defined)",
                            "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "singular transform": (sphere(x="<transform><scale>1 0 1</scale></transform>"), 2,
                           ["11: error: <transform>: the transform is singular (a zero scale or collapsed axes): "
                            "it has no inverse"]),
    "collapsed axes": (sphere(x="<transform><scale>1 1e-300 1</scale><scale>1 1e-300 1</scale></transform>"), 2,
                       ["11: error: <transform>: the transform is singular (a zero scale or collapsed axes): "
                        "it has no inverse"]),
    "overflowing transform": (sphere(x="<transform><scale>1e200 1 1</scale><scale>1e200 1 1</scale></transform>"), 2,
                              ["11: error: <transform>: the transform is not finite (its product overflows)"]),
    "transform beyond float": (sphere(x="<transform><translate>1e200 0 0</translate></transform>"), 2,
                               ["11: error: <transform>: the transform is beyond the 32-bit float range (an entry of "
                                "magnitude above 3.402823e+38) in which the renderer places instances"]),
    "bad axis": (sphere(x='<transform><rotate axis="x">30</rotate></transform>'), 2,
                 ["11: error: <rotate>: attribute 'axis': 'x' is not one of 'X', 'Y', 'Z'"]),
    "no shader": ('<shape name="s" type="sphere"><center>0 0 0</center><radius>1</radius></shape>', 2,
                  ["11: error: <shape>: this shape needs a <shader> (the course requires one on every plain "
                   "shape and prototype)",
                   "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "missing geometry": ('<shape name="s" type="box"><shader ref="grey"/><minPt>0 0 0</minPt></shape>', 2,
                         ["11: error: <shape>: a box needs <maxPt>"]),
    # warnings: exit 1 with --strict, nothing written
    "misspelt shape type": (sphere().replace('"sphere"', '"spheer"'), 1,
                            ["11: warning: <shape>: unknown shape type 'spheer': read as a sphere"]),
    "student skysphere": (sphere().replace('"sphere"', '"skysphere"'), 1,
                          ["11: warning: <shape>: unknown shape type 'skysphere': read as a sphere (seen from "
                           "inside when the camera is in it)"]),
    "unknown shape type": ('<shape name="p" type="pyramid"><shader ref="grey"/></shape>', 1,
                           ["11: warning: <shape>: unknown shape type 'pyramid': no course reading, the shape is "
                            "omitted",
                            "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "unknown prototype type": ('<instance name="p" type="pyramid"><shader ref="grey"/></instance>'
                               '<shape type="instance" id="p"/>', 1,
                               ["11: warning: <instance>: unknown shape type 'pyramid': no course reading, the "
                                "prototype and its placements are omitted",
                                "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "misspelt shader type": ('<shader name="x" type="Mirrored"/>', 1,
                             ["11: warning: <shader>: unknown shader type 'Mirrored': read as Mirror",
                              "10: warning: <shader>: shader 'grey' is never used and is not written",
                              "11: warning: <shader>: shader 'x' is never used and is not written"]),
    "student shader type": ('<shader name="x" type="Perlin"><diffuse>1 0 0</diffuse></shader>'
                            + sphere().replace('ref="grey"', 'ref="x"'), 1,
                            ["11: warning: <shader>: unknown shader type 'Perlin': read as a Lambertian of its "
                             "diffuse colour",
                             "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "shader missing parameters": ('<shader name="x" type="BlinnPhong"><diffuse>1 0 0</diffuse></shader>'
                                  + sphere().replace('ref="grey"', 'ref="x"'), 1,
                                  ["11: warning: <shader>: a BlinnPhong shader has no <specular>: using the "
                                   "course's default 0 0 0",
                                   "11: warning: <shader>: a BlinnPhong shader has no <phongExp>: using the "
                                   "course's default 1",
                                   "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "missing mesh": ('<instance name="m" type="mesh"><file>objFiles/none.obj</file><shader ref="grey"/></instance>'
                     '<shape type="instance" id="m"/>', 1,
                     ["11: warning: <file>: mesh file 'objFiles/none.obj' not found (looked for "
                      "{dir}/objFiles/none.obj); the prototype and its placements are omitted"]),
    "missing plain mesh": ('<shape name="m" type="mesh"><file>none.obj</file><shader ref="grey"/></shape>', 1,
                           ["11: warning: <file>: mesh file 'none.obj' not found (looked for {dir}/none.obj); the "
                            "shape is omitted"]),
    "missing texture": ('<texture name="t" type="image"><sourcefile>images/none.png</sourcefile></texture>', 1,
                        ["11: warning: <sourcefile>: texture image 'images/none.png' not found (looked for "
                         "{dir}/images/none.png); the shader's colour is used instead",
                         "10: warning: <shader>: shader 'grey' is never used and is not written"]),
    "duplicate definition": ('<shader name="grey" type="Mirror"/>' + sphere(), 1,
                             ["11: warning: <shader>: shader 'grey' is already defined at line 10; the first "
                              "definition is used (as the course parser does)"]),
    "unknown element and attribute": (sphere(x="<wireframe/>").replace('type="sphere"', 'type="sphere" color="red"'), 1,
                                      ["11: warning: <shape>: unknown attribute 'color' ignored",
                                       "11: warning: <wireframe>: unknown element ignored (not allowed inside <shape>)"]),
    "greedy numbers": ('<shape name="b" type="box"><shader ref="grey"/><minPt>-5.5.0 0.0 -7.5</minPt>'
                       '<maxPt>1 1 1</maxPt></shape>', 1,
                       ["11: warning: <minPt>: malformed numbers '-5.5.0 0.0 -7.5' read as -5.5 0 0 (the "
                        "course's C++ parser reads greedily); please fix the file"]),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_bad_scene(case, tmp_path):
    body, status, lines = CASES[case]
    scene = write_scene(tmp_path, body)
    out = tmp_path / "out.usda"
    result = run_compile(scene, "-o", out, "--strict")
    expected = [f"{scene}:{line.format(dir=tmp_path)}" for line in lines]
    assert (result.exit_code, result.stderr.splitlines()) == (status, expected)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.xml"]


def test_warnings_without_strict_still_compile(tmp_path):
    scene = write_scene(tmp_path, '<shader name="grey" type="Mirror"/>' + sphere())
    result = run_compile(scene, "-o", tmp_path / "out.usda")
    assert result.exit_code == 0 and "already defined" in result.stderr
    assert (tmp_path / "out.usda").is_file()


LFS = "version https://git-lfs.github.com/spec/v1\noid sha256:4d7a2146\nsize 5174\n"


def test_lfs_pointers_fall_back_and_compile(tmp_path):
    """A Git LFS pointer in place of the PNG and of the OBJ (as student repositories have them):
    warnings naming file and line, the shader's colour, the mesh's shapes omitted, exit 0; the
    written stage has the sphere and no mesh; --strict makes it exit 1 and write nothing."""
    (tmp_path / "tex.png").write_text(LFS)
    (tmp_path / "dragon.obj").write_text(LFS)
    scene = write_scene(tmp_path, '<texture name="t" type="image"><sourcefile>tex.png</sourcefile></texture>'
                                  '<shader name="tx" type="Lambertian"><diffuse tex="t">1 1 1</diffuse></shader>'
                                  '<instance name="d" type="mesh"><file>dragon.obj</file><shader ref="grey"/>'
                                  '</instance><shape name="p" type="instance" id="d"/>'
                                  + sphere().replace('ref="grey"', 'ref="tx"'))
    out = tmp_path / "out.usda"
    strict = run_compile(scene, "-o", out, "--strict")
    assert strict.exit_code == 1 and not out.exists()
    result = run_compile(scene, "-o", out)
    lines = result.stderr.splitlines()
    assert result.exit_code == 0, result.stderr
    assert lines[0].startswith(f"{scene}:11: warning: <sourcefile>: texture image {tmp_path}/tex.png: ")
    assert lines[0].endswith("; the shader's colour is used instead")
    assert lines[1] == (f"{scene}:11: warning: <file>: mesh file {tmp_path}/dragon.obj is a Git LFS pointer, "
                        "not the mesh (fetch it with 'git lfs pull'); the shapes that use it are omitted")
    from pxr import Usd, UsdGeom
    stage = Usd.Stage.Open(str(out))
    gprims = [p for p in stage.Traverse() if p.IsA(UsdGeom.Gprim)]
    assert [(p.GetName(), p.GetAttribute("rtc:implicit").Get()) for p in gprims] == [("s", "Sphere")]
    assert not [p for p in stage.Traverse() if p.GetTypeName() == "UsdUVTexture" or
                p.GetAttribute("info:id").Get() == "UsdUVTexture"]


def test_malformed_xml(tmp_path):
    scene = tmp_path / "scene.xml"
    scene.write_text('<?xml version="1.0"?>\n<scene>\n<camera>\n</scene>\n')
    result = run_compile(scene, "-o", tmp_path / "out.usda")
    assert result.exit_code == 2
    assert result.stderr == (f"{scene}:4: error: malformed XML: Opening and ending tag mismatch: camera line 3 "
                             "and scene, line 4, column 9\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.xml"]


def test_missing_scene_file(tmp_path):
    result = run_compile(tmp_path / "none.xml", "-o", tmp_path / "out.usda")
    assert (result.exit_code, result.stderr) == (2, f"{tmp_path}/none.xml: error: cannot read the scene file: "
                                                    "No such file or directory\n")


def test_unwritable_output_is_an_error_not_a_traceback(tmp_path):
    scene = write_scene(tmp_path, sphere())
    result = run_compile(scene, "-o", tmp_path / "no" / "such" / "dir" / "out.usda")
    assert result.exit_code == 2 and "error: No such file or directory" in result.stderr


def test_broken_obj_names_both_files(tmp_path):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\n")
    scene = write_scene(tmp_path, '<instance name="m" type="mesh"><file>bad.obj</file><shader ref="grey"/>'
                                  '</instance><shape type="instance" id="m"/>')
    result = run_compile(scene, "-o", tmp_path / "out.usda")
    assert (result.exit_code, result.stderr) == (
        2, f"{scene}:11: error: <file>: bad.obj:3: face refers to vertex 3, but the file defines 2 such entries\n")


def test_check_only_writes_nothing(tmp_path):
    scene = write_scene(tmp_path, sphere())
    result = run_compile(scene, "--check")
    assert (result.exit_code, result.stderr) == (0, "")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.xml"]
