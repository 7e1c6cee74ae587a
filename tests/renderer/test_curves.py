"""UsdGeom.BasisCurves: read into Bezier segments (every basis and wrap), intersected as Embree's round curves, shaded
on the exact tube (`kernel/curves.py`); closed forms for the silhouette and the shading, independent evaluations of
each basis."""
import math
import warnings

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, Vt

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.kernel.records import Hit
from rtc.renderer.kernel.shapes import corner_color
from rtc.renderer.usd.geometry import GeometryError, convert_gprim
from rtc.renderer.usd.stage import read_stage

from tests.renderer.handmade import look_at, scene, translate
from tests.renderer.test_integrator import _hit_normals as _hits      # (surface() at Embree's hit, ray by ray)

BLACK = D.Material('/black', model=D.LAMBERTIAN, diffuse=(0.0, 0.0, 0.0))
GREY = D.Material('/grey', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))
T0 = Usd.TimeCode.Default()
_STAGES = []


# --------------------------------------------------------------------------- reading
def _curves(kind='cubic', basis='bezier', wrap='nonperiodic', counts=(4,), points=None, widths=None,
            interpolation=None, colors=None, color_interpolation=None):
    stage = Usd.Stage.CreateInMemory()
    c = UsdGeom.BasisCurves.Define(stage, '/c')
    c.CreateTypeAttr(kind)
    c.CreateBasisAttr(basis)
    c.CreateWrapAttr(wrap)
    c.CreateCurveVertexCountsAttr(list(counts))
    if points is None:
        rng = np.random.default_rng(len(counts) * 7 + sum(counts))
        points = rng.uniform(-1, 1, size=(sum(counts), 3))
    c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in points]))
    if widths is not None:
        c.CreateWidthsAttr(list(map(float, widths)))
        if interpolation:
            c.SetWidthsInterpolation(interpolation)
    if colors is not None:
        pv = c.CreateDisplayColorPrimvar(color_interpolation or UsdGeom.Tokens.constant)
        pv.Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, x)) for x in colors]))
    _STAGES.append(stage)                                # (a prim lives as long as its stage)
    return stage.GetPrimAtPath('/c'), np.asarray(points, np.float32).astype(np.float64)     # (as USD holds them)


def _read(prim, m=None):
    warnings = []
    records = convert_gprim(prim, np.eye(4) if m is None else m, T0, warnings.append)
    assert len(records) == 1
    return records[0], warnings


def _bezier(rows, u):
    """Independent evaluation of Bezier rows (k, 4, c) at parameters u (n,): (k, n, c)."""
    s = 1.0 - u
    w = np.stack([s ** 3, 3 * s * s * u, 3 * s * u * u, u ** 3], axis=1)        # (n, 4)
    return np.einsum('nj,kjc->knc', w, rows)


def _bspline(g, u):
    s = 1.0 - u
    w = np.stack([s ** 3, 3 * u ** 3 - 6 * u ** 2 + 4, -3 * u ** 3 + 3 * u ** 2 + 3 * u + 1, u ** 3], axis=1) / 6.0
    return w @ g


def _catmull_rom(g, u):
    w = 0.5 * np.stack([-u + 2 * u ** 2 - u ** 3, 2 - 5 * u ** 2 + 3 * u ** 3, u + 4 * u ** 2 - 3 * u ** 3,
                        -u ** 2 + u ** 3], axis=1)
    return w @ g


U = np.linspace(0.0, 1.0, 11)


@pytest.mark.parametrize('basis, evaluate', [('bspline', _bspline), ('catmullRom', _catmull_rom)])
@pytest.mark.parametrize('wrap', ['nonperiodic', 'periodic', 'pinned'])
def test_every_basis_and_wrap_becomes_the_same_cubic_as_bezier_segments(basis, evaluate, wrap):
    prim, p = _curves(basis=basis, wrap=wrap, counts=(6, 5))
    rec, warnings = _read(prim)
    assert not warnings and not rec.linear
    rows = rec.segment_rows()
    curves = [p[:6], p[6:]]
    if wrap == 'pinned':
        curves = [np.vstack([2 * q[0] - q[1], q, 2 * q[-1] - q[-2]]) for q in curves]
    expected = []
    for q in curves:
        n = len(q)
        segments = n if wrap == 'periodic' else n - 3
        for s in range(segments):
            g = q[[(s + j) % n for j in range(4)]]
            expected.append(evaluate(g, U))
    assert len(rows) == len(expected) == (11 if wrap == 'periodic' else 5 if wrap == 'nonperiodic' else 9)
    np.testing.assert_allclose(_bezier(rows[:, :, :3], U), np.array(expected), atol=1e-12)
    if wrap == 'pinned':                                 # a pinned curve passes through its end points
        np.testing.assert_allclose(rows[[0, 5], 0, :3], [p[0], p[6]], atol=1e-12)
        np.testing.assert_allclose(rows[[4, 8], 3, :3], [p[5], p[10]], atol=1e-12)
    if wrap == 'periodic':                               # a periodic curve closes
        np.testing.assert_allclose(rows[5, 3, :3], rows[0, 0, :3], atol=1e-12)


