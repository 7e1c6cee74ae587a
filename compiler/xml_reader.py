"""Course XML -> `scene.Scene`: safe parse, schema check, typed values, references, quirks.

Steps: parse with lxml (no entity resolution, no network, no DTD at all), report and remove
unknown elements/attributes (schema.remove_unknown), validate against schemas/scene.xsd, then
read each element into typed objects.  Every problem becomes a Diagnostic with file, line and
element; reading goes on after an error so one run reports as much as it can.

Quirk handling follows shared/xml-format.md section 13 (Qn below refers to it).
"""
from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from typing import Optional

from lxml import etree

from . import schema
from .diagnostics import CompileError, Diagnostics
from .scene import (FLOAT_MAX, Box, Camera, Cylinder, Environment, Light, MeshFile, Motion, Placement,
                    Prototype, Scene, Shader, Shape, Sphere, Texture, Transform, Triangle, Vec3)
from .transforms import Op

#: Course shader type -> (rtc:model, required parameters, optional parameters).
SHADER_MODELS: dict[str, tuple[str, tuple[str, ...], tuple[str, ...]]] = {
    "Lambertian": ("lambertian", ("diffuse",), ()),
    "LambertianPT": ("lambertian", ("diffuse",), ()),
    "BlinnPhong": ("blinnPhong", ("diffuse", "specular", "phongExp"), ()),
    "Phong": ("blinnPhong", ("diffuse", "specular", "phongExp"), ()),
    "BlinnPhongMirrored": ("blinnPhongMirrored", ("diffuse", "specular", "phongExp", "mirrorCoef"),
                           ("roughness",)),
    "Mirror": ("mirror", (), ()),
    "Glaze": ("glaze", ("diffuse", "mirrorCoef"), ()),
    "Dielectric": ("dielectric", ("refractiveIndex",), ("attenuationCoef",)),
    "CoolToWarm": ("coolToWarm", ("diffuse",), ()),
}
_COLOUR_PARAMS = ("diffuse", "specular", "attenuationCoef")
_GEOMETRY_CHILDREN = {
    "sphere": ("center", "radius"),
    "box": ("minPt", "maxPt"),
    "triangle": ("v0", "v1", "v2"),
    "cylinder": ("center", "radius", "height"),
    "mesh": ("file",),
}
#: Student shape types read as a sphere (spec section 7: S1's `skysphere`).
_SPHERE_LIKE = ("skysphere",)
#: Values a course shader gets for a parameter it lacks (the course's C++ structures start at zero;
#: mirrorCoef 0, roughness 0 and attenuation 1 1 1 as in spec section 6).  Zero specular reads a
#: `BlinnPhong` with only <diffuse> as the Lambertian it then is.
COURSE_DEFAULTS: dict[str, object] = {
    "diffuse": (0.0, 0.0, 0.0), "specular": (0.0, 0.0, 0.0), "phongExp": 1.0, "mirrorCoef": 0.0,
}
_ALL_GEOMETRY = {c for names in _GEOMETRY_CHILDREN.values() for c in names}
_CUBE_FACES = ("posX", "negX", "posY", "negY", "posZ", "negZ")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
# values are checked against scene.FLOAT_MAX (beyond it they would become infinities), except the
# transforms' operations and times: doubles (xformOps, time codes), of which only the product is checked
_DOUBLES = frozenset({"translate", "scale", "rotate", "transform"})
_PARSER = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False, load_dtd=False,
                          dtd_validation=False, remove_comments=True, remove_pis=True)


def read_scene(path: Path, diags: Diagnostics) -> Scene:
    """Read and check a scene file.  Raises CompileError when the scene has errors."""
    root = _parse(path, diags)
    omitted = _settle_types(root, diags)
    if not schema.is_valid(root.getroottree()):  # else nothing unknown to report (closed schema)
        schema.remove_unknown(root, diags)
        schema.validate(root.getroottree(), diags)
    diags.raise_if_errors()                     # typed reading assumes a structurally valid tree
    scene = _Reader(path, diags, omitted).scene(root)
    diags.raise_if_errors()
    return scene


