"""The course's no-fall-off lights under the physically based renderer: the compiler picks the
reference distance (median distance from the light to the rendered shapes) and scales the light so
that the irradiance there equals the course's intensity.  Pinned here end to end: XML -> USD ->
rendered pixel."""
import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Usd, UsdLux

from rtc.compiler.api import compile_to_stage
from rtc.renderer.host.film import read_image
from rtc.cli import main

# light at (0, 4, 0); shape centres at distances 3 (sphere), 4 (sphere) and 4.5 (floor box centre
# (0, -0.5, 0)): median 4 = the height of the light above the floor point the camera looks at.
SCENE = """<?xml version="1.0" encoding="UTF-8" ?>
<scene>
  <camera name="main" type="perspective">
    <position>0 3 3</position><lookatPoint>0 0 0</lookatPoint>
    <focalLength>1</focalLength><imagePlaneWidth>0.02</imagePlaneWidth>
  </camera>
  <light type="point"><position>0 4 0</position><intensity>0.8 0.6 0.4</intensity></light>
  <shader name="grey" type="Lambertian"><diffuse>0.5 0.5 0.5</diffuse></shader>
  <shape name="floor" type="box"><shader ref="grey"/><minPt>-20 -1 -20</minPt><maxPt>20 0 20</maxPt></shape>
  <shape name="near" type="sphere"><shader ref="grey"/><center>0 4 3</center><radius>0.5</radius></shape>
  <shape name="mid" type="sphere"><shader ref="grey"/><center>4 4 0</center><radius>0.5</radius></shape>
</scene>
"""


@pytest.fixture()
def scene_xml(tmp_path):
    p = tmp_path / 'units.xml'
    p.write_text(SCENE)
    return p


def test_reference_distance_is_the_median_distance_to_the_shapes(scene_xml):
    stage, _ = compile_to_stage(scene_xml)
    light = UsdLux.SphereLight(stage.GetPrimAtPath('/World/Lights/PointLight'))
    assert light.GetPrim().GetAttribute('rtc:referenceDistance').Get() == pytest.approx(4.0, rel=1e-12)
    assert light.GetIntensityAttr().Get() == pytest.approx(4 * 4.0 ** 2, rel=1e-6)
    assert light.GetNormalizeAttr().Get() and light.GetTreatAsPointAttr().Get()
    assert tuple(light.GetColorAttr().Get()) == pytest.approx((0.8, 0.6, 0.4), rel=1e-6)


def test_course_lambertian_at_the_reference_distance_renders_kd_times_intensity(scene_xml, tmp_path):
    out = tmp_path / 'units.exr'
    r = CliRunner().invoke(main, ['render', str(scene_xml), '-o', str(out), '--width', '9', '--height', '9',
                                  '--spp', '64', '-q'])
    assert r.exit_code == 0, r.output
    centre = read_image(out)[4, 4]
    # kd * I * cos(0): the floor point below the light, 4 units away, faces it
    assert centre == pytest.approx(0.5 * np.array([0.8, 0.6, 0.4]), rel=2e-3)