@pytest.mark.parametrize('wrap, counts, segments', [('nonperiodic', (4, 7, 10), 6), ('periodic', (3, 6, 9), 6),
                                                    ('pinned', (4, 7), 3)])
def test_bezier_segments_take_every_third_point(wrap, counts, segments):
    prim, p = _curves(counts=counts, wrap=wrap)
    rec, _ = _read(prim)
    rows = rec.segment_rows()
    assert len(rows) == segments
    np.testing.assert_allclose(rows[0, :, :3], p[:4] if wrap != 'periodic' else p[[0, 1, 2, 0]], atol=1e-12)
    if wrap == 'nonperiodic':
        np.testing.assert_allclose(rows[1:3, :, :3], [p[4:8], p[7:11]], atol=1e-12)


def test_linear_curves_share_their_vertices_and_flag_their_neighbours():
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [5, 5, 5], [6, 5, 5]], float)
    rec, _ = _read(_curves(kind='linear', counts=(3, 2), points=pts)[0])
    assert rec.linear
    np.testing.assert_array_equal(rec.vertices[:, :3], pts)
    np.testing.assert_array_equal(rec.segments, [0, 1, 3])
    np.testing.assert_array_equal(rec.flags, [2, 1, 0])            # right neighbour, left neighbour, alone
    rec, _ = _read(_curves(kind='linear', wrap='periodic', counts=(3,), points=pts[:3])[0])
    np.testing.assert_array_equal(rec.segment_rows()[:, :2, :3], [pts[[0, 1]], pts[[1, 2]], pts[[2, 0]]])


@pytest.mark.parametrize('widths, interpolation, ends', [
    (None, None, [(0.5, 0.5)] * 3),                                   # unauthored: 1
    ([0.4], 'constant', [(0.2, 0.2)] * 3),
    ([0.2, 0.6], 'uniform', [(0.1, 0.1), (0.1, 0.1), (0.3, 0.3)]),     # a curve
    ([0.2, 0.4, 0.6, 0.8, 0.2], 'varying', [(0.1, 0.2), (0.2, 0.3), (0.4, 0.1)]),     # a segment end
])
def test_widths_are_diameters_in_every_interpolation(widths, interpolation, ends):
    """Two bspline curves of 5 and 4 points: 2 + 1 segments, 3 + 2 segment ends; the radius along each segment."""
    prim, _ = _curves(basis='bspline', counts=(5, 4), widths=widths, interpolation=interpolation)
    rec, warnings = _read(prim)
    assert not warnings
    radius = _bezier(rec.segment_rows()[:, :, 3:], U)[:, :, 0]
    np.testing.assert_allclose(radius, [(1 - U) * a + U * b for a, b in ends], atol=1e-7)


def test_vertex_widths_follow_the_basis():
    prim, _ = _curves(basis='catmullRom', counts=(5,), widths=[1.0, 2.0, 3.0, 2.0, 1.0], interpolation='vertex')
    rows = _read(prim)[0].segment_rows()
    np.testing.assert_allclose(_bezier(rows[:, :, 3:], U)[:, :, 0],
                               [_catmull_rom(np.array([0.5, 1.0, 1.5, 1.0]), U),
                                _catmull_rom(np.array([1.0, 1.5, 1.0, 0.5]), U)], atol=1e-12)


def test_bad_curves_are_left_out_and_the_rest_kept():
    prim, p = _curves(counts=(4, 5, 7), widths=[0.1, 0.2], interpolation='vertex')
    rec, warnings = _read(prim)
    assert len(rec.segments) == 3                        # the 4- and 7-point curves: 1 + 2 segments
    np.testing.assert_allclose(rec.segment_rows()[1, :, :3], p[9:13], atol=1e-12)
    assert any('1 of 3 curves' in w for w in warnings)
    assert any('2 values for 3 curves of 16 vertices' in w for w in warnings)
    np.testing.assert_allclose(rec.vertices[:, 3], 0.05)          # (the first width: as a Points' widths)
    with pytest.raises(GeometryError, match='sum to 5 but there are 4 points'):
        _read(_curves(counts=(5,), points=np.zeros((4, 3)))[0])
    with pytest.raises(GeometryError, match='no curve to draw'):
        _read(_curves(counts=(2,))[0])
    with pytest.raises(GeometryError, match='basis'):
        _read(_curves(basis='hermite')[0])


def test_a_non_uniform_scale_is_warned_about_and_turns_normals_as_normals():
    prim, _ = _curves()
    UsdGeom.BasisCurves(prim).CreateNormalsAttr([Gf.Vec3f(0, 1, 1)])
    UsdGeom.BasisCurves(prim).SetNormalsInterpolation(UsdGeom.Tokens.constant)
    rec, warnings = _read(prim, m=np.diag([1.0, 2.0, 4.0, 1.0]))
    assert warnings == ['/c: a non-uniform scale; the curves stay round, their widths scaled by its mean scale']
    np.testing.assert_allclose(rec.vertices[:, 3], 0.5 * 2.0)      # radius x |det|^(1/3)
    np.testing.assert_allclose(rec.normals, np.tile([0.0, 2.0, 1.0], (4, 1)) / math.sqrt(5.0), atol=1e-12)


