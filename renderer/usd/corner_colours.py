"""Which colour primvar a mesh keeps per corner.

A mesh keeps one colour primvar per triangle corner (`Mesh.colors`), which a material reads as its diffuse colour
where it varies over the mesh (`materials.Materials._primvar_value`): `displayColor`, which Storm draws on unbound
meshes and a `UsdPrimvarReader_float3` of it reads, or another colour primvar that varies over the mesh when every
material bound to it (its materialBind GeomSubsets', and its own where they leave faces out; full purpose) reads
that one primvar for its UsdPreviewSurface's `diffuseColor` through a `UsdPrimvarReader_float3` (its `varname`
found through material interface inputs, as `texture_coordinates` finds a texture's), as Storm binds it for the
shader to read.  A mesh whose materials read other primvars, or several, keeps displayColor, and a reader of another
primvar reads its mean (warned).  Only a mesh with a colour primvar other than displayColor that varies over it has
its bindings looked at.
"""
from __future__ import annotations

from pxr import Sdf, Usd, UsdGeom, UsdShade

from .texture_coordinates import reader_varname, shader_sources

DISPLAY_COLOR = 'displayColor'
_COLOURS = {Sdf.ValueTypeNames.Color3fArray, Sdf.ValueTypeNames.Float3Array, Sdf.ValueTypeNames.Color3dArray,
            Sdf.ValueTypeNames.Double3Array, Sdf.ValueTypeNames.Color3hArray, Sdf.ValueTypeNames.Half3Array}
_SUBSETS = 'materialBind'


def corner_colour_name(prim: Usd.Prim) -> str:
    """The primvar (its name, no "primvars:") mesh `prim` keeps per corner: displayColor unless its bound materials
    all read one other colour primvar that varies over it for their diffuse colour."""
    if not prim.IsA(UsdGeom.Mesh):
        return DISPLAY_COLOR
    varying = {pv.GetPrimvarName() for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithAuthoredValues()
               if pv.GetTypeName() in _COLOURS and pv.GetInterpolation() != UsdGeom.Tokens.constant
               and pv.GetPrimvarName() != DISPLAY_COLOR}
    if not varying:
        return DISPLAY_COLOR
    subsets = UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(prim), UsdGeom.Tokens.face, _SUBSETS)
    covered = set()
    for s in subsets:
        covered.update(int(i) for i in s.GetIndicesAttr().Get() or [])
    faces = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get() or [])
    owners = [s.GetPrim() for s in subsets] + ([prim] if not subsets or not covered >= set(range(faces)) else [])
    names = {_diffuse_primvar(p) for p in owners}
    name = names.pop() if len(names) == 1 else None
    return name if name in varying else DISPLAY_COLOR


def _diffuse_primvar(prim: Usd.Prim) -> str | None:
    """The primvar the diffuseColor of `prim`'s bound UsdPreviewSurface reads through a UsdPrimvarReader_float3 (a
    leading "primvars:" dropped), or None."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    shader = material.ComputeSurfaceSource()[0] if material else None
    if not shader or shader.GetShaderId() != 'UsdPreviewSurface':
        return None
    inp = shader.GetInput('diffuseColor')
    readers = [s for s in (shader_sources(inp) if inp else []) if s.GetShaderId() == 'UsdPrimvarReader_float3']
    return reader_varname(readers[0]) if readers else None