def _settle_types(root, diags: Diagnostics) -> set[str]:
    """Unknown shader and shape types get the closest reading, with a warning, before the (closed)
    schema sees them: a misspelt type (`Mirrored`, `spheer`) is read as the known type it is
    closest to; any other shader is a Lambertian of its diffuse colour; a student `skysphere` is a
    sphere (seen from inside when the camera is in it); any other shape or prototype is omitted.
    Returns the names of omitted prototypes, whose placements are then omitted quietly."""
    omitted: set[str] = set()
    for el in root.iter("shader"):
        kind = el.get("type")
        if kind is not None and kind not in SHADER_MODELS:
            reading = _closest(kind, SHADER_MODELS) or "Lambertian"
            how = "a Lambertian of its diffuse colour" if reading == "Lambertian" else reading
            diags.at(el).warning(f"unknown shader type '{kind}': read as {how}")
            el.set("type", reading)
    for el in [e for e in root if e.tag in ("shape", "instance")]:
        kind = el.get("type")
        known = (*_GEOMETRY_CHILDREN, "instance") if el.tag == "shape" else tuple(_GEOMETRY_CHILDREN)
        if kind is None or kind in known:
            continue
        reading = "sphere" if kind in _SPHERE_LIKE else _closest(kind, known)
        if reading is not None:
            inside = " (seen from inside when the camera is in it)" if kind in _SPHERE_LIKE else ""
            diags.at(el).warning(f"unknown shape type '{kind}': read as a {reading}{inside}")
            el.set("type", reading)
            continue
        what = "the prototype and its placements are" if el.tag == "instance" else "the shape is"
        diags.at(el).warning(f"unknown shape type '{kind}': no course reading, {what} omitted")
        if el.tag == "instance" and el.get("name"):
            omitted.add(el.get("name"))
        root.remove(el)
    return omitted


def _closest(kind: str, known) -> Optional[str]:
    """The known type a misspelt one most resembles (difflib ratio 0.8 or more), or None."""
    match = difflib.get_close_matches(kind, list(known), n=1, cutoff=0.8)
    return match[0] if match else None

def _parse(path: Path, diags: Diagnostics):
    try:
        data = path.read_bytes()
    except OSError as exc:
        diags.error(f"cannot read the scene file: {exc.strerror or exc}")
        raise CompileError(diags.as_list()) from None
    doctype = data.find(b"<!DOCTYPE")
    if doctype >= 0:                            # refused before parsing: no entity is ever expanded
        diags.error("a <!DOCTYPE> is not allowed in a scene file (entity declarations could expand "
                    "without bound or read other files)", data.count(b"\n", 0, doctype) + 1)
        raise CompileError(diags.as_list())
    try:
        root = etree.fromstring(data, _PARSER, base_url=str(path))
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno and exc.lineno > 0 else None
        diags.error(f"malformed XML: {exc.msg}", line)
        raise CompileError(diags.as_list()) from None
    if root.tag != "scene":
        diags.error("the root element must be <scene>", root.sourceline, str(root.tag))
        raise CompileError(diags.as_list())
    return root


MAX_TEXTURE_PIXELS = 1 << 28                # 16k x 16k, the renderer's limit too