def test_display_color_varying_over_curves_is_kept_at_segment_ends():
    prim, _ = _curves(basis='bspline', counts=(5, 4), colors=[(1, 0, 0), (0, 1, 0)], color_interpolation='uniform')
    rec, _ = _read(prim)
    np.testing.assert_allclose(rec.colors, [[[1, 0, 0]] * 2] * 2 + [[[0, 1, 0]] * 2])
    cols = [(0, 0, 0), (0.3, 0, 0), (0.6, 0, 0), (0.9, 0, 0), (1.2, 0, 0), (0, 0, 0), (0, 0, 1), (0, 0, 1), (0, 0, 0)]
    prim, _ = _curves(basis='bspline', counts=(5, 4), colors=cols, color_interpolation='vertex')
    rec, _ = _read(prim)                                 # the curve's colour at each end, through the basis
    np.testing.assert_allclose(rec.colors[:2, :, 0], [[0.3, 0.6], [0.6, 0.9]], atol=1e-6)
    np.testing.assert_allclose(rec.colors[2, :, 2], [5 / 6, 5 / 6], atol=1e-6)


def test_a_segments_colour_is_interpolated_along_it():
    tri_c = np.zeros((3, 3, 3), np.float32)
    tri_c[2, 0], tri_c[2, 1] = (1.0, 0.0, 0.5), (0.0, 1.0, 0.5)

    class S:                                                    # (the fields corner_color reads)
        gp_flags = np.array([8], np.int32)
        gp_kind = np.array([2], np.int32)
        gp_c_off = np.array([1], np.int64)
    S.tri_c = tri_c
    got = corner_color.py_func(S, 0, Hit(0, 0, 0, 1, 0.25, 0.9, 1.0))
    np.testing.assert_allclose(got, (0.75, 0.25, 0.5))


# --------------------------------------------------------------------------- geometry: closed forms
def _tube(r=0.3, half=1.5, linear=False, material=0, r1=None):
    r1 = r if r1 is None else r1
    if linear:
        v = np.array([[-half, 0, 0, r], [half, 0, 0, r1]], float)
        return D.Curves('/c', vertices=v, segments=np.array([0]), linear=True, material=material,
                        flags=np.zeros(1, np.uint8))
    x = np.linspace(-half, half, 4)
    v = np.column_stack([x, np.zeros(4), np.zeros(4), np.linspace(r, r1, 4)])
    return D.Curves('/c', vertices=v, segments=np.array([0]), linear=False, material=material)


def _cast(curves, origins, dirs, matrix=None):
    cam = D.Camera('/cam', matrix=look_at((0, 0, 10), (0, 0, 0)))
    inst = None
    if matrix is not None:
        inst = D.Instances(container=np.zeros(1, np.int32), matrices=np.asarray(matrix, float)[None, None],
                           material_set=np.zeros(1, np.int32), material_sets=[()])
    b = build(scene([D.Container('/p', curves=curves)], [GREY], [], cam, instances=inst))
    try:
        P, N = np.zeros((len(origins), 3)), np.zeros((len(origins), 3))
        _hits(b.data, b.handle, np.asarray(origins, float) - b.origin, np.asarray(dirs, float), P, N)
        hit = ~np.isnan(N[:, 0])
        return hit, P + b.origin, N
    finally:
        b.close()


