"""`rtc converge` end to end (click CliRunner) on a tiny soft-shadow scene, and the library helpers."""
import csv
import math

import numpy as np
import pytest
from click.testing import CliRunner

from rtc.renderer.host import converge as C
from rtc.converge_cmd import converge_cmd

SOFT_SHADOW_XML = """<?xml version="1.0" encoding="UTF-8" ?>
<scene bgColor="0 0 0">
  <camera name="main" type="perspective">
    <position>0 4 0.01</position>
    <lookatPoint>0 0 0</lookatPoint>
    <focalLength>0.5</focalLength>
    <imagePlaneWidth>0.5</imagePlaneWidth>
  </camera>
  <light type="area"><position>0 3 0</position><intensity>1 1 1</intensity><normal>0 -1 0</normal>
    <width>1.5</width><length>1.5</length></light>
  <shader name="white" type="Lambertian"><diffuse>0.8 0.8 0.8</diffuse></shader>
  <shape name="ground" type="box"><shader ref="white"/><minPt>-5 -0.1 -5</minPt><maxPt>5 0 5</maxPt></shape>
  <shape name="ball" type="sphere"><shader ref="white"/><center>0.3 0.6 0</center><radius>0.4</radius></shape>
</scene>
"""


@pytest.fixture(scope='module')
def converge_run(tmp_path_factory):
    d = tmp_path_factory.mktemp('converge')
    scene = d / 'soft.xml'
    scene.write_text(SOFT_SHADOW_XML)
    args = [str(scene), '--width', '24', '--height', '24', '--max-spp', '16', '--seeds', '3',
            '--samplers', 'independent,cmj', '--filter', 'box', '-o', str(d / 'out'), '-q']
    res = CliRunner().invoke(converge_cmd, args)
    assert res.exit_code == 0, res.output + repr(res.exception)
    return d, scene, args, res


def test_csv_columns_and_values(converge_run):
    d, _, _, res = converge_run
    rows = list(csv.DictReader(open(d / 'out.csv')))
    assert tuple(rows[0].keys()) == C.CSV_COLUMNS
    assert len(rows) == 2 * 5 * 3                        # samplers x spp (1, 2, 4, 8, 16) x seeds
    assert {r['sampler'] for r in rows} == {'independent', 'cmj'}
    assert sorted({int(r['spp']) for r in rows}) == [1, 2, 4, 8, 16]
    for r in rows:
        e, q, t = float(r['rmse']), float(r['relmse']), float(r['seconds'])
        assert 0 < e < 1 and 0 < q < 10 and 0 < t < 60
    # errors fall with spp (mean over seeds) for both samplers
    for s in ('independent', 'cmj'):
        e = [np.mean([float(r['rmse']) for r in rows if r['sampler'] == s and int(r['spp']) == n])
             for n in (1, 16)]
        assert e[1] < 0.5 * e[0]
    assert (d / 'out.png').stat().st_size > 10_000
    assert 'fitted log-log slopes' in res.output and 'relMSE' in res.output


def test_independent_slope_is_minus_one_half(converge_run):
    d, *_ = converge_run
    summary = C.summarize(C.read_csv(d / 'out.csv'))
    slope_spp, _ = C.slopes(summary, 'rmse', fit_from=1)['independent']
    assert slope_spp == pytest.approx(-0.5, abs=0.15)


def test_reference_is_cached_beside_the_scene_and_reused(converge_run):
    d, scene, args, _ = converge_run
    refs = list(d.glob('soft.xml.ref-*.exr'))
    assert len(refs) == 1
    mtime = refs[0].stat().st_mtime_ns
    res = CliRunner().invoke(converge_cmd, [*args[:-3], '--samplers', 'independent', '--max-spp', '2',
                                            '--seeds', '1', '-o', str(d / 'again'), '--reference-spp', '256'])
    assert res.exit_code == 0, res.output
    assert refs[0].stat().st_mtime_ns == mtime                   # same key (16 x 16 = 256): reused
    # a different scene file content gives a different key
    k1 = C.reference_key(scene.read_bytes(), 24, 24, 256, 4, 'sobol', 'box', 4)
    k2 = C.reference_key(scene.read_bytes() + b' ', 24, 24, 256, 4, 'sobol', 'box', 4)
    k3 = C.reference_key(scene.read_bytes(), 24, 25, 256, 4, 'sobol', 'box', 4)
    assert refs[0].name == f'soft.xml.ref-{k1}.exr' and len({k1, k2, k3}) == 3


def test_bad_sampler_is_rejected(tmp_path):
    scene = tmp_path / 's.xml'
    scene.write_text(SOFT_SHADOW_XML)
    res = CliRunner().invoke(converge_cmd, [str(scene), '--samplers', 'independent,halton'])
    assert res.exit_code == 2 and 'halton' in res.output


def test_fit_slope_and_spp_sequence():
    x = np.array([1, 2, 4, 8, 16.0])
    assert C.fit_slope(x, 3 * x ** -0.75) == pytest.approx(-0.75, abs=1e-12)
    assert math.isnan(C.fit_slope([4], [1.0]))
    assert C.spp_sequence(16) == [1, 2, 4, 8, 16]
    assert C.spp_sequence(24, 3) == [4, 8, 16, 24]


def test_summary_is_rms_over_seeds():
    pts = [C.Point('independent', 4, s, 1.0, e, e * e) for s, e in enumerate((0.1, 0.2, 0.3))]
    (s,) = C.summarize(pts)
    assert s.rmse == pytest.approx(math.sqrt((0.01 + 0.04 + 0.09) / 3))
    assert (s.rmse_min, s.rmse_max, s.seeds) == (0.1, 0.3, 3)
