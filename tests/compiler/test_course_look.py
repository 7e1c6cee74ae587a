"""The course look: 8-bit images encoded the course's way, the camera-inside warning."""
from __future__ import annotations

import numpy as np
import pytest
import OpenImageIO as oiio
from pxr import Usd, UsdRender

from rtc.renderer.host.film import write_image
from rtc.renderer.usd.stage import read_stage
from tests.compiler.compiler_helpers import run_compile, write_scene

INSIDE = """<shape name="sky" type="skysphere"><shader ref="grey"/><center>0 0 0</center><radius>50</radius></shape>
<instance name="unit" type="sphere"><shader ref="grey"/><center>0 0 0</center><radius>1</radius></instance>
<shape name="egg" type="instance" id="unit"><transform><translate>0 1 3</translate><scale>1 1 2.5</scale></transform></shape>
<shape name="near miss" type="instance" id="unit"><transform><translate>0 0 3</translate><scale>1 1 2.5</scale></transform></shape>
<shape name="box" type="box"><shader ref="grey"/><minPt>-1 0 4</minPt><maxPt>1 2 6</maxPt></shape>
<shape name="far box" type="box"><shader ref="grey"/><minPt>1 1 1</minPt><maxPt>2 2 2</maxPt></shape>
<shape name="can" type="cylinder"><shader ref="grey"/><center>0 1 5.5</center><radius>0.6</radius><height>1</height></shape>"""


def test_camera_inside_closed_shapes_is_warned(tmp_path):
    """The eye (0 1 5) is inside the skysphere, the ellipsoid placed at (0 1 3) with semi-axis 2.5
    along z (distance 2 < 2.5), the box and the cylinder; not inside the same ellipsoid one unit
    lower ((0 1 2)/(1 1 2.5) has length sqrt(1 + 0.64) > 1) nor the far box."""
    scene = write_scene(tmp_path, INSIDE)
    result = run_compile(scene, "-o", tmp_path / "out.usda")
    assert result.exit_code == 0
    inside = [line.split(": warning: ")[1] for line in result.stderr.splitlines() if "inside the" in line]
    assert inside == [f"<camera>: the camera is inside the closed {kind} of line {line}: camera rays meet its "
                      "inner side first, which hides what lies outside it"
                      for kind, line in (("sphere", 11), ("sphere", 13), ("box", 15))]
    assert result.stderr.splitlines()[-1] == f"{scene}:3: warning: <camera>: the camera is inside 1 more closed shapes"


def test_compiled_course_scene_asks_for_linear_8_bit_images(tmp_path):
    scene = write_scene(tmp_path, '<shape name="s" type="sphere"><shader ref="grey"/><center>0 0 0</center>'
                                  '<radius>1</radius></shape>')
    out = tmp_path / "out.usda"
    assert run_compile(scene, "-o", out).exit_code == 0
    stage = Usd.Stage.Open(str(out))
    settings = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings"))
    assert settings.GetPrim().GetAttribute("rtc:imageEncoding").Get() == "linear"
    assert read_stage(str(out)).settings.encoding == "linear"


def test_linear_and_srgb_encodings_of_an_8_bit_image(tmp_path):
    """Linear: code = round(255 v) (the course's `v * 255`); sRGB: the IEC 61966-2-1 curve
    (0.5 -> 0.7354 -> 188; 0.002 -> 12.92 * 0.002 -> 7)."""
    image = np.array([[[0.5, 0.002, 1.5]]], np.float32)
    codes = {}
    for encoding in ("linear", "srgb"):
        path = tmp_path / f"{encoding}.png"
        write_image(path, image, encoding=encoding)
        codes[encoding] = oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8)[0, 0].tolist()
    assert codes == {"linear": [128, 1, 255], "srgb": [188, 7, 255]}