def _random_rays(n, box, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    target = rng.uniform(-1, 1, size=(n, 3)) * box
    return target - 10 * d, d


def _foot(v, p, u0):
    """The parameter of p's nearest point on the Bezier v (4, 4) near u0, by Newton's method on (p - c) . c'."""
    u = u0
    for _ in range(50):
        w = np.array([(1 - u) ** 3, 3 * (1 - u) ** 2 * u, 3 * (1 - u) * u * u, u ** 3])
        dw = np.array([-3 * (1 - u) ** 2, 3 * (1 - u) ** 2 - 6 * (1 - u) * u, 6 * (1 - u) * u - 3 * u * u, 3 * u * u])
        ddw = np.array([6 * (1 - u), 6 * u - 12 * (1 - u), 6 * (1 - u) - 12 * u, 6 * u])
        c, d, dd = w @ v, dw @ v, ddw @ v
        u = float(np.clip(u - np.dot(p - c[:3], d[:3]) / (np.dot(p - c[:3], dd[:3]) - np.dot(d[:3], d[:3])), 0, 1))
    return u, (w @ v)


def test_a_wavy_tube_of_varying_radius_is_hit_on_its_surface_with_its_normal():
    """A Bezier whose radius grows from 0.1 to 0.2: every hit lies on the circle of its foot on the curve (the
    curve's point nearest to it: dense search, then Newton), of that point's radius, and its normal is the
    gradient of the distance to that surface, F(p) = |p - c(u(p))| - r(u(p)), by central differences."""
    v = np.array([[-2, 0, 0, 0.1], [-1, 1.3, 0, 0.133], [1, -1.3, 0, 0.167], [2, 0, 0, 0.2]], float)
    curve = D.Curves('/c', vertices=v, segments=np.array([0]), linear=False, material=0)
    o, d = _random_rays(4000, np.array([1.8, 0.6, 0.2]))
    hit, P, N = _cast([curve], o, d)
    front = hit & (np.einsum('ij,ij->i', N, d) < 0)
    assert front.sum() > 1000
    u = np.linspace(0, 1, 4001)
    C = _bezier(v.astype(np.float32).astype(float)[None], u)[0]
    vv = v.astype(np.float32).astype(float)

    def F(p):
        k = np.argmin(np.linalg.norm(C[:, :3] - p, axis=1))
        _, c = _foot(vv, p, u[k])
        return np.linalg.norm(p - c[:3]) - c[3]
    dist, err, h = [], [], 1e-5
    for p, n in list(zip(P[front], N[front]))[:300]:
        dist.append(F(p))
        grad = np.array([F(p + h * e) - F(p - h * e) for e in np.eye(3)]) / (2 * h)
        err.append(np.degrees(np.arccos(np.clip(np.dot(grad / np.linalg.norm(grad), n), -1, 1))))
    assert np.max(np.abs(dist)) < 1e-6
    assert np.max(err) < 2e-3


@pytest.mark.parametrize('linear', [False, True])
def test_a_cone_of_growing_radius_has_its_normal(linear):
    """From radius 0.2 to 0.4 over a length 2.  Linear (Embree's round linear curve, swept spheres): the cone
    tangent to the spheres, whose normal leans back by asin(dr / L).  A straight Bezier of linearly growing radius
    (Embree's round Bezier curve, circles perpendicular to the curve): the cone of radius r(x), leaning back by
    atan(dr / L)."""
    curve = _tube(r=0.2, r1=0.4, half=1.0, linear=linear)
    rng = np.random.default_rng(3)
    phi = rng.uniform(0, 2 * np.pi, 3000)
    x = rng.uniform(-0.8, 0.8, 3000)
    radial = np.column_stack([np.zeros_like(phi), np.cos(phi), np.sin(phi)])
    o = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]) + 5 * radial
    hit, P, N = _cast([curve], o, -radial)
    assert hit.all()
    s = 0.2 / 2.0                                        # dr / L
    lean = s if linear else s / math.sqrt(1 + s * s)
    expected = np.column_stack([np.full(len(x), -lean), np.sqrt(1 - lean * lean) * radial[:, 1:]])
    np.testing.assert_allclose(N, expected, atol=2e-6)
    # the distance to the axis: the tangent cone's radius there (spheres), the circle's radius (circles)
    rho = np.linalg.norm(P[:, 1:], axis=1)
    cone = (0.3 + 0.1 * P[:, 0]) / (math.sqrt(1 - s * s) if linear else 1.0)
    np.testing.assert_allclose(rho, cone, atol=2e-6)


def test_an_instanced_tube_has_its_placements_normals():
    """Placed by a rotation and a uniform scale of 2, a tube of radius 0.1 along x becomes one of radius 0.2 along
    the rotated axis: the normals are radial there."""
    c, s = math.cos(0.7), math.sin(0.7)
    m = np.array([[2 * c, -2 * s, 0, 0.5], [2 * s, 2 * c, 0, -0.25], [0, 0, 2, 1.0], [0, 0, 0, 1]])
    o, d = _random_rays(3000, np.array([2.0, 2.0, 1.0]), seed=5)
    hit, P, N = _cast([_tube(r=0.1, half=1.0)], o + m[:3, 3], d, matrix=m)
    axis = np.array([c, s, 0.0])
    front = hit & (np.einsum('ij,ij->i', N, d) < 0)
    assert front.sum() > 200
    rel = P[front] - m[:3, 3]
    radial = rel - np.outer(rel @ axis, axis)
    np.testing.assert_allclose(np.linalg.norm(radial, axis=1), 0.2, atol=1e-6)
    np.testing.assert_allclose(N[front], radial / 0.2, atol=1e-5)


def test_a_linear_curves_ends_are_round():
    """Rays from every side: the hits beyond a linear tube's ends lie on the spheres there, with their normals."""
    r = 0.3
    o, d = _random_rays(4000, np.array([2.0, 0.5, 0.5]), seed=2)
    hit, P, N = _cast([_tube(r, 1.5, linear=True)], o, d)
    cap = hit & (np.einsum('ij,ij->i', N, d) < 0) & (np.abs(P[:, 0]) > 1.5)
    assert cap.sum() > 200
    rel = P[cap] - np.column_stack([np.sign(P[cap, 0]) * 1.5, np.zeros((cap.sum(), 2))])
    np.testing.assert_allclose(np.linalg.norm(rel, axis=1), r, atol=1e-6)
    np.testing.assert_allclose(N[cap], rel / r, atol=1e-6)


