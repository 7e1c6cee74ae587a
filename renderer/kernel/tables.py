"""The column layouts of the flat tables the builder writes and the kernels read, declared once.

Each table is a list of (field, width) pairs; the offsets, the row width and the module-level
constants the kernels index with (`MF_KD`, `LF_RAD`, `C_FOCUS`, ...: prefix + field = offset of the
field's first column) are generated from that list.  The host writes rows through the same
declaration (`MATERIAL_F.write(row, KD=..., ...)`), so no column is numbered by hand anywhere.

Tables (arrays of `SceneData`, and the camera table):

* `MATERIAL_F` (MF_*, `mat_f` float32): colours and scalars of a material.
* `MATERIAL_I` (MI_*, `mat_i` int32): the shading model, texture ids (-1 = none), whether the diffuse
  colour (bit VC_COLOR) and the opacity (VC_OPACITY) are multiplied by the gprim's per-corner displayColor and
  displayOpacity (VERTEX_COLOR: the RGB and the A of its `tri_c` rows), and the textures and channels
  that multiply roughness, metallic, opacity, clearcoat and clearcoatRoughness (SCALAR_TEX, SCALAR_CH: S_ROUGH,
  S_METAL, S_OPACITY, S_CLEARCOAT, S_CC_ROUGH), and the texture of its tangent-space normal (NORMAL_TEX).
* `LIGHT_F` (LF_*, `li_f` float64): light-to-world 3x4 (camera-relative), radiance, sizes, cone, area.
* `TEXTURE_I` (TI_*, `tex_i` int64) and `TEXTURE_F` (TF_*, `tex_f` float32): where a texture's texels
  are in `tex_data` (float32), or in `tex_bytes` for an 8-bit image (BYTES: how many of its channels are read as
  sRGB, through row 1 of `tex_lut`, the others through row 0; -1: floats), its size, channels and wrap modes; its
  scale and bias (rgba) and the affine map of its texture coordinates (XF: a UsdTransform2d's; the identity without
  one).  A UDIM texture's UDIM: the entry read
  outside its tiles (a texel 0), followed by its 10 x UDIM_ROWS tiles (`textures.udim_tile`); -1 for any other.
* `CAMERA` (C_*, float64 vector): see `cameras.camera_table`.

Enumerations stored in the tables: gprim kinds (GP_MESH, GP_SPHERE, GP_CURVES) and flags (GP_HAS_NORMALS,
GP_HAS_UVS, GP_CLOUD - a sphere gprim of several spheres, a point cloud -, GP_HAS_COLORS, GP_LINEAR - curves
of linear segments -, GP_RIBBON - curves facing their normals -, bits of `gp_flags`), texture
wrap modes (WRAP_*, by UsdUVTexture name in `WRAP`).
"""
from __future__ import annotations


class Table:
    """A row layout: named fields of given widths, packed in declaration order."""

    def __init__(self, prefix: str, fields):
        self.prefix = prefix
        self.fields = tuple(fields)
        self.offset, self.widths = {}, {}
        width = 0
        for name, w in self.fields:
            self.offset[name] = width
            self.widths[name] = w
            width += w
        self.width = width

    def constants(self) -> dict:
        """{'PREFIX_FIELD': offset of the field's first column}."""
        return {f'{self.prefix}_{name}': off for name, off in self.offset.items()}

    def write(self, row, **values) -> None:
        """Store field values into one row (a 1-D array of `self.width` columns)."""
        for name, v in values.items():
            off = self.offset[name]
            if self.widths[name] == 1:
                row[off] = v
            else:
                row[off:off + self.widths[name]] = v

    def write_rows(self, rows, **values) -> None:
        """Store each field's values (an array, one a row) into rows (n, `self.width`)."""
        for name, v in values.items():
            off, width = self.offset[name], self.widths[name]
            rows[:, off:off + width] = v.reshape(len(rows), width)


MATERIAL_F = Table('MF', [('KD', 3), ('KS', 3), ('EXP', 1), ('MIRROR', 1), ('ROUGH', 1), ('IOR', 1),
                          ('ATTEN', 3), ('EMIT', 3), ('METAL', 1), ('OPACITY', 1), ('SPECWF', 1),
                          ('CLEARCOAT', 1), ('CC_ROUGH', 1), ('OPACITY_CUT', 1), ('GAIN', 2)])
