"""Instance transforms at the edge of precision: extreme non-uniform scale, near-singular (condition
number 1e8), mirrored, and long chains of operations.

* Matrix inverse and normal matrix of the renderer (`vecmath.inverse_xform`, `cofactor_dir`) and of the
  compiler (`compiler.transforms.inverse`, `normal_matrix`) against exact rational arithmetic
  (`fractions.Fraction` on the float64 entries): relative error below 100 x cond x 2^-53.
* Images: each transform as an instance of a mesh prototype against the same mesh flattened to world
  space in float64 (points M p, normals M^-T n): mean |diff| < 1e-6, max < 1e-4 (measured max 3.5e-6).
"""
from fractions import Fraction

import numpy as np
import pytest

from rtc.compiler import transforms as T
from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.kernel.vecmath import cofactor_dir, inverse_xform

from tests.renderer.handmade import look_at, point_light, quad, scene
from tests.stability.stability_scenes import compare, uv_sphere

EPS = 2.0 ** -53


def rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def affine(lin, t=(0.0, 0.0, 0.0)):
    m = np.eye(4)
    m[:3, :3] = lin
    m[:3, 3] = t
    return m


def chain(n, seed=5):
    """n course operations (translate / rotateX/Y/Z / scale) composed by the compiler."""
    rng = np.random.default_rng(seed)
    ops = []
    for _ in range(n):
        k = rng.choice(T.OP_KINDS)
        if k == 'translate':
            ops.append(T.Op(k, tuple(rng.uniform(-2, 2, 3))))
        elif k == 'scale':
            ops.append(T.Op(k, tuple(rng.uniform(0.7, 1.4, 3))))
        else:
            ops.append(T.Op(k, float(rng.uniform(-180, 180))))
    return ops


