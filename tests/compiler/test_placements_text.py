"""The .usda fast path for placements (compiler/placements_text.py) writes exactly what Sdf writes.

Independent answer: the same scene authored as Sdf specs and exported by usd-core.  Files must be
byte-identical, so everything the other tests prove about compiled .usda files holds for both paths.
"""
from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom

from rtc.compiler import api
from rtc.compiler.placements_text import splice, usd_double
from rtc.compiler.usd_writer import AssetPlan, write_scene as author
from tests.compiler.compiler_helpers import SCENES, write_scene


def _both_paths(xml: Path, anchor: Path) -> tuple[str, str, bool]:
    """(Sdf-authored text, text-path text, whether the text path was taken)."""
    c = api._front_end(xml, None, None, None, None, None)
    plan = AssetPlan(anchor=anchor, side_dir="scene_assets", meshes_inline=False)
    specs = author(c.scene, c.meshes, c.options, plan, c.bounds)
    text = author(c.scene, c.meshes, c.options, plan, c.bounds, placements_as_text=True)
    assert specs.placements_text is None
    return specs.root.ExportToString(), text.root_text(), text.placements_text is not None


def _sdf_doubles(values: list[float]) -> list[str]:
    layer = Sdf.Layer.CreateAnonymous("numbers.usda")
    prim = Sdf.CreatePrimInLayer(layer, "/N")
    for i, v in enumerate(values):
        Sdf.AttributeSpec(prim, f"a{i:06d}", Sdf.ValueTypeNames.Double).default = v
    lines = [line.strip() for line in layer.ExportToString().splitlines() if line.strip().startswith("double ")]
    return [line.split(" = ", 1)[1] for line in lines]


def test_doubles_are_formatted_as_usd_formats_them():
    rng = np.random.default_rng(7)
    values = [0.0, -0.0, 1.0, -3.0, 0.5, 1e-4, 9.999999e-5, 1e-6, 1e-7, 1.5e-7, 123456.0, 1e14,
              99999999999999.9, 1e15, 1.2345678901234568e17, 1e21, 5e-324, 1.7976931348623157e308,
              0.1 + 0.2, 2.0 ** 52, 2.0 ** 53 + 2, -1e-300]
    values += list(rng.standard_normal(300) * 10.0 ** rng.integers(-12, 20, 300))
    values += [float(np.float32(v)) for v in rng.uniform(-1000, 1000, 100)]
    expected = _sdf_doubles(values)
    got = [usd_double(v) for v in values]
    assert got == expected
    assert all(float(text) == v for text, v in zip(got, values))


@pytest.mark.parametrize("xml", sorted(SCENES.glob("*.xml")), ids=lambda p: p.stem)
def test_gallery_scenes_byte_identical(xml, tmp_path):
    specs, text, _ = _both_paths(xml, tmp_path)
    assert text == specs


def test_course_scenes_byte_identical(course_scenes, tmp_path):
    taken = 0
    for xml in course_scenes:
        specs, text, used = _both_paths(xml, tmp_path)
        assert text == specs, xml.name
        taken += used
    assert taken >= 4          # threeEggs, the dragons, the Buddha and the dielectric test place instances


def _random_chain(rnd: random.Random) -> str:
    ops = []
    for _ in range(rnd.randint(0, 14)):              # up to 14: names up to :t13 sort numerically
        kind = rnd.choice(["translate", "scale", "X", "Y", "Z", "Z", "Z"])
        mag = 10.0 ** rnd.randint(-8, 16)
        if kind == "translate":
            ops.append(f"<translate>{rnd.uniform(-1, 1) * mag!r} {-0.0!r} {rnd.uniform(-9, 9)!r}</translate>")
        elif kind == "scale":
            s = [rnd.choice([-1, 1]) * rnd.uniform(0.01, 100) for _ in range(3)]
            ops.append(f"<scale>{s[0]!r} {s[1]!r} {s[2]!r}</scale>")
        else:
            ops.append(f'<rotate axis="{kind}">{rnd.uniform(-720, 720)!r}</rotate>')
    return f"<transform>{''.join(ops)}</transform>" if ops else ""


def test_random_transform_chains_and_overrides(tmp_path):
    rnd = random.Random(2026)
    body = ['<shader name="red" type="Lambertian"><diffuse>0.8 0.1 0.1</diffuse></shader>',
            '<instance name="ball" type="sphere"><center>0 0 0</center><radius>1</radius><shader ref="grey"/></instance>',
            '<instance name="box" type="box"><minPt>-1 -1 -1</minPt><maxPt>1 1 1</maxPt><shader ref="grey"/></instance>']
    for i in range(300):
        override = '<shader ref="red"/>' if rnd.random() < 0.3 else ""
        name = rnd.choice(["p", "p", "", "9lives", "q"])          # repeats, empty, invalid identifiers
        body.append(f'<shape name="{name}" type="instance" id="{rnd.choice(["ball", "box"])}">'
                    f"{override}{_random_chain(rnd)}</shape>")
    xml = write_scene(tmp_path, "\n".join(body))
    specs, text, used = _both_paths(xml, tmp_path)
    assert used
    assert text == specs


def test_compiled_file_composes_to_the_compilers_matrices(tmp_path):
    """End to end through `compile_file` (which takes the text path for .usda): every placement's
    composed world matrix equals the compiler's own to 1e-9 relative."""
    rnd = random.Random(5)
    body = ['<instance name="ball" type="sphere"><center>0 0 0</center><radius>1</radius><shader ref="grey"/></instance>']
    for i in range(200):
        body.append(f'<shape name="p{i}" type="instance" id="ball">{_random_chain(rnd)}</shape>')
    xml = write_scene(tmp_path, "\n".join(body))
    out = tmp_path / "out.usda"
    api.compile_file(xml, out)
    c = api._front_end(xml, None, None, None, None, None)
    stage = Usd.Stage.Open(str(out))
    cache = UsdGeom.XformCache()
    for i, placement in enumerate(c.scene.placements):
        prim = stage.GetPrimAtPath(f"/World/Instances/p{i}")
        assert prim.IsInstance()
        got = np.array(cache.GetLocalToWorldTransform(prim)).T
        want = placement.motion.matrices()[0]
        scale = max(1.0, float(np.abs(want).max()))
        assert np.abs(got - want).max() <= 1e-9 * scale, (i, got, want)


def test_animated_placements_use_sdf(tmp_path):
    from rtc.compiler.placements_text import eligible
    xml = SCENES / "motion.xml"
    c = api._front_end(xml, None, None, None, None, None)
    assert not eligible(c.scene.placements)
    specs, text, used = _both_paths(xml, tmp_path)
    assert not used and text == specs


def test_splice_needs_exactly_one_empty_scope():
    with pytest.raises(ValueError):
        splice("#usda 1.0\n", "x")
    layer = Sdf.Layer.CreateAnonymous("s.usda")
    spec = Sdf.CreatePrimInLayer(layer, "/World/Instances")
    spec.specifier, spec.typeName = Sdf.SpecifierDef, "Scope"
    assert '        def Xform "a"\n' in splice(layer.ExportToString(), '        def Xform "a"\n        {\n        }\n')