def _ortho(width, y=0.0):
    return D.Camera('/cam', matrix=translate(0, y, 10), projection='orthographic', horizontal_aperture=width,
                    vertical_aperture=width)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('linear', [False, True])
def test_a_tubes_silhouette_has_its_area(integrator, linear):
    """A black tube of radius r and length L before a white background, seen side-on by an orthographic camera:
    it covers 2 r L (a cubic curve's ends are open, as Embree's round curves are), plus pi r^2 for a linear curve's
    two round ends.  Pixel by pixel, the coverage of a supersampled exact silhouette."""
    r, half, n, width = 0.3, 1.5, 48, 4.0
    desc = scene([D.Container('/p', curves=[_tube(r, half, linear)])], [BLACK], [], _ortho(width), width=n, height=n,
                 background=(1, 1, 1))
    img = render(desc, RenderOptions(spp=256, sampler='sobol', filter='box', integrator=integrator)).image[..., 0]
    coverage = 1.0 - img
    area = coverage.sum() * (width / n) ** 2
    expected = 2 * r * 2 * half + (math.pi * r * r if linear else 0.0)
    assert area == pytest.approx(expected, rel=4e-3)
    sub = (np.arange(16) + 0.5) / 16 - 0.5
    xs = (-width / 2 + width * (np.arange(n) + 0.5) / n)
    X = (xs[:, None] + sub[None] * width / n).ravel()
    GX, GY = np.meshgrid(X, -X)
    inside = (np.abs(GX) <= half) & (np.abs(GY) <= r)
    if linear:
        inside |= (np.abs(GX) - half) ** 2 + GY ** 2 <= r * r
    ref = inside.reshape(n, 16, n, 16).mean(axis=(1, 3))
    assert np.max(np.abs(coverage - ref)) < 0.08


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('linear', [False, True])
def test_a_lambert_tube_under_a_distant_light_shades_as_the_cosine(integrator, linear):
    """A grey (0.5) tube of radius 1 along x, longer than the view, lit by a delta distant light of irradiance E
    along the view direction: radiance 0.5 E / pi * cos(theta) (path; cook's course Lambertian: 0.5 E cos(theta)),
    cos(theta) = sqrt(1 - y^2), at each pixel the average over it of that profile (0 off the tube)."""
    E, n, width = 2.0, 32, 3.0
    light = D.Light('/sun', D.DISTANT, np.eye(4), (E, E, E), angle=0.0)
    desc = scene([D.Container('/p', curves=[_tube(1.0, 4.0, linear)])], [GREY], [light], _ortho(width), width=n,
                 height=n)
    img = render(desc, RenderOptions(spp=256, sampler='sobol', filter='box', integrator=integrator,
                                     max_depth=1 if integrator == 'path' else None)).image[..., 0]
    ys = (width / 2 - width * (np.arange(n) + 0.5) / n)
    brdf = 0.5 / np.pi if integrator == 'path' else 0.5          # (the course's Lambertian in cook: kd E cos)
    y0, y1 = np.clip(ys - 0.5 * width / n, -1, 1), np.clip(ys + 0.5 * width / n, -1, 1)
    area = lambda y: 0.5 * (y * np.sqrt(1 - y * y) + np.arcsin(y))          # the integral of sqrt(1 - y^2)
    ref = brdf * E * (area(y1) - area(y0)) / (width / n)
    np.testing.assert_allclose(img, np.repeat(ref[:, None], n, axis=1), atol=2e-3 * ref.max())
    rows = np.abs(ys) < 0.9
    np.testing.assert_allclose(img[rows], np.repeat(ref[rows, None], n, axis=1), rtol=2e-4)


