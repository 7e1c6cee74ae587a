"""The course's 4x4 affine algebra, in float64, for column vectors (``p' = M @ [x, y, z, 1]``).

A course ``<transform>`` lists operations; **document order is the left-to-right matrix product**
``M = M1 M2 ... Mn``, so the last listed operation applies to the object first (spec section 9),
which is also USD's ``xformOpOrder`` convention.  Rotations are in degrees, right-handed, about the
X, Y or Z axis.

The inverse is computed the way the course teaches it: the adjugate (transposed cofactor matrix)
divided by the determinant, each cofactor a signed 3x3 minor, vectorised over any leading batch
dimensions.  The normal matrix is ``(M^-1)^T`` restricted to the linear part.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

#: A matrix is treated as singular when |det A| <= SINGULAR_RTOL * |a1| |a2| |a3| (A = linear part,
#: a_i its columns): the volume of the image of the unit cube relative to the largest it could be
#: for those column lengths.  1e-12 flags exact and numerically-exact degeneracy (a zero scale, two
#: parallel axes) while accepting any honest non-uniform scale (1e-4 x 1e4 gives 1e0 relative).
SINGULAR_RTOL = 1e-12

OP_KINDS = ("translate", "rotateX", "rotateY", "rotateZ", "scale")


@dataclass(frozen=True)
class Op:
    """One transform operation: ``kind`` in OP_KINDS; ``value`` a 3-tuple (translate, scale) or the
    angle in degrees (rotations)."""

    kind: str
    value: tuple[float, float, float] | float

    def matrix(self) -> np.ndarray:
        if self.kind == "translate":
            return translation(self.value)
        if self.kind == "scale":
            return scaling(self.value)
        return rotation(self.kind[-1], self.value)


def translation(t: Sequence[float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


def scaling(s: Sequence[float]) -> np.ndarray:
    return np.diag([float(s[0]), float(s[1]), float(s[2]), 1.0])


def rotation(axis: str, degrees: float) -> np.ndarray:
    """Right-handed rotation about a coordinate axis ('X', 'Y' or 'Z')."""
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]
    m = np.eye(4)
    m[i, i] = c
    m[j, j] = c
    m[j, i] = s
    m[i, j] = -s
    return m


def compose(ops: Iterable[Op]) -> np.ndarray:
    """M = M1 M2 ... Mn for the operations in document order."""
    m = np.eye(4)
    for op in ops:
        m = m @ op.matrix()
    return m


def _det3(m: np.ndarray, rows: Sequence[int], cols: Sequence[int]) -> np.ndarray:
    """Determinant of the 3x3 submatrix (rows x cols) of a batch of matrices (rule of Sarrus)."""
    (a, b, c), (d, e, f), (g, h, i) = ([m[..., r, k] for k in cols] for r in rows)
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def adjugate_and_determinant(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Adjugate (transposed cofactor matrix) and determinant of 4x4 matrices, shape (..., 4, 4).

    Cofactor C_ij = (-1)^(i+j) * (3x3 minor without row i and column j); det = row 0 . C_0."""
    m = np.asarray(m, dtype=np.float64)
    cof = np.empty_like(m)
    for i in range(4):
        rows = [r for r in range(4) if r != i]
        for j in range(4):
            minor = _det3(m, rows, [c for c in range(4) if c != j])
            cof[..., i, j] = minor if (i + j) % 2 == 0 else -minor
    det = np.einsum("...j,...j->...", m[..., 0, :], cof[..., 0, :])
    return np.swapaxes(cof, -1, -2), det


def determinant(m: np.ndarray) -> np.ndarray:
    return adjugate_and_determinant(m)[1]


def inverse(m: np.ndarray) -> np.ndarray:
    """M^-1 = adj(M) / det(M) for one matrix or a batch.  Raises ValueError if any is singular or
    not finite."""
    m = np.asarray(m, dtype=np.float64)
    if not np.all(np.isfinite(m)) or np.any(singular_mask(m)):
        raise ValueError("cannot invert a singular or non-finite transform")
    adj, det = adjugate_and_determinant(m)
    return adj / det[..., None, None]


def normal_matrix(m: np.ndarray) -> np.ndarray:
    """The 3x3 matrix that maps surface normals: ``(M^-1)^T`` of the linear part."""
    return np.swapaxes(inverse(m), -1, -2)[..., :3, :3]


def singular_mask(m: np.ndarray) -> np.ndarray:
    """Boolean mask over a batch (..., 4, 4): True where the linear part is (numerically) singular."""
    m = np.asarray(m, dtype=np.float64)
    det = determinant(m)                          # = det of the linear part for an affine matrix
    bound = np.prod(np.linalg.norm(m[..., :3, :3], axis=-2), axis=-1)
    return ~(np.abs(det) > SINGULAR_RTOL * bound)


def conditioning_problem(m: np.ndarray) -> str | None:
    """Why a single affine matrix cannot be used as a transform, or None if it can."""
    m = np.asarray(m, dtype=np.float64)
    if not np.all(np.isfinite(m)):
        return "the transform is not finite (overflow to inf or NaN)"
    if bool(singular_mask(m)):
        return "the transform is singular (a zero scale or collapsed axes): it has no inverse"
    return None


def compose_many(op_lists: Sequence[Sequence[Op]]) -> np.ndarray:
    """``compose`` for many operation lists at once, shape (N, 4, 4).

    Lists with the same sequence of operation kinds (all placements of a generated scene, say) are
    composed together with batched matrix products, so 10^5 placements cost milliseconds."""
    out = np.empty((len(op_lists), 4, 4))
    groups: dict[tuple[str, ...], list[int]] = {}
    for i, ops in enumerate(op_lists):
        groups.setdefault(tuple([op.kind for op in ops]), []).append(i)
    for kinds, members in groups.items():
        lists = [op_lists[i] for i in members]
        m = np.broadcast_to(np.eye(4), (len(members), 4, 4))
        for k, kind in enumerate(kinds):
            values = np.array([ops[k].value for ops in lists], dtype=np.float64)
            m = m @ _batch_matrices(kind, values)
        out[members] = m
    return out


def _batch_matrices(kind: str, values: np.ndarray) -> np.ndarray:
    n = len(values)
    m = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    if kind == "translate":
        m[:, :3, 3] = values
    elif kind == "scale":
        m[:, 0, 0], m[:, 1, 1], m[:, 2, 2] = values.T
    else:
        a = np.radians(values)
        c, s = np.cos(a), np.sin(a)
        i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[kind[-1]]
        m[:, i, i] = c
        m[:, j, j] = c
        m[:, j, i] = s
        m[:, i, j] = -s
    return m
