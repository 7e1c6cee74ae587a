"""Which primvar holds a gprim's texture coordinates.

Storm reads the primvar a material's `UsdPrimvarReader_float2` names (its `varname`, often through a material
interface input such as `inputs:coords` or `inputs:frame:stPrimvarName`), found by following each `UsdUVTexture`'s
`inputs:st` (through `UsdTransform2d` nodes).  A gprim with one set of coordinates named `st` or `UVMap` (Blender's
name) reads it whatever the material names, without looking at the material (what nearly every file has); one with
several sets, or one other 2-vector primvar, reads the set its bound material's textures name when it has that
primvar, else `st`, `UVMap` or its first `texCoord2f[]` primvar, as before.  One set a gprim: a material whose
textures read several sets reads the first found (the shader's inputs in order).
"""
from __future__ import annotations

from pxr import Sdf, Usd, UsdGeom, UsdShade

DEFAULT_NAMES = ('st', 'UVMap')
_TYPES = {Sdf.ValueTypeNames.TexCoord2fArray, Sdf.ValueTypeNames.Float2Array, Sdf.ValueTypeNames.TexCoord2dArray,
          Sdf.ValueTypeNames.Double2Array, Sdf.ValueTypeNames.TexCoord2hArray, Sdf.ValueTypeNames.Half2Array}
_READERS = ('UsdPrimvarReader_float2',)


def uv_primvar(prim: Usd.Prim):
    """The texture-coordinate primvar of gprim `prim` (None: it has none)."""
    api = UsdGeom.PrimvarsAPI(prim)
    sets = [pv for pv in api.GetPrimvarsWithAuthoredValues() if pv.GetTypeName() in _TYPES]
    if len(sets) > 1 or (len(sets) == 1 and sets[0].GetPrimvarName() not in DEFAULT_NAMES):
        name = material_uv_name(prim)
        chosen = [pv for pv in sets if pv.GetPrimvarName() == name]
        if chosen:
            return chosen[0]
    for name in DEFAULT_NAMES:
        pv = api.GetPrimvar(name)
        if pv and pv.HasAuthoredValue():
            return pv
    for pv in sets:
        if pv.GetTypeName() == Sdf.ValueTypeNames.TexCoord2fArray:
            return pv
    return None


def material_uv_name(prim: Usd.Prim) -> str | None:
    """The primvar the first texture of `prim`'s bound UsdPreviewSurface reads its coordinates from (None: no
    texture, or one whose coordinates come from no primvar reader)."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not material:
        return None
    shader = material.ComputeSurfaceSource()[0]
    if not shader or shader.GetShaderId() != 'UsdPreviewSurface':
        return None
    for inp in shader.GetInputs():
        for source in shader_sources(inp):
            if source.GetShaderId() == 'UsdUVTexture':
                name = _reader_name(source)
                if name:
                    return name
    return None


def shader_sources(inp: UsdShade.Input) -> list[UsdShade.Shader]:
    """The shaders whose outputs drive input `inp` (through material-interface inputs)."""
    return [UsdShade.Shader(attr.GetPrim()) for attr in inp.GetValueProducingAttributes()
            if UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output]


def _reader_name(texture: UsdShade.Shader) -> str | None:
    """The varname of the primvar reader that gives UsdUVTexture `texture` its coordinates, past UsdTransform2d
    nodes (a leading "primvars:" dropped)."""
    node, name = texture, 'st'
    for _ in range(8):                              # (a chain of transforms; a cycle stops here)
        inp = node.GetInput(name)
        name = 'in'
        sources = shader_sources(inp) if inp else []
        if not sources:
            return None
        node = sources[0]
        if node.GetShaderId() in _READERS:
            return reader_varname(node)
        if node.GetShaderId() != 'UsdTransform2d':
            return None
    return None


def reader_varname(reader: UsdShade.Shader) -> str | None:
    """The primvar a UsdPrimvarReader names (its inputs:varname, through material interface inputs; a leading
    "primvars:" dropped), or None."""
    varname = reader.GetInput('varname')
    for attr in varname.GetValueProducingAttributes() if varname else []:
        value = attr.Get()
        if value:
            name = str(value)
            return name[len('primvars:'):] if name.startswith('primvars:') else name
    return None