# --------------------------------------------------------------------------- USD, end to end
def _usd_stage(path, coloured=False, split=False, instanced=False):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    cam = UsdGeom.Camera.Define(stage, '/cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 8))
    UsdLux.DomeLight.Define(stage, '/sky').CreateIntensityAttr(1.0)
    root = '/proto' if instanced else '/world'
    pts = [(-2, -1, 0), (-1, 0, 0), (1, -1, 0), (2, 0, 0), (-2, 1, 0), (-1, 2, 0), (1, 1, 0), (2, 2, 0)]
    groups = [([0, 1, 2, 3, 4, 5, 6, 7], [(1, 0, 0), (0, 1, 0)])] if not split else \
        [([0, 1, 2, 3], [(1, 0, 0)]), ([4, 5, 6, 7], [(0, 1, 0)])]
    for k, (sel, cols) in enumerate(groups):
        c = UsdGeom.BasisCurves.Define(stage, f'{root}/c{k}')
        c.CreateBasisAttr('bspline')
        c.CreateWrapAttr('pinned')
        c.CreateCurveVertexCountsAttr([4] * (len(sel) // 4))
        c.CreatePointsAttr([Gf.Vec3f(*pts[i]) for i in sel])
        c.CreateWidthsAttr([0.4])
        if coloured:
            interpolation = UsdGeom.Tokens.uniform if len(cols) > 1 else UsdGeom.Tokens.constant
            c.CreateDisplayColorPrimvar(interpolation).Set([Gf.Vec3f(*x) for x in cols])
    if instanced:
        stage.GetPrimAtPath('/proto').SetSpecifier(Sdf.SpecifierClass)
        for k, dx in enumerate((-1.0, 1.0)):
            inst = UsdGeom.Xform.Define(stage, f'/i{k}')
            inst.AddTranslateOp().Set(Gf.Vec3d(dx, 0, 0))
            inst.GetPrim().GetInherits().AddInherit('/proto')
            inst.GetPrim().SetInstanceable(True)
    stage.Save()
    return str(path)


def test_curves_under_native_instances_are_one_prototype_placed_twice(tmp_path):
    desc = read_stage(_usd_stage(tmp_path / 'i.usda', instanced=True))
    with_curves = [c for c in desc.containers if c.curves]
    assert len(with_curves) == 1 and len(with_curves[0].curves) == 1                  # one gprim of two curves,
    assert len(with_curves[0].curves[0].segments) == 6                                   # 3 segments each
    placed = desc.instances.container == desc.containers.index(with_curves[0])
    np.testing.assert_allclose(sorted(desc.instances.matrices[placed, 0, 0, 3]), [-1.0, 1.0])


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_colours_per_curve_render_as_curves_of_one_colour_each(tmp_path, integrator):
    """A gprim of two curves, red and green (uniform displayColor), renders as two gprims of one colour each."""
    opts = RenderOptions(width=48, height=32, spp=8, integrator=integrator,
                         max_depth=2 if integrator == 'path' else None)
    a = render(read_stage(_usd_stage(tmp_path / 'a.usda', coloured=True)), opts).image
    b = render(read_stage(_usd_stage(tmp_path / 'b.usda', coloured=True, split=True)), opts).image
    assert a[..., 0].max() > 0.3 and a[..., 1].max() > 0.3
    assert np.abs(a - b).mean() <= 1e-6 * max(b.mean(), 1e-6) + 1e-7
    assert np.abs(a - b).max() <= 1e-4 * b.max()


def test_a_curves_gprim_that_cannot_be_used_is_skipped_with_its_reason(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / 'bad.usda'))
    bad = UsdGeom.BasisCurves.Define(stage, '/bad')
    bad.CreateCurveVertexCountsAttr([4, 4])
    bad.CreatePointsAttr([Gf.Vec3f(0, 0, 0)] * 5)
    good = UsdGeom.BasisCurves.Define(stage, '/good')
    good.CreateCurveVertexCountsAttr([4])
    good.CreatePointsAttr([Gf.Vec3f(x, 0, 0) for x in range(4)])
    stage.Save()
    desc = read_stage(str(tmp_path / 'bad.usda'))
    assert [len(c.curves) for c in desc.containers] == [1]
    assert any('/bad: curveVertexCounts sum to 8 but there are 5 points' in s for s in desc.skipped)


def test_a_width_of_zero_tapers_to_a_point_and_a_negative_one_is_warned_about():
    prim, _ = _curves(kind='linear', counts=(3,), widths=[0.0, 0.4, 0.0], interpolation='vertex')
    rec, warnings = _read(prim)
    assert not warnings
    np.testing.assert_allclose(rec.vertices[:, 3], [0.0, 0.2, 0.0])
    prim, _ = _curves(kind='linear', counts=(3,), widths=[-1.0, 0.4, float('nan')], interpolation='vertex')
    rec, warnings = _read(prim)
    assert warnings == ['/c: 2 control points with a width that is negative or not finite; drawn with width 0']
    np.testing.assert_allclose(rec.vertices[:, 3], [0.0, 0.2, 0.0])
    with pytest.raises(GeometryError, match='no width is positive'):
        _read(_curves(kind='linear', counts=(3,), widths=[0.0])[0])


def test_the_curves_example_scene():
    """scenes/curves.usda: the tuft of 80 blades (pinned bspline, 5 points: 4 segments each) is one prototype placed
    seven times; the knot (periodic bspline of 72 points: 72 segments), the spring (pinned catmullRom of 64: 63),
    the wire (two linear curves of 12: 22) and the ribbon (pinned bspline of 24 with normals: 23) are placed once;
    colours a blade and a vertex; no warning; a small path render is finite and lit."""
    from pathlib import Path
    desc = read_stage(str(Path(__file__).resolve().parents[2] / 'scenes' / 'curves.usda'))
    assert not desc.warnings and not desc.skipped
    curves = {x.path: (x, k) for k, c in enumerate(desc.containers) for x in c.curves}
    assert {p: len(x.segments) for p, (x, _) in curves.items()} == {
        '/__Prototype_1/Blades': 320, '/World/Knot': 72, '/World/Spring': 63, '/World/Wire': 22, '/World/Ribbon': 23}
    blades, k = curves['/__Prototype_1/Blades']
    assert np.count_nonzero(desc.instances.container == k) == 7
    assert blades.colors.shape == (320, 2, 3) and curves['/World/Spring'][0].colors.shape == (63, 2, 3)
    assert curves['/World/Wire'][0].linear and curves['/World/Knot'][0].colors is None
    assert curves['/World/Ribbon'][0].normals.shape == (4 * 23, 3) and curves['/World/Knot'][0].normals is None
    img = render(desc, RenderOptions(width=40, height=30, spp=4, integrator='path', max_depth=2)).image
    assert np.isfinite(img).all() and img.mean() > 0.05


def test_nurbs_curves_are_drawn_as_their_control_cage_as_usdimaging_draws_them():
    """usdImaging's NurbsCurves adapter gives Storm a linear, nonperiodic BasisCurves topology of the control points:
    so does rtc, with the widths and colours, and says so."""
    stage = Usd.Stage.CreateInMemory()
    c = UsdGeom.NurbsCurves.Define(stage, '/n')
    pts = np.array([[0, 0, 0], [1, 1, 0], [2, 1, 0], [3, 0, 0], [0, 0, 2], [1, 1, 2], [2, 0, 2]], float)
    c.CreatePointsAttr([Gf.Vec3f(*p) for p in pts])
    c.CreateCurveVertexCountsAttr([4, 3])
    c.CreateOrderAttr([4, 3])
    c.CreateKnotsAttr([0, 0, 0, 0, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1])
    c.CreateWidthsAttr([0.2, 0.4])
    c.SetWidthsInterpolation(UsdGeom.Tokens.uniform)
    c.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 0, 1)])
    rec, warnings = _read(stage.GetPrimAtPath('/n'))
    assert rec.linear and warnings == ['/n: NurbsCurves drawn as their control cage (linear segments through the '
                                       'control points), as usdImaging draws them']
    np.testing.assert_array_equal(rec.vertices[:, :3], pts)
    np.testing.assert_allclose(rec.vertices[:, 3], [0.1] * 4 + [0.2] * 3)
    np.testing.assert_array_equal(rec.segments, [0, 1, 2, 4, 5])
    np.testing.assert_allclose(rec.colors[:, 0], [[1, 0, 0]] * 3 + [[0, 0, 1]] * 2)


