"""rtc's applied API schemas (schemas/generatedSchema.usda): every rtc: attribute the compiler
writes is declared, typed and documented by a schema applied to its prim, and the compiled stages
still validate with zero errors."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from pxr import Usd

import rtc
from rtc.compiler.api import compile_to_stage
from tests.compiler.compiler_helpers import REPO, SCENES, validation_errors

SCHEMA_DIR = REPO / "schemas"


@pytest.mark.parametrize("scene", ["gallery", "envmap", "ellipsoids", "cylinder", "dof"])
def test_every_rtc_attribute_is_declared_by_an_applied_schema(scene):
    stage, _ = compile_to_stage(SCENES / f"{scene}.xml", width=64, height=48, spp=4)
    seen = set()
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        for attr in prim.GetAuthoredAttributes():
            name = attr.GetName()
            if not name.startswith("rtc:"):
                continue
            declared = prim.GetPrimDefinition().GetAttributeDefinition(name)
            assert declared, f"{prim.GetPath()}.{name} is not declared by {prim.GetAppliedSchemas()}"
            assert declared.GetTypeName() == attr.GetPropertyStack(Usd.TimeCode.Default())[0].typeName
            assert declared.GetDocumentation()
            assert not attr.IsCustom()
            seen.add(name)
    assert {"rtc:model", "rtc:intensity", "rtc:imageEncoding"} <= seen
    assert validation_errors(stage) == []


def test_schemas_are_registered_by_importing_rtc_and_shipped_as_package_data():
    registry = Usd.SchemaRegistry()
    names = json.loads((SCHEMA_DIR / "plugInfo.json").read_text())["Plugins"][0]["Info"]["Types"]
    for type_name, info in names.items():
        identifier = info["alias"]["UsdSchemaBase"]
        assert registry.FindAppliedAPIPrimDefinition(identifier) is not None, identifier
        assert Usd.SchemaRegistry.GetSchemaKind(identifier) == Usd.SchemaKind.SingleApplyAPI
    pyproject = (REPO / "pyproject.toml").read_text()
    assert '"rtc.schemas" = "schemas"' in pyproject and '"plugInfo.json", "generatedSchema.usda"' in pyproject
    assert Path(rtc.__file__).resolve().parents[1] / "schemas" == SCHEMA_DIR.resolve()