def exact_compose(ops):
    m = [[Fraction(int(i == j)) for j in range(4)] for i in range(4)]
    for op in ops:
        b = [[Fraction(float(x)) for x in row] for row in op.matrix()]
        m = [[sum(m[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]
    return m


def exact_inverse3(a):
    """Exact inverse of the 3x3 part of float matrix a (Fractions)."""
    f = [[Fraction(float(a[i, j])) for j in range(3)] for i in range(3)]
    c = [[f[(i + 1) % 3][(j + 1) % 3] * f[(i + 2) % 3][(j + 2) % 3] - f[(i + 1) % 3][(j + 2) % 3] * f[(i + 2) % 3][(j + 1) % 3]
          for j in range(3)] for i in range(3)]
    det = sum(f[0][j] * c[0][j] for j in range(3))
    return [[c[j][i] / det for j in range(3)] for i in range(3)]                    # adj / det


RNG = np.random.default_rng(11)
R1, R2 = rotation(RNG), rotation(RNG)
CASES = {
    'uniform': affine(1.3 * R1, (0.3, 1.0, -0.2)),
    'extreme_scale': affine(R1 @ np.diag([1e4, 1e-4, 1.0]) @ R2, (0.0, 1.0, 0.0)),
    'cond_1e8': affine(R1 @ np.diag([1.0, 1e-4, 1e-8]) @ R2 * 1.5, (0.0, 1.0, 0.0)),
    'mirrored': affine(np.diag([-1.0, 1.0, 1.0]) @ R1 @ np.diag([1.2, 0.5, 0.9]), (0.0, 0.9, 0.0)),
    'chain_200': T.compose(chain(200)),
}


@pytest.mark.parametrize('name', list(CASES))
def test_inverse_and_normal_matrix_against_exact_arithmetic(name):
    m = CASES[name]
    cond = np.linalg.cond(m[:3, :3])
    inv = np.array([[float(x) for x in row] for row in exact_inverse3(m)])
    bound = 100 * cond * EPS                    # measured: up to ~30 cond eps (cond 1e8)
    # compiler algebra (4x4 adjugate)
    ci = T.inverse(m)[:3, :3] if not T.singular_mask(m) else None
    if ci is not None:
        assert np.linalg.norm(ci - inv) / np.linalg.norm(inv) < bound
        nm = T.normal_matrix(m)
        assert np.linalg.norm(nm - inv.T) / np.linalg.norm(inv) < bound
    # renderer kernels: inverse_xform maps world points/directions back to object space
    m34 = np.ascontiguousarray(m[:3, :])
    rng = np.random.default_rng(2)
    for _ in range(20):
        po = rng.normal(size=3)
        pw = m34[:, :3] @ po + m34[:, 3]
        got_p, got_v = inverse_xform(m34, tuple(pw), tuple(po))
        ref_v = inv @ po
        assert np.linalg.norm(np.array(got_v) - ref_v) / np.linalg.norm(ref_v) < bound
        assert np.linalg.norm(np.array(got_p) - po) <= bound * (np.linalg.norm(inv, 2) * np.linalg.norm(pw) + 1)
        # normals: cof(L) n = det(L) L^-T n, sign-corrected to det > 0, so parallel to L^-T n
        n = np.array(cofactor_dir(m34, tuple(po)))
        ref_n = inv.T @ po
        cos = n @ ref_n / np.linalg.norm(n) / np.linalg.norm(ref_n)
        assert 1 - cos < bound


def test_long_chain_composition_error():
    ops = chain(200)
    exact = np.array([[float(x) for x in row] for row in exact_compose(ops)])
    got = T.compose(ops)
    assert np.max(np.abs(got - exact)) / np.max(np.abs(exact)) < 200 * 8 * EPS


def _mesh_under(lin, path, material=1):
    """The UV sphere with its points mapped by the 3x3 `lin` and normals by lin^-T (float64)."""
    m = uv_sphere(24, 12, 1.0, material=material, path=path)
    m.points = m.points @ lin.T
    n = m.normals.astype(np.float64) @ np.linalg.inv(lin)
    m.normals = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)
    if np.linalg.det(lin) < 0:                       # keep counter-clockwise-from-outside winding
        m.triangles = m.triangles[:, ::-1].copy()
        m.normals = m.normals[:, ::-1].copy()
    return m


def instanced_and_flat(m, proto_lin):
    """Scene A: prototype = sphere under `proto_lin`, placed with `m`; scene B: the sphere under
    m[:3,:3] @ proto_lin + m[:3, 3] computed in float64 and stored as world-space geometry."""
    lam = D.Material('/l', model=D.LAMBERTIAN, diffuse=(0.6, 0.6, 0.6))
    red = D.Material('/r', model=D.BLINN_PHONG, diffuse=(0.7, 0.2, 0.1), specular=(0.3, 0.3, 0.3), exponent=20)
    floor = quad(30.0, y=-1.5, material=0, path='/floor')
    cam = D.Camera('/cam', matrix=look_at((0.5, 3.0, 7.0), (0, 0.5, 0)), focal_length=1.0, horizontal_aperture=1.0,
                   vertical_aperture=0.75)
    lights = [point_light((3, 6, 4), (60, 60, 60))]
    inst = D.Instances(container=np.array([0, 1], np.int32), matrices=np.stack([np.eye(4), m])[:, None],
                       material_set=np.zeros(2, np.int32), material_sets=[()])
    a = scene([D.Container('/', meshes=[floor]), D.Container('/p', meshes=[_mesh_under(proto_lin, '/p/s')])],
              [lam, red], lights, cam, instances=inst, width=64, height=48)
    # flattened: points M p + t; corner normals M^-T n with one common scale and *no* per-corner
    # normalisation, so that interpolating them and normalising equals the instanced route
    # (normalise(M^-T sum w_i n_i)); per-corner unit normals would weight the corners differently
    flat = _mesh_under(proto_lin, '/flat')
    lin = m[:3, :3]
    flat.points = flat.points @ lin.T + m[:3, 3]
    n = flat.normals.astype(np.float64) @ np.linalg.inv(lin)
    flat.normals = (n / np.abs(n).max()).astype(np.float32)
    if np.linalg.det(lin) < 0:
        flat.triangles = flat.triangles[:, ::-1].copy()
        flat.normals = flat.normals[:, ::-1].copy()
    b = scene([D.Container('/', meshes=[floor, flat])], [lam, red], lights, cam, width=64, height=48)
    return a, b


SHAPE = np.diag([1.2, 0.7, 0.9])
# placement matrix and the prototype's own linear map; world shape = m @ proto (a normal ellipsoid),
# so that the flattened float64 -> float32 mesh is an exact enough comparison
IMAGE_CASES = {
    'uniform': (CASES['uniform'], np.eye(3)),
    'extreme_scale': (affine(R1 @ np.diag([1e4, 1e-4, 1.0]), (0.0, 0.6, 0.0)), np.diag([1e-4, 1e4, 1.0]) @ SHAPE),
    'cond_1e8': (affine(R1 @ np.diag([1.0, 1e-4, 1e-8]), (0.0, 0.6, 0.0)), np.diag([1.0, 1e4, 1e8]) @ SHAPE),
    'mirrored': (CASES['mirrored'], np.eye(3)),
    'chain_200': (affine(CASES['chain_200'][:3, :3], (0.0, 0.5, 0.0)),
                  np.linalg.inv(CASES['chain_200'][:3, :3]) @ SHAPE),
}


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('name', list(IMAGE_CASES))
def test_instanced_equals_flattened(name, integrator):
    m, proto_lin = IMAGE_CASES[name]
    a, b = instanced_and_flat(m, proto_lin)
    opts = RenderOptions(spp=8, sampler='sobol', seed=2, integrator=integrator)
    ia, ib = render(a, opts).image, render(b, opts).image
    assert np.all(np.isfinite(ia)) and np.all(np.isfinite(ib))
    mean_diff, frac = compare(ia, ib)
    assert mean_diff < 1e-6 and np.abs(ia - ib).max() < 1e-4, (mean_diff, np.abs(ia - ib).max())  # measured <= 3.5e-6
    # the instance is actually visible and lit (not a vacuous comparison)
    empty = render(scene(a.containers[:1], a.materials, a.lights, a.camera, width=64, height=48), opts).image
    assert (np.abs(ia - empty).max(axis=2) > 0.05).mean() > 0.01
