"""Which colour and opacity primvars a mesh keeps per corner.

A mesh keeps one colour primvar and one opacity primvar per triangle corner (`Mesh.colors`: RGB, and A where an
opacity is kept), which a material reads as its diffuse colour or its opacity where they vary over the mesh
(`materials.MaterialTable._primvar_value`): `displayColor` and `displayOpacity`, which Storm's fallback material
draws on unbound meshes and a `UsdPrimvarReader_float3` / `_float` of them reads, or another primvar of the kind that
varies over the mesh when every material bound to it (its materialBind GeomSubsets', and its own where they leave
faces out; full purpose) reads that one primvar for its UsdPreviewSurface's `diffuseColor` (through a
`UsdPrimvarReader_float3`) or `opacity` (through a `UsdPrimvarReader_float`; its `varname` found through material
interface inputs, as `texture_coordinates` finds a texture's), as Storm binds it for the shader to read.  A mesh
whose materials read other primvars, or several, keeps displayColor / displayOpacity, and a reader of another
primvar reads its mean (warned).  Only a mesh with a primvar of the kind other than the display one that varies
over it has its bindings looked at.
"""
from __future__ import annotations

from pxr import Sdf, Usd, UsdGeom, UsdShade

from .texture_coordinates import reader_varname, shader_sources

DISPLAY_COLOR = 'displayColor'
DISPLAY_OPACITY = 'displayOpacity'
_COLOURS = {Sdf.ValueTypeNames.Color3fArray, Sdf.ValueTypeNames.Float3Array, Sdf.ValueTypeNames.Color3dArray,
            Sdf.ValueTypeNames.Double3Array, Sdf.ValueTypeNames.Color3hArray, Sdf.ValueTypeNames.Half3Array}
_SCALARS = {Sdf.ValueTypeNames.FloatArray, Sdf.ValueTypeNames.DoubleArray, Sdf.ValueTypeNames.HalfArray}
_SUBSETS = 'materialBind'


def corner_colour_name(prim: Usd.Prim) -> str:
    """The colour primvar (its name, no "primvars:") mesh `prim` keeps per corner: displayColor unless its bound
    materials all read one other colour primvar that varies over it for their diffuse colour."""
    return _kept(prim, _COLOURS, DISPLAY_COLOR, 'diffuseColor', 'UsdPrimvarReader_float3')


def corner_opacity_name(prim: Usd.Prim) -> str:
    """The opacity primvar mesh `prim` keeps per corner: displayOpacity unless its bound materials all read one other
    scalar primvar that varies over it for their opacity."""
    return _kept(prim, _SCALARS, DISPLAY_OPACITY, 'opacity', 'UsdPrimvarReader_float')


def _kept(prim: Usd.Prim, types: set, display: str, input_name: str, reader: str) -> str:
    """The primvar of one of `types` mesh `prim` keeps per corner: `display`, or the one other such primvar varying
    over it that every material bound to it reads for `input_name` through a `reader`."""
    if not prim.IsA(UsdGeom.Mesh):
        return display
    varying = {pv.GetPrimvarName() for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithAuthoredValues()
               if pv.GetTypeName() in types and pv.GetInterpolation() != UsdGeom.Tokens.constant
               and pv.GetPrimvarName() != display}
    if not varying:
        return display
    subsets = UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(prim), UsdGeom.Tokens.face, _SUBSETS)
    covered = set()
    for s in subsets:
        covered.update(int(i) for i in s.GetIndicesAttr().Get() or [])
    faces = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get() or [])
    owners = [s.GetPrim() for s in subsets] + ([prim] if not subsets or not covered >= set(range(faces)) else [])
    names = {_read_primvar(p, input_name, reader) for p in owners}
    name = names.pop() if len(names) == 1 else None
    return name if name in varying else display


def _read_primvar(prim: Usd.Prim, input_name: str, reader: str) -> str | None:
    """The primvar input `input_name` of `prim`'s bound UsdPreviewSurface reads through a `reader` (a leading
    "primvars:" dropped), or None."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    shader = material.ComputeSurfaceSource()[0] if material else None
    if not shader or shader.GetShaderId() != 'UsdPreviewSurface':
        return None
    inp = shader.GetInput(input_name)
    readers = [s for s in (shader_sources(inp) if inp else []) if s.GetShaderId() == reader]
    return reader_varname(readers[0]) if readers else None
