"""Rect lights sampled uniformly in the solid angle they subtend (the spherical rectangle of Urena,
Fajardo and King 2013, `light_sampling.spherical_rect`): its solid angle against an independent
formula (Van Oosterom and Strackee's, for the two triangles of the rectangle), its directions uniform
in that solid angle (integrals of two functions against closed forms and against area sampling), its
points on the rectangle, and the hard cases: a shading point almost in the light's plane, at a corner's
normal, far away, behind the light."""
import math

import numpy as np
import pytest

from rtc.renderer.kernel.light_sampling import SPHERICAL_MAX, SPHERICAL_MIN, spherical_rect, spherical_rect_point

EX, EY, NRM = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)       # emits along -Y (along -nrm)
C, W, H = (0.2, 2.0, -0.1), 1.5, 0.8


def _corners(c=C, w=W, h=H):
    c = np.asarray(c)
    ex, ey = np.asarray(EX), np.asarray(EY)
    return [c + sx * 0.5 * w * ex + sy * 0.5 * h * ey for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def _triangle_solid_angle(p, a, b, c):
    a, b, c = a - p, b - p, c - p
    la, lb, lc = np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(c)
    num = abs(np.dot(a, np.cross(b, c)))
    den = la * lb * lc + np.dot(a, b) * lc + np.dot(a, c) * lb + np.dot(b, c) * la
    return 2.0 * math.atan2(num, den)


def _rect_solid_angle(p, **kw):
    q = _corners(**kw)
    return _triangle_solid_angle(p, q[0], q[1], q[2]) + _triangle_solid_angle(p, q[0], q[2], q[3])


def _projected_solid_angle(p, n):
    """Lambert's formula: the integral of max(0, n . w) over the rectangle's solid angle seen from p
    (the rectangle wholly above p's tangent plane)."""
    v = [(q - p) / np.linalg.norm(q - p) for q in _corners()]
    total = 0.0
    for i in range(4):
        a, b = v[i], v[(i + 1) % 4]
        g = math.acos(np.clip(np.dot(a, b), -1.0, 1.0))
        u = np.cross(a, b)
        total += g * np.dot(n, u / np.linalg.norm(u))
    return abs(total) / 2.0


def _directions(p, u):
    sr = spherical_rect(tuple(p), C, EX, EY, NRM, W, H)
    out = np.empty((len(u), 3))
    for i, (u1, u2) in enumerate(u):
        x, y = spherical_rect_point(sr, W, H, u1, u2)
        out[i] = x * np.asarray(EX) + y * np.asarray(EY) - sr[3] * np.asarray(NRM)     # frame z = -nrm
    return sr, out


POINTS = [(0.0, 0.0, 0.0), (0.5, 1.7, 0.3), (-3.0, 0.5, 2.0), (0.95, 1.99, 0.3), (0.2, -10.0, -0.1)]


@pytest.mark.parametrize('p', POINTS)
def test_solid_angle_matches_van_oosterom_strackee(p):
    S = spherical_rect(p, C, EX, EY, NRM, W, H)[0]
    assert S == pytest.approx(_rect_solid_angle(np.asarray(p)), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize('p', POINTS[:4])
def test_directions_are_uniform_in_the_solid_angle(p):
    p = np.asarray(p)
    rng = np.random.default_rng(3)
    u = rng.random((40000, 2))
    sr, v = _directions(p, u)
    S = sr[0]
    q = p + v
    # every point lies on the rectangle, in its plane
    rel = q - (np.asarray(C) - 0.5 * W * np.asarray(EX) - 0.5 * H * np.asarray(EY))
    assert np.all(rel[:, 0] >= -1e-9) and np.all(rel[:, 0] <= W + 1e-9)
    assert np.all(rel[:, 2] >= -1e-9) and np.all(rel[:, 2] <= H + 1e-9)
    assert np.allclose(rel[:, 1], 0.0, atol=1e-9)
    w = v / np.linalg.norm(v, axis=1)[:, None]
    # the integral of cos about the upward normal: Lambert's closed form
    n = np.array([0.0, 1.0, 0.0])
    est = S * np.maximum(w @ n, 0.0)
    assert est.mean() == pytest.approx(_projected_solid_angle(p, n), rel=4 * est.std() / math.sqrt(len(est)) / est.mean())
    # the integral of (w . a)^2 for a tilted axis: against area sampling with pdf d^2 / (cos A)
    a = np.array([0.6, 0.0, 0.8])
    est = S * (w @ a) ** 2
    rel_a = rng.random((400000, 2))
    qa = _corners()[0] + rel_a[:, :1] * W * np.asarray(EX) + rel_a[:, 1:] * H * np.asarray(EY)
    va = qa - p
    da = np.linalg.norm(va, axis=1)
    wa = va / da[:, None]
    ref = (wa @ a) ** 2 * (wa @ np.array([0.0, 1.0, 0.0])) * W * H / da ** 2
    tol = 4 * math.hypot(est.std() / math.sqrt(len(est)), ref.std() / math.sqrt(len(ref)))
    assert est.mean() == pytest.approx(ref.mean(), abs=tol)


def test_lower_variance_than_area_sampling_near_the_light():
    p = np.array([0.5, 1.7, 0.3])                         # 0.3 below the light
    rng = np.random.default_rng(5)
    u = rng.random((20000, 2))
    sr, v = _directions(p, u)
    w = v / np.linalg.norm(v, axis=1)[:, None]
    spherical = sr[0] * w[:, 1]
    qa = _corners()[0] + u[:, :1] * W * np.asarray(EX) + u[:, 1:] * H * np.asarray(EY)
    va = qa - p
    da = np.linalg.norm(va, axis=1)
    area = (va[:, 1] / da) ** 2 * W * H / da ** 2
    assert spherical.mean() == pytest.approx(area.mean(), rel=0.02)
    assert spherical.var() < 0.2 * area.var()


@pytest.mark.parametrize('p', [(0.2, 2.0 - 1e-9, -0.1), (0.2 + 0.75, 2.0 - 1e-7, -0.1 + 0.4), (5.0, 2.0 - 1e-12, 0.0),
                               (0.2, -3e4, -0.1), (0.2, 2.5, 0.0), (0.2, 2.0, -0.1)])
def test_hard_cases_give_finite_points_or_fall_back(p):
    """In the plane or just below it (S near 2 pi or 0), far away (S below SPHERICAL_MIN, where the
    renderer samples by area), behind the light (S = 0): never a NaN, every point on the rectangle."""
    sr = spherical_rect(p, C, EX, EY, NRM, W, H)
    S = sr[0]
    assert math.isfinite(S) and 0.0 <= S <= 2 * math.pi + 1e-12
    if p[1] >= 2.0:
        assert S == 0.0
        return
    if not SPHERICAL_MIN <= S <= SPHERICAL_MAX:
        return
    for u1 in (0.0, 1e-12, 0.5, 1 - 1e-12, 0.99999994):
        for u2 in (0.0, 0.5, 0.99999994):
            x, y = spherical_rect_point(sr, W, H, u1, u2)
            assert math.isfinite(x) and math.isfinite(y)
            assert sr[1] - 1e-9 <= x <= sr[1] + W + 1e-9 and sr[2] - 1e-9 <= y <= sr[2] + H + 1e-9