MATERIAL_I = Table('MI', [('MODEL', 1), ('DIFFUSE_TEX', 1), ('SPECULAR_TEX', 1), ('EMISSION_TEX', 1),
                          ('VERTEX_COLOR', 1), ('SCALAR_TEX', 5), ('SCALAR_CH', 5),
                          ('NORMAL_TEX', 1)])
VC_COLOR, VC_OPACITY = 1, 2                   # the bits of MI_VERTEX_COLOR
# the inputs of MI_SCALAR_TEX / MI_SCALAR_CH (a texture and the channel of it that multiplies each), in order
S_ROUGH, S_METAL, S_OPACITY, S_CLEARCOAT, S_CC_ROUGH = 0, 1, 2, 3, 4
# COURSE: 1 for a course light (RtcCourseLightAPI), whose course intensity COURSE_I the cook integrator
# uses with the course's semantics (lights.sample_course_light); LENGTH: a cylinder light's (along local X);
# SHAPED: 1 for a light shaped by UsdLux.ShapingAPI, its CONE (the cone's angle and the angle its soft edge starts
# at, radians), FOCUS and focus TINT (`lights.shaped`); IES: its IES profile's offset in li_ies (-1: none),
# 1 + angleScale and gain (`ies_profiles.ies_weight`); GAIN: UsdLux inputs:diffuse and inputs:specular, the
# light's effect on the diffuse and on the specular lobes it lights (`lights.lobe_gains`)
LIGHT_F = Table('LF', [('M', 12), ('RAD', 3), ('RADIUS', 1), ('W', 1), ('H', 1), ('COS_MAX', 1), ('AREA', 1),
                       ('COURSE', 1), ('COURSE_I', 3), ('LENGTH', 1), ('SHAPED', 1), ('CONE', 2), ('FOCUS', 1),
                       ('TINT', 3), ('IES', 3), ('GAIN', 2)])
TEXTURE_I = Table('TI', [('OFFSET', 1), ('WIDTH', 1), ('HEIGHT', 1), ('CHANNELS', 1), ('WRAP_S', 1),
                         ('WRAP_T', 1), ('UDIM', 1), ('UDIM_ROWS', 1), ('BYTES', 1)])
TEXTURE_F = Table('TF', [('SCALE', 4), ('BIAS', 4), ('XF', 6)])
# camera: camera-to-world 3x4 at shutter open and close (camera-relative world: translation 0 at open;
# M1 == M when the camera does not move), orthographic flag, half film width / height (over the focal
# length for perspective), film offsets, lens radius, focus distance, clipping range, moving flag
CAMERA = Table('C', [('M', 12), ('M1', 12), ('ORTHO', 1), ('HALF_W', 1), ('HALF_H', 1), ('OFF_X', 1),
                     ('OFF_Y', 1), ('LENS', 1), ('FOCUS', 1), ('NEAR', 1), ('FAR', 1), ('MOVING', 1)])

# the path integrator's light tree (host/light_tree.py, kernel/light_tree.py): a node's bounds - centre,
# its bounding sphere's radius (half its box's diagonal) - power, the cone of emission normals (axis, cos
# and sin of its half-angle; the sine's sign bit set: two-sided).  Every light emits up to pi/2 from its
# normals (UsdLux: a hemisphere about each normal, or everywhere), so the emission angle is no field.
# A row of the tree is a *block*: the nodes of TREE_LEVELS levels of the binary tree below one node (its
# children in slots 0-1, theirs in 2-5, theirs in 6-13: the children of slot s are in slots 2s + 2 and
# 2s + 3), TREE_SLOTS slots, field-major: column T_x * TREE_SLOTS + j is field x of slot j (so that the
# kernel's loop over a block's slots reads consecutive values: it vectorises)
TREE_LEVELS, TREE_SLOTS = 3, 16
LIGHT_TREE = Table('T', [('C', 3), ('RADIUS', 1), ('PHI', 1), ('W', 3), ('COS_O', 1), ('SIN_O', 1)])

