"""Large scenes: per-placement costs must stay constant (issue #2 / #5: 10^5 placements)."""
from __future__ import annotations

import time

import numpy as np
from pxr import Usd, UsdGeom

from rtc.compiler.api import compile_to_stage
from rtc.compiler.usd_writer import _Names
from tests.compiler.compiler_helpers import write_scene


def test_repeated_names_get_counted_suffixes():
    names = _Names()
    given = [names.unique("/W", n) for n in ("egg", "egg", "egg_1", "egg", "3 eggs", "egg")]
    assert given == ["egg", "egg_1", "egg_1_1", "egg_2", "__eggs", "egg_3"]
    assert names.unique("/Other", "egg") == "egg"                 # per parent


def test_many_identical_names_stay_linear():
    """Unnamed placements are all called "instance"; searching the suffixes from 1 each time made
    20,000 of them take over a minute."""
    names = _Names()
    start = time.perf_counter()
    result = [names.unique("/World/Instances", "instance") for _ in range(50_000)]
    assert time.perf_counter() - start < 5.0
    assert len(set(result)) == len(result) and result[-1] == "instance_49999"


def test_unnamed_placements_compile_with_their_transforms(tmp_path):
    rng = np.random.default_rng(7)
    values = rng.uniform(-10, 10, (300, 4))
    body = ['<instance name="egg" type="sphere"><center>0 0 0</center><radius>1</radius>'
            '<shader ref="grey"/></instance>']
    body += [f'<shape type="instance" id="egg"><transform><translate>{a} {b} {c}</translate>'
             f'<rotate axis="Y">{d}</rotate><rotate axis="Y">{-d}</rotate></transform></shape>'
             for a, b, c, d in values]
    stage, _ = compile_to_stage(write_scene(tmp_path, "\n".join(body)))
    prims = stage.GetPrimAtPath("/World/Instances").GetChildren()
    assert [p.GetName() for p in prims[:3]] == ["instance", "instance_1", "instance_2"]
    assert len(prims) == 300 and all(p.IsInstance() for p in prims)
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for prim, (a, b, c, _) in zip(prims, values):
        ops = UsdGeom.Xformable(prim).GetXformOpOrderAttr().Get()
        assert list(ops) == ["xformOp:translate", "xformOp:rotateY", "xformOp:rotateY:t1"]
        world = np.array(cache.GetLocalToWorldTransform(prim))
        np.testing.assert_allclose(world[3, :3], (a, b, c), rtol=0, atol=1e-12)
        np.testing.assert_allclose(world[:3, :3], np.eye(3), rtol=0, atol=1e-12)
