"""Wavefront OBJ loader, vectorised with numpy.

Reads `v`, `vt`, `vn` and `f` (polygons of any size, corners `v`, `v/vt`, `v/vt/vn` or `v//vn`,
negative = relative indices); everything else (groups, smoothing groups, materials, comments) is
ignored because the scene's shader applies.  Polygons are triangulated as fans around their first
corner, in file order, and vertices are neither merged nor reordered, so indices stay those of the
file.  (trimesh was measured as an alternative: it merges/reorders vertices and is slower on the
course meshes; see benchmarks/RESULTS.md, "Compiler".)
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from .scene import FLOAT_MAX


class ObjError(Exception):
    """The file cannot be used; `line` is the 1-based OBJ line (None for the whole file)."""

    def __init__(self, message: str, line: Optional[int] = None):
        super().__init__(message)
        self.message, self.line = message, line


@dataclass
class ObjMesh:
    points: np.ndarray                    # float64 (n, 3)
    triangles: np.ndarray                 # int32 (m, 3) indices into points, counter-clockwise as in the file
    normals: Optional[np.ndarray] = None  # float32 (k, 3) `vn` values
    normal_indices: Optional[np.ndarray] = None   # int32 (m, 3) per corner
    uvs: Optional[np.ndarray] = None      # float32 (k, 2) `vt` values (u, v)
    uv_indices: Optional[np.ndarray] = None       # int32 (m, 3) per corner
    polygons: int = 0                     # faces in the file before triangulation
    warnings: list[tuple[int, str]] = field(default_factory=list)   # (OBJ line, message)
    _bounds: Optional[tuple[np.ndarray, np.ndarray]] = field(default=None, repr=False, compare=False)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Box around the vertices that faces use (computed once)."""
        if self._bounds is None:
            used = np.zeros(len(self.points), bool)
            used[self.triangles.ravel()] = True
            pts = self.points[used] if used.any() else self.points
            self._bounds = (pts.min(axis=0), pts.max(axis=0))
        return self._bounds


_LINES = {key: re.compile(rb"^" + key + rb"[ \t]+([^\n]*)", re.M) for key in (b"v", b"vt", b"vn", b"f")}
_ANY_LINE = re.compile(rb"^(v|vt|vn|f)[ \t]+([^\n]*)", re.M)


def load_obj(path: Path) -> ObjMesh:
    """Parse an OBJ file.  Raises OSError if unreadable, ObjError if malformed."""
    data = path.read_bytes()
    bodies: dict[str, list[bytes]] = {"v": [], "vt": [], "vn": [], "f": []}
    append = {key.encode(): items.append for key, items in bodies.items()}
    for key, body in _ANY_LINE.findall(data):
        append[key](body)
    if not bodies["f"]:
        raise ObjError("no faces ('f' lines) in the file")
    lines = _LineFinder(data)
    points = _table(bodies["v"], 3, "v", lines)
    uvs = _table(bodies["vt"], 2, "vt", lines) if bodies["vt"] else None
    normals = _table(bodies["vn"], 3, "vn", lines) if bodies["vn"] else None
    corners, counts = _face_corners(bodies["f"], lines)
    mesh = ObjMesh(points, np.empty((0, 3), np.int32), polygons=len(counts))
    fans = _fan_corners(counts)
    defined = {"v": len(points), "vt": 0 if uvs is None else len(uvs), "vn": 0 if normals is None else len(normals)}

    def resolve(column: int, key: str, kind: str) -> np.ndarray:
        raw = corners[:, column]
        idx = raw - 1
        negative = raw < 0
        if negative.any():                     # relative to the entries defined before the face
            before = np.repeat(lines.count_before(key, "f"), counts)
            idx = np.where(negative, raw + before, idx)
        bad = (idx < 0) | (idx >= defined[key]) | (raw == 0)
        if bad.any():
            corner = int(np.argmax(bad))
            face = int(np.searchsorted(np.cumsum(counts), corner, side="right"))
            raise ObjError(f"face refers to {kind} {int(raw[corner])}, but the file defines "
                           f"{defined[key]} such entries", lines.line_of("f", face))
        return idx.astype(np.int32)[fans]

    mesh.triangles = resolve(0, "v", "vertex")
    for column, key, kind, values in ((1, "vt", "texture coordinate", uvs), (2, "vn", "normal", normals)):
        present = corners[:, column] != 0
        if not present.any():
            continue
        if not present.all():
            mesh.warnings.append((lines.line_of("f", 0), f"only some face corners have a {kind}; all "
                                  f"{kind}s are ignored"))
            continue
        indices = resolve(column, key, kind)
        if column == 1:
            mesh.uvs, mesh.uv_indices = values.astype(np.float32), indices
        else:
            mesh.normals, mesh.normal_indices = values.astype(np.float32), indices
    return mesh