# the path integrator's emissive surfaces as lights (host/surface_lights.py, kernel/surface_lights.py): a
# light's emitted radiance, total area, a sphere's world centre and radius; an ellipsoid's axes A (3x3,
# row-major: its points are centre + A n for the unit vectors n) and their inverse, its AREA 4 pi |det A|
# (float64); its first world triangle and their count, 0 for a sphere or an ellipsoid, 1 for an
# ellipsoid, and for a moving placement 1 and its instance (geometry id, index) in the top-level scene
# (int64: its triangles, centre, radius and AREA are the object's, placed at a ray's time by Embree's matrix);
# a curve segment's world Bezier control points (x, y, z, radius: CTRL, 4 x 4 row-major) and CURVE 1 (CURVE_CUBIC;
# CURVE_LINEAR: a linear segment's cone side as a straight Bezier, `host/surface_lights.cone_sides`); the material
# whose opacity texture the emission is multiplied by at each point (OPACITY_MAT, -1: none); the material that emits
# (MAT: its MF_GAIN, a MeshLightAPI's inputs:diffuse and inputs:specular); a linear segment's lights of the round
# ends or joints at its two ends (CAP0, CAP1: surface-light indices, -1: none); CURVE_CAP: such a light, the sphere
# (CENTER, RADIUS) of an end or a joint, its part outside the cones that meet it (CTRL: CAP_PLANES rows (a, z), the
# unit normals n with n . a >= z; the first row's cap the one drawn, of area AREA)
CURVE_CUBIC, CURVE_LINEAR, CURVE_CAP = 1, 2, 3
CAP_PLANES = 4
SURFACE_LIGHT_F = Table('SLF', [('RAD', 3), ('AREA', 1), ('CENTER', 3), ('RADIUS', 1), ('AXES', 9), ('INV', 9),
                                ('CTRL', 16)])
SURFACE_LIGHT_I = Table('SLI', [('FIRST', 1), ('COUNT', 1), ('ELLIPSOID', 1), ('MOVING', 1), ('INST', 1),
                                ('INST_PRIM', 1), ('EMISSION_TEX', 1), ('GPRIM', 1), ('CURVE', 1), ('OPACITY_MAT', 1),
                                ('MAT', 1), ('CAP0', 1), ('CAP1', 1)])

TABLES = (MATERIAL_F, MATERIAL_I, LIGHT_F, TEXTURE_I, TEXTURE_F, CAMERA, LIGHT_TREE, SURFACE_LIGHT_F, SURFACE_LIGHT_I)
for _t in TABLES:
    globals().update(_t.constants())
MAT_F_COLS = MATERIAL_F.width
MAT_I_COLS = MATERIAL_I.width
LI_F_COLS = LIGHT_F.width
TEX_I_COLS = TEXTURE_I.width
TEX_F_COLS = TEXTURE_F.width
TREE_COLS = LIGHT_TREE.width
CAM_COLS = CAMERA.width

# gprim kinds (gp_kind) and flag bits (gp_flags)
GP_MESH, GP_SPHERE, GP_CURVES = 0, 1, 2
GP_HAS_NORMALS, GP_HAS_UVS, GP_CLOUD, GP_HAS_COLORS, GP_LINEAR, GP_RIBBON = 1, 2, 4, 8, 16, 32
# texture wrap modes (tex_i[:, TI_WRAP_S / TI_WRAP_T]), by UsdUVTexture wrapS / wrapT token
WRAP_REPEAT, WRAP_CLAMP, WRAP_MIRROR, WRAP_BLACK = 0, 1, 2, 3
WRAP = {'repeat': WRAP_REPEAT, 'clamp': WRAP_CLAMP, 'mirror': WRAP_MIRROR, 'black': WRAP_BLACK}

__all__ = ['Table', 'MATERIAL_F', 'MATERIAL_I', 'LIGHT_F', 'TEXTURE_I', 'TEXTURE_F',
           'CAMERA', 'LIGHT_TREE', 'SURFACE_LIGHT_F', 'SURFACE_LIGHT_I', 'TREE_COLS', 'TREE_LEVELS', 'TREE_SLOTS', 'TABLES', 'S_ROUGH', 'S_METAL',
           'S_OPACITY', 'S_CLEARCOAT', 'S_CC_ROUGH', *(name for t in TABLES for name in t.constants()), 'MAT_F_COLS', 'MAT_I_COLS',
           'LI_F_COLS', 'TEX_I_COLS', 'TEX_F_COLS', 'CAM_COLS', 'GP_MESH', 'GP_SPHERE', 'GP_CURVES',
           'GP_HAS_NORMALS', 'GP_LINEAR', 'GP_RIBBON', 'CURVE_CUBIC', 'CURVE_LINEAR', 'CURVE_CAP', 'CAP_PLANES',
           'GP_HAS_UVS', 'GP_CLOUD', 'GP_HAS_COLORS', 'VC_COLOR', 'VC_OPACITY', 'WRAP_REPEAT', 'WRAP_CLAMP',
           'WRAP_MIRROR', 'WRAP_BLACK', 'WRAP']
