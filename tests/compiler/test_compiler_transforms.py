"""The 4x4 affine algebra against the course's worked numbers and independent float64 references."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rtc.compiler.transforms import (Op, adjugate_and_determinant, compose, compose_many, conditioning_problem,
                                 inverse, normal_matrix, rotation, scaling, translation)


def test_rotate_y_then_translate_worked_example():
    m = compose([Op("translate", (3, 0.5, 0)), Op("rotateY", 50.0)])
    c, s = math.cos(math.radians(50)), math.sin(math.radians(50))
    np.testing.assert_allclose(m, [[c, 0, s, 3], [0, 1, 0, 0.5], [-s, 0, c, 0], [0, 0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(m[0], [0.642788, 0, 0.766044, 3], atol=1e-6)
    np.testing.assert_allclose(m[2], [-0.766044, 0, 0.642788, 0], atol=1e-6)


def test_ellipsoid_instance_inverse_maps_the_ray():
    m = np.array([[0.5, 0, 0, 0], [0, 1.5, 0, 1.5], [0, 0, 1, -4], [0, 0, 0, 1]])
    inv = inverse(m)
    np.testing.assert_allclose(inv, [[2, 0, 0, 0], [0, 2 / 3, 0, -1], [0, 0, 1, 4], [0, 0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(inv @ [0, 1.5, 0, 1], [0, 0, 4, 1], atol=1e-15)
    np.testing.assert_allclose(inv @ [0, 0.192, -0.5, 0], [0, 0.128, -0.5, 0], atol=1e-15)


def test_document_order_applies_the_last_operation_first():
    # translate 3 0.5 0; rotate Z -58.3; scale 1.618 0.618 1; rotate Z 31.7
    ops = [Op("translate", (3, 0.5, 0)), Op("rotateZ", -58.3), Op("scale", (1.618, 0.618, 1)),
           Op("rotateZ", 31.7)]
    p = np.array([1.0, 0.0, 0.0, 1.0])
    expected = p
    for op in reversed(ops):                    # rotation, then scale, then rotation, then translation
        expected = op.matrix() @ expected
    np.testing.assert_allclose(compose(ops) @ p, expected, rtol=1e-15)
    r = math.radians(31.7)
    step1 = np.array([math.cos(r), math.sin(r), 0])
    step2 = step1 * [1.618, 0.618, 1]
    r2 = math.radians(-58.3)
    step3 = np.array([math.cos(r2) * step2[0] - math.sin(r2) * step2[1],
                      math.sin(r2) * step2[0] + math.cos(r2) * step2[1], 0])
    np.testing.assert_allclose((compose(ops) @ p)[:3], step3 + [3, 0.5, 0], rtol=1e-12)


@pytest.mark.parametrize("axis, v, expected", [
    ("X", (0, 1, 0), (0, 0, 1)), ("Y", (0, 0, 1), (1, 0, 0)), ("Z", (1, 0, 0), (0, 1, 0))])
def test_rotations_are_right_handed(axis, v, expected):
    np.testing.assert_allclose(rotation(axis, 90)[:3, :3] @ v, expected, atol=1e-15)


finite = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.lists(finite, min_size=12, max_size=12))
def test_cofactor_inverse_matches_an_independent_reference(values):
    m = np.eye(4)
    m[:3, :] = np.reshape(values, (3, 4))
    if conditioning_problem(m) or np.linalg.cond(m) > 1e8:
        return
    reference = np.linalg.inv(m)                 # independent float64 reference (LU), not the implementation
    np.testing.assert_allclose(inverse(m), reference, rtol=1e-7, atol=1e-9 * np.abs(reference).max())
    adj, det = adjugate_and_determinant(m)
    assert det == pytest.approx(np.linalg.det(m), rel=1e-9, abs=1e-12)


def test_inverse_is_not_a_transpose_for_scales():
    m = compose([Op("translate", (1, 2, 3)), Op("scale", (2, 4, 8))])
    np.testing.assert_allclose(inverse(m) @ m, np.eye(4), atol=1e-15)
    assert not np.allclose(inverse(m)[:3, :3], m[:3, :3].T)


def test_normal_matrix_keeps_normals_perpendicular():
    m = compose([Op("rotateX", 30.0), Op("scale", (1, 3, 0.5))])
    tangent = np.array([1.0, -1.0, 0.0])
    normal = np.array([1.0, 1.0, 0.0])
    t_world = m[:3, :3] @ tangent
    n_world = normal_matrix(m) @ normal
    assert abs(np.dot(t_world, n_world)) < 1e-12
    np.testing.assert_allclose(normal_matrix(scaling((1, 2, 4))), np.diag([1, 0.5, 0.25]), atol=1e-15)


def test_singular_and_non_finite_are_detected():
    assert "singular" in conditioning_problem(scaling((1, 0, 1)))
    assert "singular" in conditioning_problem(compose([Op("scale", (1, 1, 1e-300)), Op("scale", (1, 1, 1e-300))]))
    with np.errstate(over="ignore"):
        huge = scaling((1e200, 1, 1)) @ scaling((1e200, 1, 1))
    assert "not finite" in conditioning_problem(huge)
    assert conditioning_problem(scaling((1e-4, 1e4, 1))) is None
    with pytest.raises(ValueError):
        inverse(translation((1, 2, 3)) @ scaling((0, 1, 1)))


def test_batched_composition_equals_one_at_a_time():
    rng = np.random.default_rng(7)
    lists = []
    for i in range(300):
        kinds = ["translate", "rotateY", "scale", "rotateX"][: 1 + i % 4]
        lists.append([Op(k, float(rng.uniform(-180, 180)) if k.startswith("rotate")
                         else tuple(rng.uniform(0.1, 3, 3))) for k in kinds])
    batch = compose_many(lists)
    for m, ops in zip(batch, lists):
        np.testing.assert_array_max_ulp(m, compose(ops), maxulp=4)