class _LineFinder:
    """Line numbers, computed only when a message or a relative index needs them."""

    def __init__(self, data: bytes):
        self.data = data

    def _starts(self, key: str) -> np.ndarray:
        return np.array([m.start() for m in _LINES[key.encode()].finditer(self.data)], dtype=np.int64)

    def line_of(self, key: str, ordinal: int) -> int:
        """1-based line of the ordinal-th `key` line."""
        return self.data.count(b"\n", 0, int(self._starts(key)[ordinal])) + 1

    def count_before(self, key: str, at_key: str) -> np.ndarray:
        """For each `at_key` line, how many `key` lines precede it."""
        return np.searchsorted(self._starts(key), self._starts(at_key))


def _table(bodies: list[bytes], width: int, key: str, lines: _LineFinder) -> np.ndarray:
    """The first `width` numbers of each `key` line, as float64 (n, width)."""
    joined = b" ".join(bodies)
    try:
        values = np.array(joined.split(), dtype=np.float64)
        if values.size != width * len(bodies):
            raise ValueError
        values = values.reshape(-1, width)
    except ValueError:                          # extra components (v x y z w) or a bad line
        rows = [b.split() for b in bodies]
        for i, row in enumerate(rows):
            if len(row) < width or not _all_floats(row[:width]):
                raise ObjError(f"'{key}' needs {width} numbers", lines.line_of(key, i)) from None
        values = np.array([r[:width] for r in rows], dtype=np.float64)
    finite = np.isfinite(values).all(axis=1)
    if not finite.all():
        raise ObjError(f"'{key}' has a NaN or infinite value", lines.line_of(key, int(np.argmin(finite))))
    within = (np.abs(values) <= FLOAT_MAX).all(axis=1)
    if not within.all():
        raise ObjError(f"'{key}' has a value beyond the 32-bit float range (magnitude at most {FLOAT_MAX:.7g}) "
                       "in which USD and the renderer hold it", lines.line_of(key, int(np.argmin(within))))
    return values


def _all_floats(tokens: list[bytes]) -> bool:
    try:
        [float(t) for t in tokens]
    except ValueError:
        return False
    return True


def _face_corners(bodies: list[bytes], lines: _LineFinder) -> tuple[np.ndarray, np.ndarray]:
    """Per corner (v, vt, vn) as written (0 = absent), and the corner count of each face."""
    counts = np.fromiter(map(len, map(bytes.split, bodies)), dtype=np.int64, count=len(bodies))
    if (counts < 3).any():
        raise ObjError("a face needs at least 3 corners", lines.line_of("f", int(np.argmax(counts < 3))))
    joined = b" ".join(bodies)
    total = int(counts.sum())
    slashes = joined.count(b"/")
    try:
        per = joined.split(maxsplit=1)[0].count(b"/")
        if slashes == per * total and per <= 2:   # one corner format throughout: vectorised
            table = _integers(joined.replace(b"//", b"/0/").replace(b"/", b" "), total * (per + 1))
            return np.pad(table.reshape(total, per + 1), ((0, 0), (0, 2 - per))), counts
        return np.array([_corner(t) for b in bodies for t in b.split()], dtype=np.int64), counts
    except ValueError:
        bad = next(i for i, b in enumerate(bodies) if not _corners_ok(b.split()))
        raise ObjError("a face corner is not of the form v, v/vt, v/vt/vn or v//vn",
                       lines.line_of("f", bad)) from None


def _integers(text: bytes, expected: int) -> np.ndarray:
    """Whitespace-separated integers, parsed in C; ValueError unless exactly `expected` of them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)   # numpy's notice on unparsable text
        values = np.fromstring(text, dtype=np.int64, sep=" ")
    if values.size != expected:
        raise ValueError("not all integers")
    return values


def _corner(token: bytes) -> tuple[int, int, int]:
    parts = token.split(b"/")
    if len(parts) > 3 or not parts[0]:
        raise ValueError(token)
    parts += [b""] * (3 - len(parts))
    return tuple(int(p) if p else 0 for p in parts)


def _corners_ok(tokens: list[bytes]) -> bool:
    try:
        [_corner(t) for t in tokens]
    except ValueError:
        return False
    return True


def _fan_corners(counts: np.ndarray) -> np.ndarray:
    """(T, 3) corner indices of the fan triangulation (0, i, i+1) of every polygon."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    per_face = counts - 2
    face = np.repeat(np.arange(len(counts)), per_face)
    first_tri = np.concatenate([[0], np.cumsum(per_face)[:-1]])
    i = np.arange(int(per_face.sum())) - first_tri[face] + 1
    s = starts[face]
    return np.stack([s, s + i, s + i + 1], axis=1)
