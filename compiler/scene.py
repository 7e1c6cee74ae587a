"""The typed scene description the XML reader produces and the USD writer consumes.

Plain dataclasses with every reference resolved (a placement holds its Prototype, a shape its
Shader), every path absolute and checked, every quirk already settled.  Lines point back into the
XML for messages that arise later (a bad OBJ file, a singular transform).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .transforms import Op, compose

# the largest magnitude of a 32-bit float, in which USD attributes (points, normals, sizes, colours,
# intensities) and the renderer (Embree's float32 instance matrices) hold a scene's values
FLOAT_MAX = float(np.finfo(np.float32).max)

Vec3 = tuple[float, float, float]


# ----------------------------------------------------------------------------- transforms
@dataclass(frozen=True)
class Transform:
    """One `<transform>`: operations in document order; `time` set for a motion sample."""

    ops: tuple[Op, ...]
    line: int
    time: Optional[float] = None

    def matrix(self) -> np.ndarray:
        return compose(self.ops)


@dataclass(frozen=True)
class Motion:
    """The transform of a shape or placement: one static sample (time None), or samples at
    increasing time codes.  No transform at all is the identity (an empty static sample)."""

    samples: tuple[Transform, ...] = ()

    @property
    def is_animated(self) -> bool:
        samples = self.samples                  # asked once per placement: no generator
        return len(samples) > 1 or (len(samples) == 1 and samples[0].time is not None)

    @property
    def times(self) -> tuple[float, ...]:
        return tuple(s.time for s in self.samples if s.time is not None)

    def matrices(self) -> list[np.ndarray]:
        return [s.matrix() for s in self.samples] or [np.eye(4)]


# ----------------------------------------------------------------------------- view and lights
@dataclass
class Camera:
    projection: str                       # 'perspective' | 'orthographic'
    position: Vec3
    gaze: Vec3                            # viewDir, or lookatPoint - position (not normalised)
    focal_length: float                   # course d
    image_plane_width: float              # course W
    line: int
    lookat: Optional[Vec3] = None
    lens_radius: float = 0.0              # rtc extension; 0 = pinhole
    focus_distance: Optional[float] = None
    shutter: Optional[tuple[float, float]] = None


@dataclass
class Light:
    kind: str                             # 'point' | 'area'
    position: Vec3                        # point position / area-light centre
    intensity: Vec3
    line: int
    normal: Optional[Vec3] = None         # area only
    width: Optional[float] = None
    length: Optional[float] = None


# ----------------------------------------------------------------------------- appearance
@dataclass
class Texture:
    name: str
    path: Path                            # absolute, exists
    line: int


@dataclass
class Shader:
    """A course shader.  `model` is the rtc:model token (usd-conventions.md); parameters that the
    model does not use are None."""

    name: str
    model: str
    line: int
    course_type: str
    diffuse: Optional[Vec3] = None
    specular: Optional[Vec3] = None
    phong_exp: Optional[float] = None
    mirror_coef: Optional[float] = None
    roughness: Optional[float] = None
    refractive_index: Optional[float] = None
    attenuation: Optional[Vec3] = None
    diffuse_texture: Optional[Texture] = None
    specular_texture: Optional[Texture] = None


# ----------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class Sphere:
    center: Vec3
    radius: float


@dataclass(frozen=True)
class Box:
    min: Vec3
    max: Vec3


@dataclass(frozen=True)
class Triangle:
    v0: Vec3
    v1: Vec3
    v2: Vec3


@dataclass(frozen=True)
class Cylinder:
    """Y-axis cylinder centred at `center`, spanning height/2 below and above."""

    center: Vec3
    radius: float
    height: float


@dataclass(frozen=True)
class MeshFile:
    path: Path                            # absolute, exists
    line: int                             # the <file> element


Geometry = Union[Sphere, Box, Triangle, Cylinder, MeshFile]


# ----------------------------------------------------------------------------- objects
@dataclass
class Prototype:
    """An `<instance>`: geometry loaded once, its default shader, and an optional transform that
    applies inside every placement (spec 8.4 / Q14)."""

    name: str
    geometry: Geometry
    shader: Shader
    line: int
    transform: Optional[Transform] = None


@dataclass
class Shape:
    """A plain shape, rendered where it is."""

    name: str
    geometry: Geometry
    shader: Shader
    motion: Motion
    line: int


@dataclass
class Placement:
    """A `<shape type="instance">`: a prototype under a transform, with an optional shader that
    overrides the prototype's."""

    name: str
    prototype: Prototype
    motion: Motion
    line: int
    shader: Optional[Shader] = None

    @property
    def effective_shader(self) -> Shader:
        return self.shader or self.prototype.shader


@dataclass
class Environment:
    faces: dict[str, Path]                # 'posX' ... 'negZ' -> existing PNG


@dataclass
class Scene:
    file: Path
    camera: Camera
    background: Vec3 = (0.0, 0.0, 0.0)
    environment: Optional[Environment] = None
    lights: list[Light] = field(default_factory=list)
    shapes: list[Shape] = field(default_factory=list)
    placements: list[Placement] = field(default_factory=list)

    @property
    def is_animated(self) -> bool:
        return any(o.motion.is_animated for o in (*self.shapes, *self.placements))

    def used_shaders(self) -> list[Shader]:
        """Every shader something renders with, each once, in first-use order."""
        seen: dict[int, Shader] = {}
        for obj in self.shapes:
            seen.setdefault(id(obj.shader), obj.shader)
        for p in self.placements:
            seen.setdefault(id(p.prototype.shader), p.prototype.shader)
            if p.shader is not None:
                seen.setdefault(id(p.shader), p.shader)
        return list(seen.values())

    def used_prototypes(self) -> list[Prototype]:
        seen: dict[int, Prototype] = {}
        for p in self.placements:
            seen.setdefault(id(p.prototype), p.prototype)
        return list(seen.values())