# --------------------------------------------------------------------------- ribbons (BasisCurves with normals)
def test_normals_make_ribbons_facing_them():
    """Normals a vertex go through the basis as the points do (unit length after); a linear curve with normals
    becomes straight Bezier segments (Embree has no normal-oriented linear curves); varying normals run linearly
    along each segment."""
    prim, p = _curves(kind='linear', counts=(3,), widths=[0.2])
    UsdGeom.BasisCurves(prim).CreateNormalsAttr([Gf.Vec3f(0, 0, 2), Gf.Vec3f(0, 1, 1), Gf.Vec3f(0, 1, 0)])
    UsdGeom.BasisCurves(prim).SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    rec, warnings = _read(prim)
    assert not warnings and not rec.linear and rec.flags is None
    rows = rec.segment_rows()
    np.testing.assert_allclose(rows[:, :, :3], [[p[0] + (p[1] - p[0]) * k / 3 for k in range(4)],
                                                [p[1] + (p[2] - p[1]) * k / 3 for k in range(4)]], atol=1e-12)
    n = rec.normals[rec.segments[:, None] + np.arange(4)]
    expect = np.array([[(0, 0, 2), (0, 1, 1)], [(0, 1, 1), (0, 1, 0)]], float)
    raw = (1 - np.arange(4) / 3)[None, :, None] * expect[:, :1] + (np.arange(4) / 3)[None, :, None] * expect[:, 1:]
    np.testing.assert_allclose(n, raw / np.linalg.norm(raw, axis=2, keepdims=True), atol=1e-12)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_ribbon_tilted_from_the_view_covers_its_projected_area_and_shades_as_its_cosine(integrator):
    """A straight ribbon of width 2 r along x whose normal leans 60 degrees from the view direction, seen by an
    orthographic camera: it covers 2 r L cos(60); lit by a delta distant light along the view, a grey Lambert
    ribbon's radiance is 0.5 E cos(60) / pi (path; cook's course Lambertian 0.5 E cos(60)) wherever it covers a
    pixel whole."""
    r, half, n, width, E = 0.6, 1.5, 48, 4.0, 2.0
    th = math.radians(60.0)
    v = np.column_stack([np.linspace(-half, half, 4), np.zeros(4), np.zeros(4), np.full(4, r)])
    ribbon = D.Curves('/r', vertices=v, segments=np.array([0]), linear=False, material=0,
                      normals=np.tile([0.0, -math.sin(th), math.cos(th)], (4, 1)))
    opts = RenderOptions(spp=256, sampler='sobol', filter='box', integrator=integrator,
                         max_depth=1 if integrator == 'path' else None)
    desc = scene([D.Container('/p', curves=[ribbon])], [BLACK], [], _ortho(width), width=n, height=n,
                 background=(1, 1, 1))
    coverage = 1.0 - render(desc, opts).image[..., 0]
    assert coverage.sum() * (width / n) ** 2 == pytest.approx(2 * r * 2 * half * math.cos(th), rel=4e-3)
    light = D.Light('/sun', D.DISTANT, np.eye(4), (E, E, E), angle=0.0)
    desc = scene([D.Container('/p', curves=[ribbon])], [GREY], [light], _ortho(width), width=n, height=n)
    img = render(desc, opts).image[..., 0]
    whole = coverage > 1 - 1e-6
    assert whole.sum() > 100
    brdf = 0.5 / np.pi if integrator == 'path' else 0.5
    np.testing.assert_allclose(img[whole], brdf * E * math.cos(th), rtol=1e-4)