def _render_codes(tmp_path, scene, *extra) -> list[int]:
    """`rtc render` (the real CLI, in a child process) of a 4 x 4 image; the first pixel's codes."""
    import subprocess
    import sys
    out = tmp_path / f"out{len(extra)}.png"
    done = subprocess.run([sys.executable, "-m", "rtc.cli", "render", str(scene), "-o", str(out), "--width", "4",
                           "--height", "4", "--spp", "1", "-q", *extra], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return oiio.ImageBuf(str(out)).get_pixels(oiio.UINT8)[0, 0].tolist()


def test_render_encodes_course_scenes_linear_and_other_usd_srgb(tmp_path):
    """Nothing to hit, a background of 0.5: a course scene gives code 128 (linear, the default for
    it) or 188 with --encoding srgb; a USD stage from elsewhere lit by a constant DomeLight of 0.5
    gives 188 (sRGB) unless --encoding linear."""
    from pxr import UsdLux
    scene = write_scene(tmp_path, "", root_attrs=' bgColor="0.5 0.5 0.5"')
    assert _render_codes(tmp_path, scene) == [128] * 3
    assert _render_codes(tmp_path, scene, "--encoding", "srgb") == [188] * 3
    foreign = tmp_path / "foreign.usda"
    stage = Usd.Stage.CreateNew(str(foreign))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr((0.5, 0.5, 0.5))
    stage.Save()
    assert _render_codes(tmp_path, foreign) == [188] * 3
    assert _render_codes(tmp_path, foreign, "--encoding", "linear") == [128] * 3


FLOOR = """<shape name="floor" type="box"><shader ref="grey"/><minPt>-50 -1 -50</minPt><maxPt>50 0 50</maxPt></shape>"""


def _course_scene(tmp_path, name, light):
    """A grey (kd 0.5) floor seen from (0 2 4) looking at the origin; only `light`."""
    text = f"""<?xml version="1.0" encoding="UTF-8" ?>
<scene>
  <camera name="main" type="perspective">
    <position>0 2 4</position><lookatPoint>0 0 0</lookatPoint>
    <focalLength>0.4</focalLength><imagePlaneWidth>0.5</imagePlaneWidth>
  </camera>
  {light}
  <shader name="grey" type="Lambertian"><diffuse>0.5 0.5 0.5</diffuse></shader>
  {FLOOR}
</scene>
"""
    path = tmp_path / f"{name}.xml"
    path.write_text(text)
    return path


def _centre(tmp_path, scene) -> float:
    """The centre pixel of a 41 x 41 cook render (linear EXR): the floor at the origin."""
    import subprocess
    import sys
    out = tmp_path / f"{scene.stem}.exr"
    done = subprocess.run([sys.executable, "-m", "rtc.cli", "render", str(scene), "-o", str(out), "--width", "41",
                           "--height", "41", "--spp", "16", "--filter", "box", "-q"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return float(oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)[20, 20].mean())


def test_course_lights_have_the_courses_semantics_in_cook(tmp_path):
    """The course shades a Lambertian point with kd * I * max(0, n.l): no distance fall-off and, for
    an area light, no cosine at the light and both sides lit.  A small light straight above the
    floor's origin (n.l = 1 there, within 0.2 % over the centre pixel) gives kd * I = 0.5 * 0.8 = 0.4:
    a point light one unit or three units up, an area light facing the floor, and an area light
    facing away from it (black under the physical convention)."""
    area = ('<light type="area"><position>0 1 0</position><intensity>0.8 0.8 0.8</intensity>'
            '<normal>{n}</normal><width>0.01</width><length>0.01</length></light>')
    lights = {
        "point_near": '<light type="point"><position>0 1 0</position><intensity>0.8 0.8 0.8</intensity></light>',
        "point_far": '<light type="point"><position>0 3 0</position><intensity>0.8 0.8 0.8</intensity></light>',
        "area_facing": area.format(n="0 -1 0"),
        "area_away": area.format(n="0 1 0"),
    }
    values = {name: _centre(tmp_path, _course_scene(tmp_path, name, light)) for name, light in lights.items()}
    assert values == pytest.approx({name: 0.4 for name in lights}, rel=5e-3)