def _unreadable_image(path: Path) -> Optional[str]:
    """Why a texture image cannot be used (corrupt, truncated, absurd size), or None.  Decodes
    it once, so that a bad file fails at compile time rather than rendering untextured."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        return oiio.geterror().strip() or "not a readable image"
    try:
        spec = inp.spec()
        if spec.width * spec.height * spec.depth > MAX_TEXTURE_PIXELS:
            return f"{spec.width} x {spec.height} pixels is more than the limit of {MAX_TEXTURE_PIXELS}"
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.UINT8)
        if pixels is None:
            return inp.geterror().strip() or "cannot decode the pixels"
    finally:
        inp.close()
    return None


class _Reader:
    def __init__(self, path: Path, diags: Diagnostics, omitted: frozenset = frozenset()):
        self.path = path
        self.base = path.resolve().parent
        self.diags = diags
        self.textures: dict[str, Texture] = {}
        self.shaders: dict[str, Shader] = {}
        self.prototypes: dict[str, Prototype] = {}
        self.used: set[int] = set()             # id() of referenced definitions
        self.broken: set[tuple[int, str]] = set()  # (table, name) of definitions that had errors
        self.broken.update((id(self.prototypes), name) for name in omitted)

    # ------------------------------------------------------------------ scene
    def scene(self, root) -> Scene:
        background = self._root_background(root)
        envmap = root.get("envmapPrefix")
        envmap_line = root.sourceline
        cameras, lights, shapes, placements = [], [], [], []
        for el in root:
            tag = el.tag
            if tag == "sceneParameters":
                background, envmap, envmap_line = self._scene_parameters(el, background, envmap,
                                                                         envmap_line)
            elif tag == "camera":
                cameras.append(el)
            elif tag == "light":
                _append(lights, self._light(el))
            elif tag == "texture":
                self._define(self.textures, self._texture(el), el, "texture")
            elif tag == "shader":
                self._define(self.shaders, self._shader(el, el.get("name")), el, "shader")
            elif tag == "instance":
                self._define(self.prototypes, self._prototype(el), el, "instance prototype")
            elif tag == "shape":
                obj = self._shape(el)
                _append(placements if isinstance(obj, Placement) else shapes, obj)
        camera = self._cameras(root, cameras)
        if not lights:
            self.diags.warning("the scene has no light: only the background will show", root.sourceline,
                               "scene")
        self._report_unused()
        environment = self._environment(envmap, envmap_line) if envmap else None
        if camera is None:
            raise CompileError(self.diags.as_list())
        return Scene(self.path, camera, background, environment, lights, shapes, placements)

    def _root_background(self, root) -> Vec3:
        text = root.get("bgColor")
        if text is None:
            return (0.0, 0.0, 0.0)
        return self._numbers_text(text, 3, root.sourceline, "scene", "bgColor") or (0.0, 0.0, 0.0)

    def _scene_parameters(self, el, background, envmap, envmap_line):
        """<sceneParameters> (2016+ spelling) wins over the root attributes (Q1, Q2)."""
        first = self._first_children(el)
        if "bgColor" in first:
            value = self._colour(first["bgColor"])
            if value is not None:
                if el.getparent().get("bgColor") is not None:
                    self.diags.at(first["bgColor"]).warning(
                        "background given both as <scene bgColor> and here; this one is used")
                background = value
        if "envMapPrefix" in first:
            envmap, envmap_line = (first["envMapPrefix"].text or "").strip(), first["envMapPrefix"].sourceline
        return background, envmap, envmap_line

    def _cameras(self, root, cameras) -> Optional[Camera]:
        if not cameras:
            self.diags.error("the scene has no <camera>", root.sourceline, "scene")
            return None
        for extra in cameras[1:]:
            self.diags.at(extra).warning("only the first <camera> is used")
        return self._camera(cameras[0])

    # ------------------------------------------------------------------ definitions
    def _define(self, table: dict, obj, el, what: str) -> None:
        name = el.get("name")
        if obj is None:                         # already reported; later references stay quiet
            self.broken.add((id(table), name))
            return
        if name in table:
            self.diags.at(el).warning(f"{what} '{name}' is already defined at line {table[name].line}; "
                                      "the first definition is used (as the course parser does)")
            return
        table[name] = obj

    def _report_unused(self) -> None:
        for what, table in (("texture", self.textures), ("shader", self.shaders),
                            ("instance prototype", self.prototypes)):
            for name, obj in table.items():
                if id(obj) not in self.used:
                    self.diags.warning(f"{what} '{name}' is never used and is not written", obj.line,
                                       "instance" if what.startswith("instance") else what)

    def _lookup(self, table: dict, name: str, el, what: str):
        obj = table.get(name)
        if obj is None and (id(table), name) in self.broken:
            return None
        if obj is None:
            known = ", ".join(sorted(table)) or "none defined"
            self.diags.at(el).error(f"unknown {what} '{name}' (defined before this point: {known})")
            return None
        self.used.add(id(obj))
        return obj

    # ------------------------------------------------------------------ camera and lights
    def _camera(self, el) -> Optional[Camera]:
        at = self.diags.at(el)
        c = self._first_children(el)
        position = self._vec_child(el, c, "position")
        focal = self._positive_child(el, c, "focalLength")
        width = self._positive_child(el, c, "imagePlaneWidth")
        lookat = self._vector(c["lookatPoint"]) if "lookatPoint" in c else None
        view_dir = self._vector(c["viewDir"]) if "viewDir" in c else None
        if "lookatPoint" in c and "viewDir" in c:
            self.diags.at(c["viewDir"]).warning("both <viewDir> and <lookatPoint> given: lookatPoint "
                                                "wins (as in the course code)")
        gaze = None
        if lookat is not None and position is not None:
            gaze = tuple(a - b for a, b in zip(lookat, position))
        elif "lookatPoint" not in c:
            gaze = view_dir
            if "viewDir" not in c:
                at.error("a camera needs <viewDir> or <lookatPoint>")
        if gaze is not None and math.hypot(*gaze) == 0.0:
            at.error("the view direction is zero (lookatPoint equals position, or viewDir is 0 0 0)")
            gaze = None
        lens = self._scalar(c["lensRadius"], minimum=0.0) if "lensRadius" in c else 0.0
        focus = self._positive(c["focusDistance"]) if "focusDistance" in c else None
        shutter = self._shutter(c["shutter"]) if "shutter" in c else None
        if None in (position, focal, width, gaze, lens):
            return None
        return Camera(el.get("type", "perspective"), position, gaze, focal, width, el.sourceline,
                      lookat=lookat, lens_radius=lens, focus_distance=focus, shutter=shutter)

    def _shutter(self, el) -> Optional[tuple[float, float]]:
        times = [self._numbers_text(el.get(k), 1, el.sourceline, "shutter", k) for k in ("open", "close")]
        if None in times:
            return None
        (t0,), (t1,) = times
        if t1 < t0:
            self.diags.at(el).error(f"shutter closes ({t1:g}) before it opens ({t0:g})")
            return None
        return (t0, t1)

    def _light(self, el) -> Optional[Light]:
        c = self._first_children(el)
        kind = el.get("type")
        position = self._vec_child(el, c, "position")
        intensity = self._colour_child(el, c, "intensity")
        if kind == "point":
            extra = [n for n in ("normal", "width", "length") if n in c]
            if extra:
                self.diags.at(el).warning(f"area-light fields ({', '.join(extra)}) on a point light are "
                                          "ignored")
            if None in (position, intensity):
                return None
            return Light("point", position, intensity, el.sourceline)
        normal = self._vec_child(el, c, "normal")
        width = self._positive_child(el, c, "width")
        length = self._positive_child(el, c, "length")
        if normal is not None and math.hypot(*normal) == 0.0:
            self.diags.at(c["normal"]).error("the area light's normal is zero")
            normal = None
        if None in (position, intensity, normal, width, length):
            return None
        return Light("area", position, intensity, el.sourceline, normal, width, length)

    # ------------------------------------------------------------------ textures and shaders
    def _texture(self, el) -> Optional[Texture]:
        c = self._first_children(el)
        if "sourcefile" not in c:
            self.diags.at(el).error("a texture needs a <sourcefile>")
            return None
        fallback = "the shader's colour is used instead"
        path = self._existing_file(c["sourcefile"], "texture image", fallback)
        problem = _unreadable_image(path) if path else None
        if problem:
            self.diags.at(c["sourcefile"]).warning(f"texture image {path}: {problem}; {fallback}")
            return None
        return Texture(el.get("name"), path, el.sourceline) if path else None

    def _shader(self, el, name: str) -> Optional[Shader]:
        course_type = el.get("type")
        model, required, optional = SHADER_MODELS[course_type]
        at = self.diags.at(el)
        c = self._first_children(el)
        if course_type == "LambertianPT":
            at.warning("LambertianPT (the course's path-tracing variant) is rendered as Lambertian")
        if course_type == "BlinnPhong" and "mirrorCoef" in c:
            # 2011-2015 spelling of the mirrored variant (Q7).
            model, required, optional = "blinnPhongMirrored", required + ("mirrorCoef",), ("roughness",)
        if course_type == "Dielectric" and "refractiveIndex" not in c:
            at.warning("Dielectric without <refractiveIndex>: using 1.5 (glass)")
            required = ()
        for missing in (p for p in required if p not in c):
            default = COURSE_DEFAULTS[missing]
            text = " ".join(f"{v:g}" for v in default) if isinstance(default, tuple) else f"{default:g}"
            at.warning(f"a {course_type} shader has no <{missing}>: using the course's default {text}")
        known = set(required) | set(optional) | {"diffusetex"}
        for extra in (p for p in c if p not in known):
            self.diags.at(c[extra]).warning(f"<{extra}> is not a parameter of a {course_type} shader; "
                                            "ignored")
        shader = Shader(name, model, el.sourceline, course_type)
        values = {}
        for param in (p for p in (*required, *optional) if p in c):
            values[param] = (self._colour(c[param]) if param in _COLOUR_PARAMS else
                             self._scalar(c[param], minimum=0.0))
        shader.diffuse = values.get("diffuse", _default("diffuse", required))
        shader.specular = values.get("specular", _default("specular", required))
        shader.phong_exp = values.get("phongExp", _default("phongExp", required))
        if "mirrorCoef" in required:
            shader.mirror_coef = values.get("mirrorCoef", COURSE_DEFAULTS["mirrorCoef"])
            if shader.mirror_coef is not None and shader.mirror_coef > 1.0:
                self.diags.at(c["mirrorCoef"]).warning("mirrorCoef above 1 reflects more light than "
                                                       "arrives")
        if "roughness" in optional:
            shader.roughness = values.get("roughness", 0.0)
        if model == "dielectric":
            shader.refractive_index = values.get("refractiveIndex", 1.5)
            if shader.refractive_index == 0.0:
                self.diags.at(c["refractiveIndex"]).error("refractiveIndex must be positive")
            shader.attenuation = values.get("attenuationCoef", (1.0, 1.0, 1.0))
        shader.diffuse_texture = self._shader_texture(c, "diffuse", required)
        shader.specular_texture = self._shader_texture(c, "specular", required)
        if any(v is None for k, v in values.items()):
            return None
        return shader

    def _shader_texture(self, c: dict, colour: str, params: tuple) -> Optional[Texture]:
        """The texture multiplying `colour`: <diffuse tex="t"> (Q3, 2016+) or <diffusetex>t</...>."""
        ref_el, name = None, None
        if colour in c and c[colour].get("tex"):
            ref_el, name = c[colour], c[colour].get("tex")
        elif colour == "diffuse" and "diffusetex" in c:
            ref_el, name = c["diffusetex"], (c["diffusetex"].text or "").strip()
        if ref_el is None:
            return None
        if colour not in params:
            self.diags.at(ref_el).warning(f"this shader has no {colour} colour for a texture to multiply; "
                                          "ignored")
            return None
        return self._lookup(self.textures, name, ref_el, "texture")

    def _shader_use(self, el, owner: str, placement: bool) -> Optional[Shader]:
        """<shader ref="n"/> or an inline definition <shader type="T">...</shader>."""
        ref = el.get("ref")
        if ref is not None:
            if el.get("type") is not None:
                self.diags.at(el).warning("both 'ref' and 'type' given: the reference is used")
            if placement and ref == "null":
                return None                     # S2's spelling of "use the prototype's shader"
            return self._lookup(self.shaders, ref, el, "shader")
        if el.get("type") is None:
            self.diags.at(el).error("a <shader> here needs ref=\"name\" or an inline type=\"...\"")
            return None
        return self._shader(el, el.get("name") or f"{owner or 'shape'}_shader")

    # ------------------------------------------------------------------ objects
    def _prototype(self, el) -> Optional[Prototype]:
        c = self._first_children(el)
        kind = el.get("type")
        geometry = self._geometry(el, c, kind)
        shader = self._object_shader(el, c, placement=False)
        transform = None
        transforms = el.findall("transform")
        if transforms:
            self.diags.at(transforms[0]).warning(
                "a transform inside an <instance> prototype applies inside every placement (the 2014 "
                "course code ignored it)")
            motion = self._motion(transforms)
            if motion is not None and motion.is_animated:
                self.diags.at(transforms[0]).error("a prototype's transform cannot be animated")
                return None
            transform = motion.samples[0] if motion is not None and motion.samples else None
        if geometry is None or shader is None:
            return None
        return Prototype(el.get("name"), geometry, shader, el.sourceline, transform)

    def _shape(self, el):
        c, transforms = self._children(el)
        kind = el.get("type")
        name = el.get("name") or f"{kind}"
        motion = self._motion(transforms)
        if kind == "instance":
            for extra in (n for n in c if n in _ALL_GEOMETRY):
                self.diags.at(c[extra]).warning("geometry on a placement is ignored (it comes from the "
                                                "prototype)")
            proto_name = el.get("id")
            if proto_name is None:
                self.diags.at(el).error("a shape of type \"instance\" needs id=\"prototype name\"")
                return None
            prototype = self._lookup(self.prototypes, proto_name, el, "instance prototype")
            shader = self._object_shader(el, c, placement=True)
            if prototype is None or motion is None or shader is False:
                return None
            return Placement(name, prototype, motion, el.sourceline, shader)
        if "id" in el.attrib:
            self.diags.at(el).warning(f"'id' only applies to type=\"instance\"; ignored on a {kind}")
        geometry = self._geometry(el, c, kind)
        shader = self._object_shader(el, c, placement=False)
        if geometry is None or shader is None or motion is None:
            return None
        return Shape(name, geometry, shader, motion, el.sourceline)

    def _object_shader(self, el, c: dict, placement: bool):
        """The shader of a shape/prototype (required) or a placement (optional override: None =
        inherit, False = broken reference)."""
        if "shader" not in c:
            if placement:
                return None
            self.diags.at(el).error("this shape needs a <shader> (the course requires one on every "
                                    "plain shape and prototype)")
            return None
        shader = self._shader_use(c["shader"], el.get("name"), placement)
        if shader is None and placement and c["shader"].get("ref") != "null":
            return False
        return shader

    def _geometry(self, el, c: dict, kind: str):
        needed = _GEOMETRY_CHILDREN[kind]
        for extra in (n for n in c if n in _ALL_GEOMETRY and n not in needed):
            self.diags.at(c[extra]).warning(f"<{extra}> is not used by a {kind}; ignored")
        missing = [n for n in needed if n not in c]
        if missing:
            self.diags.at(el).error(f"a {kind} needs " + ", ".join(f"<{n}>" for n in missing))
            return None
        if kind == "mesh":
            path = self._existing_file(c["file"], "mesh file", "the prototype and its placements are omitted"
                                       if el.tag == "instance" else "the shape is omitted")
            return MeshFile(path, c["file"].sourceline) if path else None
        if kind == "sphere":
            center, radius = self._vector(c["center"]), self._positive(c["radius"])
            return None if None in (center, radius) else Sphere(center, radius)
        if kind == "cylinder":
            center, radius, height = self._vector(c["center"]), self._positive(c["radius"]), \
                self._positive(c["height"])
            return None if None in (center, radius, height) else Cylinder(center, radius, height)
        if kind == "box":
            return self._box(c["minPt"], c["maxPt"])
        v = [self._vector(c[n]) for n in ("v0", "v1", "v2")]
        if None in v:
            return None
        e1 = [b - a for a, b in zip(v[0], v[1])]
        e2 = [b - a for a, b in zip(v[0], v[2])]
        cross = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        if math.hypot(*cross) == 0.0:
            self.diags.at(el).warning("degenerate triangle (zero area): it can never be hit")
        return Triangle(*v)

    def _box(self, min_el, max_el) -> Optional[Box]:
        lo, hi = self._vector(min_el), self._vector(max_el)
        if lo is None or hi is None:
            return None
        swapped = [axis for axis, a, b in zip("xyz", lo, hi) if a > b]
        if swapped:
            self.diags.at(min_el).warning(f"minPt > maxPt along {', '.join(swapped)}: the corners are "
                                          "swapped on that axis")
        flat = [axis for axis, a, b in zip("xyz", lo, hi) if a == b]
        if len(flat) == 3:
            self.diags.at(min_el).warning("the box is a single point (minPt = maxPt): it cannot be "
                                          "seen and is skipped")
            return None
        if flat:
            self.diags.at(min_el).warning(f"the box has zero extent along {', '.join(flat)}: it is "
                                          "written as a flat mesh")
        return Box(tuple(map(min, lo, hi)), tuple(map(max, lo, hi)))

    # ------------------------------------------------------------------ transforms
    def _motion(self, elements) -> Optional[Motion]:
        """All <transform> children of one object: one static transform, or timed samples (rtc
        extension).  None if any is broken."""
        transforms = [self._transform(t) for t in elements]
        if None in transforms:
            return None
        if len(transforms) == 1 and transforms[0].time is None:
            return Motion((transforms[0],))      # the common case: one static transform
        static = [t for t in transforms if t.time is None]
        timed = [t for t in transforms if t.time is not None]
        if timed:
            for s in static:
                self.diags.error("a transform without 'time' next to timed ones is ignored", s.line,
                                 "transform")
            times = [t.time for t in timed]
            if len(set(times)) != len(times):
                self.diags.error("two transforms have the same time", timed[0].line, "transform")
                return None
            return Motion(tuple(sorted(timed, key=lambda t: t.time)))
        for extra in static[1:]:
            self.diags.warning("only the first <transform> is used (add time=\"...\" for motion "
                               "samples)", extra.line, "transform")
        return Motion(tuple(static[:1]))

    def _transform(self, el) -> Optional[Transform]:
        time = None
        if el.get("time") is not None:
            value = self._numbers_text(el.get("time"), 1, el.sourceline, "transform", "time")
            if value is None:
                return None
            time = value[0]
        ops = []
        for op in el:
            tag = op.tag
            if tag == "rotate":
                angle = self._scalar(op)
                ops.append(None if angle is None else Op("rotate" + op.get("axis"), angle))
            else:
                ops.append(None if (v := self._vector(op)) is None else Op(tag, v))
        if None in ops:
            return None
        return Transform(tuple(ops), el.sourceline, time)

    # ------------------------------------------------------------------ environment
    def _environment(self, prefix: str, line: int) -> Optional[Environment]:
        """Cube-map faces prefix + {pos,neg}{X,Y,Z}.png.  The course files point at a data/ folder
        that never existed while the faces ship in images/ (Q4): look there too."""
        def faces(p: Path) -> dict[str, Path]:
            return {f: p.parent / f"{p.name}{f}.png" for f in _CUBE_FACES}

        given = self.base / prefix
        candidates = [given, self.base / "images" / given.name]
        for candidate in candidates:
            found = faces(candidate)
            if all(f.is_file() for f in found.values()):
                if candidate != given:
                    self.diags.warning(f"environment map '{prefix}' not found; using the faces in "
                                       f"{candidate.parent.relative_to(self.base)}/ instead", line,
                                       "envMapPrefix")
                return Environment(found)
        self.diags.warning(f"environment map faces '{prefix}{{pos,neg}}{{X,Y,Z}}.png' not found; the "
                           "background colour is used instead", line, "envMapPrefix")
        return None

    # ------------------------------------------------------------------ values
    def _first_children(self, el) -> dict:
        """Child elements by tag, first occurrence wins (spec section 1); repeats are warned about
        (transforms, which carry motion samples, are read separately)."""
        return self._children(el)[0]

    def _children(self, el) -> tuple[dict, list]:
        """`_first_children` and the list of every <transform> child, in one pass."""
        first: dict = {}
        transforms = []
        for child in el:
            tag = child.tag
            if tag == "transform":
                transforms.append(child)
                first.setdefault(tag, child)
            elif tag in first:
                self.diags.at(child).warning(f"repeated <{tag}>: the first one (line "
                                             f"{first[tag].sourceline}) is used")
            else:
                first[tag] = child
        return first, transforms

    def _existing_file(self, el, what: str, fallback: str) -> Optional[Path]:
        """The file an element names, or None with a warning saying what happens without it (the
        course parsers go on without a missing mesh or image)."""
        text = (el.text or "").strip()
        if not text:
            self.diags.at(el).warning(f"empty {what} path; {fallback}")
            return None
        path = (self.base / text).resolve()
        if not path.is_file():
            self.diags.at(el).warning(f"{what} '{text}' not found (looked for {path}); {fallback}")
            return None
        return path

    def _vec_child(self, el, c: dict, name: str) -> Optional[Vec3]:
        if name not in c:
            self.diags.at(el).error(f"missing <{name}>")
            return None
        return self._vector(c[name])

    def _colour_child(self, el, c: dict, name: str) -> Optional[Vec3]:
        if name not in c:
            self.diags.at(el).error(f"missing <{name}>")
            return None
        return self._colour(c[name])

    def _positive_child(self, el, c: dict, name: str) -> Optional[float]:
        if name not in c:
            self.diags.at(el).error(f"missing <{name}>")
            return None
        return self._positive(c[name])

    def _vector(self, el) -> Optional[Vec3]:
        return _finite_numbers(el.text, 3) or self._numbers_text(el.text, 3, el.sourceline, el.tag)

    def _colour(self, el) -> Optional[Vec3]:
        value = self._vector(el)
        if value is not None and min(value) < 0.0:
            self.diags.at(el).warning("negative colour component")
        return value

    def _scalar(self, el, minimum: Optional[float] = None) -> Optional[float]:
        value = _finite_numbers(el.text, 1) or self._numbers_text(el.text, 1, el.sourceline, el.tag)
        if value is None:
            return None
        if minimum is not None and value[0] < minimum:
            self.diags.at(el).error(f"must be at least {minimum:g}, got {value[0]:g}")
            return None
        return value[0]

    def _positive(self, el) -> Optional[float]:
        value = self._numbers_text(el.text, 1, el.sourceline, el.tag)
        if value is None:
            return None
        if value[0] <= 0.0:
            self.diags.at(el).error(f"must be positive, got {value[0]:g}")
            return None
        return value[0]

    def _numbers_text(self, text: Optional[str], count: int, line: int, element: str,
                      attribute: Optional[str] = None) -> Optional[tuple]:
        """Exactly `count` finite decimals.  Text a C++ stream would still read greedily
        ("-5.5.0 0.0 -7.5" -> -5.5 .0 0.0, Q12) is read the same way, with a warning.  Element
        values try `_finite_numbers` first and come here only when it fails, with the line."""
        values = _finite_numbers(text, count)
        if values is not None:
            return values
        tokens = (text or "").split()
        try:
            values = tuple(map(float, tokens))
        except ValueError:
            values = None
        where = f"attribute '{attribute}': " if attribute else ""
        text = " ".join(tokens)
        noun = "number" if count == 1 else "numbers"
        if values is None:
            values = _greedy(text, count)
            if values is None:
                self.diags.error(f"{where}expected {count} {noun}, got {text!r}", line, element)
                return None
            self.diags.warning(f"{where}malformed {noun} {text!r} read as "
                               f"{' '.join(f'{v:g}' for v in values)} (the course's C++ parser reads "
                               "greedily); please fix the file", line, element)
        elif len(values) != count:
            self.diags.error(f"{where}expected {count} {noun}, got {len(values)}: {text!r}", line, element)
            return None
        if not all(map(math.isfinite, values)):
            self.diags.error(f"{where}NaN and infinity are not allowed: {text!r}", line, element)
            return None
        if element not in _DOUBLES and max(map(abs, values), default=0.0) > FLOAT_MAX:
            self.diags.error(f"{where}{text!r} is beyond the 32-bit float range (magnitude at most "
                             f"{FLOAT_MAX:.7g}) in which USD and the renderer hold it", line, element)
            return None
        return values


def _finite_numbers(text: Optional[str], count: int) -> Optional[tuple[float, ...]]:
    """`count` finite numbers within the 32-bit float range (FLOAT_MAX), or None for anything else (then
    `_Reader._numbers_text` reads the text again and reports the problem).  This is the path of every
    well-formed value, so it does no bookkeeping: no line lookup, no message; one sum tests all values
    for NaN and infinity (an overflowing sum only sends the value down the exact path), and only text
    that can hold a value beyond FLOAT_MAX (an exponent, or 39 characters) pays for a sum of magnitudes."""
    try:
        values = tuple(map(float, text.split()))
    except (ValueError, AttributeError):
        return None
    if len(values) != count:
        return None
    if len(text) < 39 and "e" not in text and "E" not in text:
        return values if math.isfinite(sum(values)) else None
    return values if sum(map(abs, values)) <= FLOAT_MAX else None


def _greedy(text: str, count: int) -> Optional[tuple[float, ...]]:
    """Read `count` numbers the way `stream >> double` does; None if the stream would fail."""
    values, pos = [], 0
    for _ in range(count):
        while pos < len(text) and text[pos].isspace():
            pos += 1
        match = _NUMBER.match(text, pos)
        if match is None:
            return None
        values.append(float(match.group()))
        pos = match.end()
    return tuple(values)


def _default(param: str, required: tuple):
    """The course default of a required parameter the shader lacks (None if not required)."""
    return COURSE_DEFAULTS[param] if param in required else None


def _append(items: list, obj) -> None:
    if obj is not None:
        items.append(obj)
