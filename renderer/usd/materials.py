"""UsdShade materials -> `Material` / `Texture` records, each converted once.

Resolution order for a bound material:
1. ``rtc:model`` on the Material prim (written by rtc's compiler): the exact course model and
   parameters (``rtc:diffuse``, ``rtc:specular``, ``rtc:phongExp``, ... see
   schemas/usd-conventions.md).
2. Its universal-render-context surface shader if that is a ``UsdPreviewSurface``: constant inputs
   (following material-interface connections), ``UsdUVTexture`` connections on
   ``diffuseColor`` / ``specularColor`` / ``emissiveColor`` (file, wrapS/T, scale, bias, sourceColorSpace,
   fallback, a ``UsdTransform2d`` on its st) and on ``roughness`` / ``metallic`` / ``opacity`` / ``clearcoat`` /
   ``clearcoatRoughness`` (the channel its r, g, b or a output names:
   `Material.scalar_textures`), on ``normal`` (a tangent-space normal map: `Material.normal_texture`,
   `kernel/normal_maps.py`), ``opacityThreshold`` (a cut-out), and ``UsdPrimvarReader_float`` / ``_float3``
   connections on any input: the gprim's primvar
   ``varname`` (found with inheritance; its ``fallback`` where the gprim has none), so that one material
   gives each gprim its own value (`MaterialTable.bound`).
3. Anything else (MaterialX-only networks, unknown shader ids, missing surface) -> a warning and
   the gprim's fallback.
A gprim without a usable material gets a fallback material: its ``primvars:displayColor``
(inherited from ancestors; on a mesh where it varies, its colour at each point, interpolated from the
triangle's corners; on a point cloud, each point's; on other gprims where it varies, averaged), else 18% grey.

Textures are loaded lazily -- only when a material that is actually bound uses them -- and each
image file is decoded once (sRGB-decoded when the file is 8-bit sRGB or the shader says so).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdShade

from ..description import LAMBERTIAN, MODEL_NAMES, PREVIEW_SURFACE, BytePixels, Material, Texture
from .dome_formats import file_layout, relayout
from .corner_primvars import DISPLAY_OPACITY, corner_colour_name, corner_opacity_name
from .geometry import varying_display_color, varying_display_opacity
from .primvar_values import flattened
from .texture_files import read_texture

Warn = Callable[[str], None]
GREY = (0.18, 0.18, 0.18)
PREVIEW_ROUGHNESS = 0.5              # UsdPreviewSurface roughness where unauthored (the spec; Material.roughness is 0)
_WRAPS = {'repeat', 'clamp', 'mirror', 'black'}
_TEXTURE_FIELDS = {'diffuseColor': 'diffuse_texture', 'specularColor': 'specular_texture',
                   'emissiveColor': 'emission_texture'}
# scalar inputs a UsdUVTexture channel may drive: their place in Material.scalar_textures / scalar_channels
_SCALAR_TEXTURES = {'roughness': 0, 'metallic': 1, 'opacity': 2, 'clearcoat': 3, 'clearcoatRoughness': 4}
_CHANNELS = {'r': 0, 'g': 1, 'b': 2, 'a': 3}
# UsdPrimvarReader ids -> the kind of value they read (`typed`); a reader feeds an input of its own kind
_READERS = {'UsdPrimvarReader_float': 'float', 'UsdPrimvarReader_float3': 'color3', 'UsdPrimvarReader_normal': 'color3',
            'UsdPrimvarReader_point': 'color3', 'UsdPrimvarReader_vector': 'color3'}


@dataclasses.dataclass(frozen=True)
class PrimvarInput:
    """A UsdPreviewSurface input driven by a UsdPrimvarReader: the Material field it sets, the kind of
    value, the primvar's name, the reader's fallback value and the reader (for messages)."""
    field: str
    kind: str
    varname: str
    fallback: object
    reader: str


def typed(value, kind: str):
    """`value` read as `kind` ('float', 'float2', 'color3', 'float4', 'asset', 'token'), or None where it is not
    one: an input or attribute authored with another type than its definition's (a string roughness, a float
    colour), which Storm, asking for the declared type, ignores."""
    if kind == 'asset':
        return value if isinstance(value, Sdf.AssetPath) else None
    if kind == 'token':
        return value if isinstance(value, str) else None
    if isinstance(value, (str, Sdf.AssetPath)):
        return None
    try:
        if kind == 'float':
            return float(value)
        items = tuple(float(x) for x in value)
    except (TypeError, ValueError):
        return None
    if kind == 'color3':
        return items if len(items) == 3 else None
    if kind == 'float2':
        return items if len(items) == 2 else None
    return items if len(items) == 4 else None


class MaterialTable:
    """Owns `materials` and `textures` of one SceneDescription; hands out indices."""

    def __init__(self, time: Usd.TimeCode, warn: Warn):
        self.time, self.warn = time, warn
        self.materials: list[Material] = []
        self.textures: list[Texture] = []
        self._index: dict = {}          # material path / fallback key -> material index
        self._converted: dict = {}      # material path -> (Material or None, its PrimvarInputs)
        self._reading: list = []        # the PrimvarInputs of the material being converted
        self._pixels: dict = {}         # (resolved file, colour space) -> float32 pixels or None
        self._texture_index: dict = {}  # (file, colour space, wraps, scale, bias, light) -> index

    # ------------------------------------------------------------------ entry points
    def bound(self, material: UsdShade.Material, gprim: Usd.Prim | None = None,
              given: dict | None = None) -> int | None:
        """Index of a material bound to `gprim`, or None when it has no usable surface (warned once).  A
        material whose inputs read primvars (`reads_primvars`) gives one material per set of values its
        gprims hold (`_primvar_value`; `given`: the primvars a PointInstancer gives the gprim's instance,
        `instance_primvars`), as Storm binds each gprim's primvars to the shader."""
        key = str(material.GetPath())
        converted, inputs = self._template(material)
        if converted is None:
            return None
        glows = any(converted.emission) or converted.emission_texture >= 0
        values = tuple(self._primvar_value(gprim, r, given, glows) for r in inputs)
        if (key, values) not in self._index:
            fields = {}
            for r, v in zip(inputs, values):
                if isinstance(v, str) and r.field == 'opacity':      # per corner: 1 times the gprim's opacities
                    fields.update({r.field: 1.0, 'vertex_opacity': True})
                elif isinstance(v, str):                 # per corner: the mesh's colours times white
                    fields.update({r.field: (1.0, 1.0, 1.0), 'vertex_colors': True})
                else:
                    fields[r.field] = v
            label = key if not inputs else f'{key} <{gprim.GetPath() if gprim else "no gprim"}>'
            self._index[(key, values)] = self._add(dataclasses.replace(converted, path=label, **fields))
        return self._index[(key, values)]

    def reads_primvars(self, material: UsdShade.Material) -> bool:
        """Whether a material's inputs read its gprims' primvars (so that instances of one prototype, which
        inherit primvars from their own ancestors, may each get another material)."""
        return bool(self._template(material)[1])

    def _template(self, material: UsdShade.Material) -> tuple:
        """(Material or None, its PrimvarInputs) of a material, converted once."""
        key = str(material.GetPath())
        if key not in self._converted:
            self._reading = []
            converted = self._convert(material)
            self._converted[key] = (converted, tuple(self._reading))
        return self._converted[key]

    def _values(self, pv: UsdGeom.Primvar, consequence: str) -> np.ndarray | None:
        """A primvar's values as float64, None where they are not numbers: its flattened array (empty where
        `geometry.flattened` cannot flatten it, which it warns of), or the one value of a constant primvar of a
        scalar type (``color3f primvars:displayColor = (0.1, 0.1, 0.1)``, which Storm reads as well)."""
        values = flattened(pv, self.time, self.warn, consequence) if pv.GetTypeName().isArray else [pv.Get(self.time)]
        try:
            return np.asarray([] if values is None else values, np.float64)
        except (TypeError, ValueError):
            return None

    @staticmethod
    def _given_or_found(prim: Usd.Prim, name: str, given: dict | None):
        """(values a PointInstancer gives prim's instance (1, w), or None; else the primvar found on prim with
        inheritance, or None): the instancer's value is closer than one authored on the instancer or above it,
        farther than one authored on the prototype's own prims."""
        pv = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)
        found = pv if pv and pv.HasAuthoredValue() else None
        if given and name in given:
            values, owner = given[name]
            if found is None or Sdf.Path(owner).HasPrefix(found.GetAttr().GetPrim().GetPath()):
                return np.asarray([values], np.float64), None
        return None, found

    def _primvar_value(self, gprim: Usd.Prim | None, r: PrimvarInput, given: dict | None = None,
                       glows: bool = False):
        """The value a UsdPrimvarReader reads on `gprim` (a GeomSubset: its mesh's): its primvar r.varname
        (found with inheritance) where it is constant over the gprim; 'per corner' for a mesh's, a cloud's or
        curves' displayColor that varies over them read for the diffuse colour (their per-corner colours,
        `geometry.varying_display_color`; a mesh's: the colour primvar it keeps per corner, `corner_primvars`), and
        for a mesh's, a cloud's or curves' displayOpacity read for the opacity (`geometry.varying_display_opacity`;
        not a cloud's or curves' whose material `glows`: their lights emit the material's emission); the mean,
        warned, for another that varies; the reader's fallback where the gprim has none (as Storm)."""
        if gprim is None or not r.varname:
            return r.fallback
        prim = gprim.GetParent() if gprim.IsA(UsdGeom.Subset) else gprim
        v, pv = self._given_or_found(prim, r.varname, given)
        if v is None and pv is None:
            return r.fallback
        name = f'primvars:{r.varname}' if pv is None else pv.GetAttr().GetName()
        v = self._values(pv, f"{r.reader}'s fallback used") if pv is not None else v
        width = 3 if r.kind == 'color3' else 1
        if v is not None and v.size == 0:                # (empty: nothing to read)
            return r.fallback
        v = None if v is None else v.reshape(len(v), -1)
        if v is None or v.shape[1] != width or not np.all(np.isfinite(v)):
            what = 'RGB colours' if width == 3 else 'numbers'
            self.warn(f'{prim.GetPath()}: {name} is not a list of finite {what}, as {r.reader} reads it; '
                      'its fallback used')
            return r.fallback
        if pv is not None and pv.GetInterpolation() != UsdGeom.Tokens.constant and np.any(v != v[0]):
            if r.field == 'diffuse' and r.varname == corner_colour_name(prim) and \
                    varying_display_color(prim, self.time, r.varname) is not None:
                return 'per corner'
            if r.field == 'opacity' and r.varname == corner_opacity_name(prim) and \
                    varying_display_opacity(prim, self.time, r.varname) is not None and \
                    not (glows and (prim.IsA(UsdGeom.Points) or prim.IsA(UsdGeom.Curves))):
                return 'per corner'
            self.warn(f'{prim.GetPath()}: {name} varies over it ({pv.GetInterpolation()}); {r.reader} reads its '
                      'mean')
            v = v.mean(axis=0, keepdims=True)
        return tuple(float(x) for x in v[0]) if width == 3 else float(v[0, 0])

    def fallback(self, gprim: Usd.Prim, given: dict | None = None) -> int:
        """The material of a gprim with no usable bound material, as Storm's fallback draws it: a UsdPreviewSurface
        of diffuse colour primvars:displayColor (or grey) and opacity primvars:displayOpacity (or 1), roughness 1.  A
        mesh whose displayColor varies over it (`geometry.varying_display_color`; a materialBind GeomSubset: its
        mesh's) gets a white diffuse that its per-corner colours multiply (`Mesh.colors`), a point cloud its colour
        a point (`Sphere.colors`); one whose displayOpacity varies, an opacity of 1 that its per-corner opacities
        multiply (`geometry.varying_display_opacity`); `given`: as `bound`."""
        mesh = gprim.GetParent() if gprim.IsA(UsdGeom.Subset) else gprim
        corner_colour = varying_display_color(mesh, self.time) is not None
        corner_opacity = varying_display_opacity(mesh, self.time) is not None
        colour = (1.0, 1.0, 1.0) if corner_colour else self._display_value(gprim, given, 'displayColor', GREY)
        opacity = 1.0 if corner_opacity else self._display_value(gprim, given, DISPLAY_OPACITY, 1.0)
        key = ('displayColor', 'per corner' if corner_colour else colour, 'per corner' if corner_opacity else opacity)
        if key not in self._index:
            label = ('<displayColor per corner>' if corner_colour else '<grey>' if colour == GREY else
                     f'<displayColor {colour[0]:.3g} {colour[1]:.3g} {colour[2]:.3g}>')
            label += ' <displayOpacity per corner>' if corner_opacity else '' if opacity == 1.0 else \
                f' <displayOpacity {opacity:.3g}>'
            self._index[key] = self._add(Material(path=label, diffuse=colour, roughness=1.0, opacity=opacity,
                                                  vertex_colors=corner_colour, vertex_opacity=corner_opacity))
        return self._index[key]

    def _display_value(self, gprim: Usd.Prim, given: dict | None, name: str, default):
        """gprim's primvars:displayColor (an RGB tuple) or displayOpacity (a float, clamped to [0, 1]) where it does
        not keep them per corner, as the fallback material reads them: its value (the first of a constant primvar's
        several, as Storm), or the mean of those of one that varies; `default` where it has none (and, warned, where
        they are not numbers of the kind)."""
        width = 1 if name == DISPLAY_OPACITY else 3
        values, pv = self._given_or_found(gprim, name, given)
        if values is None and pv is None:
            return default
        instead = 'grey used instead' if width == 3 else 'opacity 1 used instead'
        values = self._values(pv, instead) if pv is not None else values
        if values is not None and values.ndim == 1 and width == 1:
            values = values[:, None]
        if values is None or values.ndim != 2 or values.shape[1] != width:
            if values is None or values.size:
                attr = pv.GetAttr().GetName() if pv is not None else f'primvars:{name}'
                what = 'RGB colours' if width == 3 else 'numbers'
                self.warn(f'{gprim.GetPath()}: {attr} is not a list of {what}; {instead}')
            return default
        if not len(values) or not np.all(np.isfinite(values)):
            return default
        where = f'{gprim.GetPath()}: {pv.GetAttr().GetName() if pv is not None else "primvars:" + name}'
        if pv is not None and pv.GetInterpolation() == UsdGeom.Tokens.constant and len(values) > 1:
            self.warn(f'{where} is constant with {len(values)} values; the first used (as Storm)')
            values = values[:1]
        if width == 3:
            return tuple(float(x) for x in values.mean(axis=0))
        a = float(values.mean())
        if not 0.0 <= a <= 1.0:
            self.warn(f'{where} is {a:g}, outside [0, 1]; clamped')
        return min(max(a, 0.0), 1.0)

    def emitting(self, index: int, radiance: tuple, mode: str = 'independent', gains: tuple = (1.0, 1.0)) -> int:
        """Index of the material of a mesh with UsdLux MeshLightAPI whose bound material is `index`,
        emitting the light's `radiance` (`lights.mesh_light_radiance`) as `light:materialSyncMode` says:
        ``materialGlowTintsLight``: the radiance times the material's emissiveColor (its glow tints the
        light; a material that does not glow leaves it untinted), ``independent``: the radiance alone;
        both keep the material's reflection.  ``noMaterialResponse``: the radiance alone on a surface
        that reflects and transmits nothing (as if no material were bound).  Every ray sees the same
        emission (the one UsdLux gives light rays), so light and BSDF sampling estimate one light.  `gains`: the
        light's inputs:diffuse and inputs:specular (`Material.light_gains`)."""
        key = ('emitting', index, radiance, mode, gains)
        if key not in self._index:
            base = self.materials[index]
            label = f'{base.path} <MeshLightAPI {mode}>'
            if mode == 'noMaterialResponse':
                # a black Lambertian: UsdPreviewSurface always reflects at grazing angles (white F90)
                emitter = Material(path=label, model=LAMBERTIAN, diffuse=(0.0, 0.0, 0.0), emission=radiance,
                                   light_gains=gains)
                self._index[key] = self._add(emitter)
                return self._index[key]
            texture = -1                         # (an emissiveColor texture tints it where the glow does)
            if mode == 'materialGlowTintsLight' and base.model == PREVIEW_SURFACE and any(base.emission):
                radiance = tuple(float(r * g) for r, g in zip(radiance, base.emission))
                texture = base.emission_texture
            self._index[key] = self._add(dataclasses.replace(base, path=label, emission=radiance,
                                                             emission_texture=texture, light_gains=gains))
        return self._index[key]

    def _add(self, material: Material) -> int:
        self.materials.append(material)
        return len(self.materials) - 1

    # ------------------------------------------------------------------ conversion
    def _convert(self, material: UsdShade.Material) -> Material | None:
        prim, path = material.GetPrim(), str(material.GetPath())
        model = prim.GetAttribute('rtc:model')
        if model and model.Get() is not None:
            if model.Get() in MODEL_NAMES:
                return self._course(prim, MODEL_NAMES[model.Get()])
            self.warn(f'{path}: unknown rtc:model "{model.Get()}"; reading its UsdPreviewSurface')
        shader, _, _ = material.ComputeSurfaceSource()
        if not shader:
            contexts = [o.GetFullName().split(':')[1] for o in material.GetOutputs()
                        if o.GetFullName().count(':') == 2]
            self.warn(f'{path}: no UsdPreviewSurface surface'
                      + (f' (only render contexts {sorted(set(contexts))})' if contexts else '')
                      + '; using displayColor/grey')
            return None
        if shader.GetShaderId() != 'UsdPreviewSurface':
            self.warn(f'{path}: surface shader {shader.GetPath()} is "{shader.GetShaderId()}", '
                      'not UsdPreviewSurface; using displayColor/grey')
            return None
        return self._preview_surface(path, shader)

    def _course(self, prim: Usd.Prim, model: int) -> Material:
        def get(name, default, kind):
            attr = prim.GetAttribute(f'rtc:{name}')
            raw = attr.Get(self.time) if attr else None
            value = None if raw is None else typed(raw, kind)
            if raw is not None and value is None:
                self.warn(f'{attr.GetPath()}: a {attr.GetTypeName()} value, not a {kind}; using its default')
            return default if value is None else value

        def colour(name, default):
            return get(name, default, 'color3')

        m = Material(path=str(prim.GetPath()), model=model,
                     diffuse=colour('diffuse', (0.0, 0.0, 0.0)), specular=colour('specular', (0.0, 0.0, 0.0)),
                     exponent=get('phongExp', 0.0, 'float'), mirror_coef=get('mirrorCoef', 0.0, 'float'),
                     roughness=get('roughness', 0.0, 'float'), ior=get('refractiveIndex', 1.5, 'float'),
                     attenuation=colour('attenuationCoef', (1.0, 1.0, 1.0)))
        for name, field in (('diffuseTexture', 'diffuse_texture'), ('specularTexture', 'specular_texture')):
            asset = get(name, None, 'asset')
            if asset is not None and asset.path:
                setattr(m, field, self.texture(asset, 'auto', 'repeat', 'repeat',
                                                (1.0,) * 4, (0.0,) * 4, f'{prim.GetPath()}.rtc:{name}'))
        return m

    def _preview_surface(self, path: str, shader: UsdShade.Shader) -> Material:
        """A UsdPreviewSurface's inputs; an unauthored one keeps the spec's default (its Sdr definition,
        `usdShaders/shaderDefs.usda`: roughness 0.5, diffuseColor 0.18, ior 1.5, clearcoatRoughness 0.01, ...)."""
        m = Material(path=path, model=PREVIEW_SURFACE, roughness=PREVIEW_ROUGHNESS)
        for name, field, kind in (
                ('diffuseColor', 'diffuse', 'color3'), ('specularColor', 'specular', 'color3'),
                ('emissiveColor', 'emission', 'color3'), ('roughness', 'roughness', 'float'),
                ('metallic', 'metallic', 'float'), ('ior', 'ior', 'float'), ('opacity', 'opacity', 'float'),
                ('opacityThreshold', 'opacity_threshold', 'float'),
                ('clearcoat', 'clearcoat', 'float'), ('clearcoatRoughness', 'clearcoat_roughness', 'float'),
                ('useSpecularWorkflow', 'use_specular_workflow', 'float')):
            value, source = self._input(shader, name, kind)
            if source is not None:
                if name in _TEXTURE_FIELDS and source.GetShaderId() == 'UsdUVTexture':
                    index, fallback = self._uv_texture(source)
                    if index >= 0:
                        setattr(m, _TEXTURE_FIELDS[name], index)
                        setattr(m, field, (1.0, 1.0, 1.0))
                    else:
                        setattr(m, field, fallback[:3])
                elif name in _SCALAR_TEXTURES and source.GetShaderId() == 'UsdUVTexture':
                    self._scalar_texture(m, shader, name, field, source)
                elif source.GetShaderId() in _READERS and _READERS[source.GetShaderId()] == kind and \
                        field != 'use_specular_workflow':
                    self._primvar_reader(source, field, kind)
                else:
                    self.warn(f'{path}: inputs:{name} is driven by {source.GetShaderId() or "a shader"} '
                              f'({source.GetPath()}), which is not supported; using its default')
                continue
            if value is not None:
                setattr(m, field, bool(value) if field == 'use_specular_workflow' else value)
        normal = self._input(shader, 'normal', 'color3')[1]
        if normal is not None and normal.GetShaderId() == 'UsdUVTexture' and self._output(shader, 'normal') == 'rgb':
            m.normal_texture = self._uv_texture(normal)[0]     # (no file: the surface's own normals)
        elif normal is not None:
            self.warn(f'{path}: inputs:normal is driven by {normal.GetShaderId() or "a shader"} '
                      f'({normal.GetPath()}{"" if normal.GetShaderId() != "UsdUVTexture" else ", not its rgb"}), '
                      'which is not supported; the surface\'s own normals used')
        displacement = self._input(shader, 'displacement', 'float')[1]
        if displacement is not None:                   # (Storm moves the points; a surface's own shape here)
            self.warn(f'{path}: inputs:displacement is driven by {displacement.GetShaderId() or "a shader"} '
                      f'({displacement.GetPath()}), which is not supported; the surface\'s own shape used')
        return m

    @staticmethod
    def _output(shader: UsdShade.Shader, name: str) -> str | None:
        """The name of the output that drives input `name` of `shader` (through material-interface inputs)."""
        for attr in shader.GetInput(name).GetValueProducingAttributes():
            if UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output:
                return UsdShade.Utils.GetBaseNameAndType(attr.GetName())[0]
        return None

    def _scalar_texture(self, m: Material, shader: UsdShade.Shader, name: str, field: str,
                        tex: UsdShade.Shader) -> None:
        """A scalar input (roughness, metallic, opacity, clearcoat, clearcoatRoughness) driven by the r, g, b or a
        output of UsdUVTexture `tex`: the texture and the channel multiply the input's value, 1
        (`kernel/materials.scalar`); the channel of the texture's fallback where its file cannot be read.  An `rgb`
        output gives its r, as a float input reads the first component of a float3."""
        index, fallback = self._uv_texture(tex)
        channel = _CHANNELS.get(self._output(shader, name), 0)
        if index < 0:
            setattr(m, field, float(fallback[channel]))
            return
        k = _SCALAR_TEXTURES[name]
        m.scalar_textures = tuple(index if j == k else t for j, t in enumerate(m.scalar_textures))
        m.scalar_channels = tuple(channel if j == k else c for j, c in enumerate(m.scalar_channels))
        setattr(m, field, 1.0)

    def _primvar_reader(self, reader: UsdShade.Shader, field: str, kind: str) -> None:
        """Record that Material field `field` reads the primvar a UsdPrimvarReader names (`bound` reads it
        per gprim); its inputs:varname (a token or string, following material-interface connections; a
        leading "primvars:" is dropped) and inputs:fallback (default 0, as its Sdr definition)."""
        varname, _ = self._input(reader, 'varname', 'token')
        fallback, _ = self._input(reader, 'fallback', kind)
        if fallback is None:
            fallback = (0.0, 0.0, 0.0) if kind == 'color3' else 0.0
        elif not np.all(np.isfinite(fallback)):
            self.warn(f'{reader.GetPath()}.inputs:fallback: {fallback} is not finite; 0 used')
            fallback = (0.0, 0.0, 0.0) if kind == 'color3' else 0.0
        name = str(varname or '')
        name = name[len('primvars:'):] if name.startswith('primvars:') else name
        if not name:
            self.warn(f'{reader.GetPath()}: {reader.GetShaderId()} without inputs:varname; its fallback used')
        self._reading.append(PrimvarInput(field, kind, name, fallback, str(reader.GetPath())))

    def _input(self, shader: UsdShade.Shader, name: str, kind: str):
        """(constant value as `kind`, None) or (None, source shader) for a shader input, following
        connections through material interface inputs; (None, None) when unauthored, or when its value is
        not a `kind` (`typed`: warned, the input's default used)."""
        inp = shader.GetInput(name)
        if not inp:
            return None, None
        for attr in inp.GetValueProducingAttributes():
            if UsdShade.Utils.GetType(attr.GetName()) == UsdShade.AttributeType.Output:
                return None, UsdShade.Shader(attr.GetPrim())
            raw = attr.Get(self.time)
            value = None if raw is None else typed(raw, kind)
            if raw is not None and value is None:
                declarer = shader.GetShaderId() or 'the shader'
                self.warn(f'{attr.GetPath()}: a {attr.GetTypeName()} value where {declarer} declares {kind}; '
                          'using its default')
            return value, None
        return None, None

    # ------------------------------------------------------------------ textures
    def _uv_texture(self, tex: UsdShade.Shader) -> tuple[int, tuple]:
        """(texture index or -1, the rgba to use when the file cannot be read: its fallback)."""
        def value(name, default, kind='token'):
            v, _ = self._input(tex, name, kind)
            return default if v is None else v
        fallback = value('fallback', (0.0, 0.0, 0.0, 1.0), 'float4')
        asset = value('file', None, 'asset')
        if asset is None or not asset.path:
            self.warn(f'{tex.GetPath()}: UsdUVTexture without inputs:file; using its fallback')
            return -1, fallback
        wraps = []
        for name in ('wrapS', 'wrapT'):
            w = str(value(name, 'useMetadata'))
            wraps.append(w if w in _WRAPS else 'repeat')
        index = self.texture(asset, str(value('sourceColorSpace', 'auto')), *wraps,
                              value('scale', (1.0,) * 4, 'float4'), value('bias', (0.0,) * 4, 'float4'),
                              str(tex.GetPath()), transform=self._st_transform(tex),
                              layer=self._authored_in(tex, 'file'))
        return index, fallback

    def _authored_in(self, shader: UsdShade.Shader, name: str) -> Sdf.Layer | None:
        """The layer whose opinion gives shader input `name` its value (through interface connections): the layer
        a relative path in it is anchored to."""
        for attr in shader.GetInput(name).GetValueProducingAttributes():
            for spec in attr.GetPropertyStack(self.time):
                if spec.HasDefaultValue() or spec.layer.GetNumTimeSamplesForPath(spec.path):
                    return spec.layer
        return None

    def _st_transform(self, tex: UsdShade.Shader) -> tuple:
        """The affine map (a, b, c, d, e, f: s' = a s + b t + c, t' = d s + e t + f) of a UsdUVTexture's texture
        coordinates: a UsdTransform2d's on its inputs:st (its `in` scaled, rotated counter-clockwise by
        `rotation` degrees, then translated, as the spec and Storm apply them; nested ones composed), else the
        identity."""
        a = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        source = self._input(tex, 'st', 'float2')[1]
        for _ in range(8):                               # (a chain of transforms; a cycle stops here)
            if source is None or source.GetShaderId() != 'UsdTransform2d':
                break
            rot = self._input(source, 'rotation', 'float')[0] or 0.0
            sx, sy = self._input(source, 'scale', 'float2')[0] or (1.0, 1.0)
            tx, ty = self._input(source, 'translation', 'float2')[0] or (0.0, 0.0)
            if not np.all(np.isfinite([rot, sx, sy, tx, ty])):
                self.warn(f'{source.GetPath()}: a value that is not finite; its texture coordinates used as they are')
                break
            c, s = np.cos(np.radians(rot)), np.sin(np.radians(rot))
            m = np.array([[c * sx, -s * sy, tx], [s * sx, c * sy, ty], [0.0, 0.0, 1.0]])
            a = tuple((np.array(a).reshape(2, 3) @ m).ravel().tolist())   # (nearer the reader: applied first)
            source = self._input(source, 'in', 'float2')[1]
        return a

    def texture(self, asset: Sdf.AssetPath, colour_space: str, wrap_s: str, wrap_t: str,
                 scale: tuple, bias: tuple, owner: str, light: bool = False,
                 transform: tuple = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0), layer: Sdf.Layer | None = None,
                 layout: str = 'latlong') -> int:
        """Index of a texture (file decoded once per colour space), -1 if it cannot be read.

        `light`: a light's radiance image (a DomeLight's lat-long texture), whose negative values are read
        as 0 with a warning, as pbrt-v4 reads them (`ClampZero`): light sampling draws directions by the
        image's luminance and never where it is negative, so only BSDF samples saw them and the estimators
        disagreed.  A material reading the same file keeps its values (normal maps are negative).  A path with
        <UDIM>: `_udim`, its tiles found against `layer`, the layer that authored it.  `layout`: a dome image's
        (`dome_formats.FORMATS`, or 'automatic': the one its file names, `dome_formats.file_layout`), kept as the
        lat-long image resampled from it (`dome_formats.relayout`)."""
        if UsdShade.UdimUtils.IsUdimIdentifier(asset.path):
            return self._udim(asset, layer, colour_space, scale, bias, owner, light, transform)
        resolved = asset.resolvedPath
        if not resolved:
            self.warn(f'{owner}: texture "{asset.path}" not found')
            return -1
        key = (resolved, colour_space, wrap_s, wrap_t, scale, bias, light, transform, layout)
        if key not in self._texture_index:
            pixels = self._load(resolved, colour_space, owner)
            self._texture_index[key] = -1
            negative = 0 if pixels is None or not light or isinstance(pixels, BytePixels) else \
                int(np.count_nonzero((pixels[..., :3] < 0.0).any(-1)))
            if negative:
                self.warn(f'{owner}: texture {resolved} has {negative} texels with negative values; the light '
                          f'reads them as 0')
                pixels = np.maximum(pixels, np.float32(0.0))
            if pixels is not None and layout == 'automatic':
                layout = file_layout(resolved)
            if pixels is not None and layout != 'latlong':
                pixels = relayout(pixels, layout, f'{owner}.inputs:texture:format', self.warn)
            if pixels is not None:
                self.textures.append(Texture(path=resolved, pixels=pixels, wrap_s=wrap_s,
                                             wrap_t=wrap_t, scale=scale, bias=bias, transform=transform))
                self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key]

    def _udim(self, asset: Sdf.AssetPath, layer: Sdf.Layer | None, colour_space: str, scale: tuple, bias: tuple,
              owner: str, light: bool, transform: tuple) -> int:
        """Index of a UDIM texture (`Texture.tiles`): the tiles 1001-1100 that `UsdShade.UdimUtils` finds for the
        path against the layer that authored it, as Storm finds them, a row of ten for each unit of t; a missing or
        unreadable tile reads as 0 (Storm draws it black), clamped at its edges.  -1 (the UsdUVTexture's fallback,
        as Storm) where no tile is found, and on a light (no UsdLux light reads UDIM tiles)."""
        if light:
            self.warn(f'{owner}: a UDIM texture ("{asset.path}") on a light is not read')
            return -1
        pattern = UsdShade.UdimUtils.ResolveUdimPath(asset.path, layer) if layer is not None else ''
        found = UsdShade.UdimUtils.ResolveUdimTilePaths(pattern, layer) if pattern else []
        paths = {int(n): p for p, n in found if str(n).isdigit() and 1001 <= int(n) <= 1100}
        if not paths:
            self.warn(f'{owner}: texture "{asset.path}" not found (no UDIM tile)')
            return -1
        key = ('udim', pattern, colour_space, scale, bias, transform)
        if key not in self._texture_index:
            rows = (max(paths) - 1001) // 10 + 1
            tiles = tuple(self._load(paths[n], colour_space, owner) if n in paths else None
                          for n in range(1001, 1001 + 10 * rows))
            self._texture_index[key] = -1
            if any(t is not None for t in tiles):
                self.textures.append(Texture(path=pattern, pixels=np.zeros((1, 1, 1), np.float32), wrap_s='clamp',
                                             wrap_t='clamp', scale=scale, bias=bias, transform=transform, tiles=tiles))
                self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key]

    def _load(self, resolved: str, colour_space: str, owner: str):
        key = (resolved, colour_space)
        if key not in self._pixels:
            try:
                pixels = read_texture(resolved, colour_space)
            except OSError as exc:
                self.warn(f'{owner}: cannot read texture {resolved}: {exc}')
                pixels = None
            if pixels is not None and not isinstance(pixels, BytePixels):      # (bytes are finite)
                bad = ~np.isfinite(pixels)
                if bad.any():       # one NaN texel of a dome made every light sample NaN: the dome went dark
                    self.warn(f'{owner}: texture {resolved} has {int(bad.sum())} NaN or infinite values; '
                              f'they are read as 0')
                    pixels[bad] = 0.0
            self._pixels[key] = pixels
        return self._pixels[key]