def test_normals_that_fit_no_interpolation_leave_round_tubes_and_a_warning():
    prim, _ = _curves(counts=(4,))
    UsdGeom.BasisCurves(prim).CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 3)
    rec, warnings = _read(prim)
    assert rec.normals is None
    assert warnings == ['/c: normals: 3 values for 1 curve of 4 vertices (2 segment ends) do not fit interpolation '
                        'vertex', '/c: normals: the curves are drawn as round tubes']


def test_a_shots_next_frame_reuses_curves_only_when_their_bvh_would_be_the_same():
    """`shots.worker.same_containers`: curves whose points, segments or (ribbons) normals changed are rebuilt."""
    import copy
    from rtc.renderer.host.shots.worker import same_containers
    v = np.column_stack([np.linspace(-1, 1, 4), np.zeros((4, 2)), np.full(4, 0.1)])
    rib = D.Curves('/r', vertices=v, segments=np.array([0]), linear=False, normals=np.tile([0.0, 0.0, 1.0], (4, 1)))
    a = scene([D.Container('/p', curves=[rib])], [GREY], [], _ortho(2.0))
    assert same_containers(a, copy.deepcopy(a))
    for change in (lambda x: x.vertices.__setitem__((0, 1), 1e-9), lambda x: x.normals.__setitem__((0, 1), 1e-9),
                   lambda x: setattr(x, 'normals', None)):
        b = copy.deepcopy(a)
        change(b.containers[0].curves[0])
        assert not same_containers(a, b)


@pytest.mark.parametrize('linear', [False, True])
def test_an_emissive_curve_is_seen_and_is_a_light_unwarned(linear):
    """Camera rays that meet an emissive tube see its emission: side-on before a black background, an orthographic
    view shows radiance Le over the tube's silhouette, 2 r L of it (+ pi r^2, a linear tube's round ends).  Cubic and
    linear tubes are lights of the path integrator (`test_curve_lights.py`): nothing is warned."""
    glow = D.Material('/glow', model=D.PREVIEW_SURFACE, diffuse=(0.0, 0.0, 0.0), emission=(3.0, 3.0, 3.0))
    r, half, n, width = 0.3, 1.5, 48, 4.0
    desc = scene([D.Container('/p', curves=[_tube(r, half, linear=linear)])], [glow], [], _ortho(width), width=n,
                 height=n)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        img = render(desc, RenderOptions(spp=64, sampler='sobol', filter='box', integrator='path')).image[..., 0]
    assert [str(w.message) for w in said if 'emissive curves' in str(w.message)] == []
    assert img.max() == pytest.approx(3.0, rel=1e-6)
    area = 2 * r * 2 * half + (math.pi * r * r if linear else 0.0)
    assert img.sum() * (width / n) ** 2 / 3.0 == pytest.approx(area, rel=5e-3)


def test_an_emissive_ribbon_is_seen_but_is_no_light_and_is_warned():
    """Embree tessellates ribbons, so no light sample can draw the point a ray finds on one: an emissive ribbon is
    seen (radiance Le over its projected area) and warned about once, at render time, as no light of the path
    integrator."""
    glow = D.Material('/glow', model=D.PREVIEW_SURFACE, diffuse=(0.0, 0.0, 0.0), emission=(3.0, 3.0, 3.0))
    r, half, n, width = 0.6, 1.5, 48, 4.0
    v = np.column_stack([np.linspace(-half, half, 4), np.zeros(4), np.zeros(4), np.full(4, r)])
    ribbon = D.Curves('/r', vertices=v, segments=np.array([0]), linear=False, material=0,
                      normals=np.tile([0.0, 0.0, 1.0], (4, 1)))
    desc = scene([D.Container('/p', curves=[ribbon])], [glow], [], _ortho(width), width=n, height=n)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        img = render(desc, RenderOptions(spp=64, sampler='sobol', filter='box', integrator='path')).image[..., 0]
    assert [str(w.message)[:35] for w in said if 'emissive curves' in str(w.message)] == \
        ['1 emissive curves gprims (ribbons, ']
    assert img.sum() * (width / n) ** 2 / 3.0 == pytest.approx(2 * r * 2 * half, rel=5e-3)
