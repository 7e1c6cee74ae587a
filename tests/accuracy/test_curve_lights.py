"""Emissive curves are lights of the path integrator (`host/surface_lights.py`, `kernel/surface_lights.py`): a
light a segment at each placement, sampled in u along it and uniformly in angle around its circle, whose density
per unit area is f(u) / (2 pi J), J the area element of the tube of circles (`kernel/curves.tube_point`); a linear
segment's side (a cone) as the tube of circles of a straight Bezier, its round ends and joints found by BSDF rays
alone.  Light sampling alone, BSDF sampling alone and MIS converge to one image; the area element against closed
forms and an independent quadrature; a linear side's points on Embree's own surface."""
import math
from collections import namedtuple

import numba as nb
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import RenderOptions, Renderer
from rtc.renderer.host.build import build
from rtc.renderer import description as D
from rtc.renderer.host.curve_caps import round_caps
from rtc.renderer.host.surface_lights import cone_sides, surface_lights, tube_areas
from rtc.renderer.kernel.curves import tube_area_element, tube_point
from rtc.renderer.kernel.surface_lights import CURVE_BINS, _bin_density, _cap_point
from rtc.renderer.kernel.tables import CURVE_CAP, CURVE_CUBIC, CURVE_LINEAR, SLI_CURVE, SURFACE_LIGHT_F
from rtc.renderer.kernel.vecmath import turn
from rtc.renderer.usd.stage import read_stage
from tests.renderer.test_curves import _cast

WAVY = np.array([[-1.5, 0.8, 0.0, 0.05], [-0.5, 1.6, 0.5, 0.3], [0.5, 0.3, -0.5, 0.15], [1.5, 1.0, 0.2, 0.4]])


def _line(p0, p1, r0, r1):
    a = np.linspace(0.0, 1.0, 4)[:, None]
    return np.column_stack([(1 - a) * np.array(p0, float) + a * np.array(p1, float), (1 - a[:, 0]) * r0 + a[:, 0] * r1])


def test_tube_areas_against_closed_forms():
    """A frustum: pi (r0 + r1) times its slant height; a tube of constant radius around any curve: 2 pi r times the
    curve's length (Pappus), the length by a fine independent quadrature."""
    assert tube_areas(_line((0, 0, 0), (2, 0, 0), 0.1, 0.4)[None])[0] == pytest.approx(
        math.pi * 0.5 * math.hypot(2.0, 0.3), rel=1e-12)
    q = WAVY.copy()
    q[:, 3] = 0.2
    u = np.linspace(0.0, 1.0, 200001)
    s = 1.0 - u
    d = np.stack([-3 * s * s, 3 * s * s - 6 * s * u, 6 * s * u - 3 * u * u, 3 * u * u], 1) @ q[:, :3]
    length = np.trapezoid(np.linalg.norm(d, axis=1), u)
    assert tube_areas(q[None], nodes=32, angles=64)[0] == pytest.approx(2 * math.pi * 0.2 * length, rel=1e-9)
    assert tube_areas(q[None])[0] == pytest.approx(2 * math.pi * 0.2 * length, rel=1e-4)


def test_a_sampled_point_lies_on_the_tube_and_its_hit_gives_back_its_density():
    """Points drawn on the wavy, tapering tube: on the circle of radius r(u) around c(u), perpendicular to c'(u);
    the area element recomputed from the point alone (as a ray's hit gives it) is the sample's; the mean of 2 pi J
    over uniform (u, angle) is the tube's area (an independent quadrature)."""
    q = tuple(tuple(float(x) for x in row) for row in WAVY)
    rng = np.random.default_rng(7)
    total = []
    for u, a in rng.random((4000, 2)):
        p, n, jac = tube_point(*q, u, turn(a))
        s = 1.0 - u
        b = np.array([s ** 3, 3 * s * s * u, 3 * s * u * u, u ** 3])
        db = np.array([-3 * s * s, 3 * s * s - 6 * s * u, 6 * s * u - 3 * u * u, 3 * u * u])
        c, dc = b @ WAVY, db @ WAVY
        x = np.array(p) - c[:3]
        assert np.linalg.norm(x) == pytest.approx(c[3], rel=1e-9)
        assert abs(x @ dc[:3]) <= 1e-9 * np.linalg.norm(dc[:3])
        assert tube_area_element(*q, u, p) == pytest.approx(jac, rel=1e-7)
        assert np.linalg.norm(n) == pytest.approx(1.0, rel=1e-12)
        total.append(2 * math.pi * jac)
    assert np.mean(total) == pytest.approx(tube_areas(WAVY[None], nodes=32, angles=64)[0], rel=0.02)


WIDTHS = (0.1, 0.6, 0.3, 0.8, 0.4, 0.5, 0.2, 0.2, 0.3, 0.2, 0.1)


def test_the_area_element_is_the_jacobian_of_the_map():
    """J of `tube_point` against central differences of the map (u, angle) -> point itself (its frame included)."""
    q = tuple(tuple(float(x) for x in row) for row in WAVY)
    point = lambda u, a: np.array(tube_point(*q, u, (math.cos(2 * math.pi * a), math.sin(2 * math.pi * a)))[0])
    h = 1e-6
    for u, a in np.random.default_rng(1).uniform(0.01, 0.99, (300, 2)):
        du = (point(u + h, a) - point(u - h, a)) / (2 * h)
        da = (point(u, a + h) - point(u, a - h)) / (2 * h) / (2 * math.pi)
        jac = tube_point(*q, u, (math.cos(2 * math.pi * a), math.sin(2 * math.pi * a)))[2]
        assert np.linalg.norm(np.cross(du, da)) == pytest.approx(jac, rel=1e-7)


def test_the_bins_density_in_u_integrates_to_one_and_follows_the_bins_weights():
    """`_bin_density` (the draw of u seen from p): piecewise constant over CURVE_BINS bins, mean 1 over [0, 1], and
    in each bin its weight's share (circumference times speed over squared distance, an independent evaluation)."""
    q = tuple(tuple(float(x) for x in row) for row in WAVY)
    u = (np.arange(CURVE_BINS) + 0.5) / CURVE_BINS
    s = 1.0 - u
    b = np.stack([s ** 3, 3 * s * s * u, 3 * s * u * u, u ** 3], 1) @ WAVY
    db = np.stack([-3 * s * s, 3 * s * s - 6 * s * u, 6 * s * u - 3 * u * u, 3 * u * u], 1) @ WAVY
    for p in ((0.0, 0.0, 0.0), (1.5, 1.2, 0.3), (-3.0, 4.0, 2.0)):
        f = np.array([_bin_density(*q, p, x) for x in u])
        assert f.mean() == pytest.approx(1.0, rel=1e-12)
        w = b[:, 3] * np.linalg.norm(db[:, :3], axis=1) / np.maximum(((np.array(p) - b[:, :3]) ** 2).sum(1),
                                                                     b[:, 3] ** 2)
        np.testing.assert_allclose(f, CURVE_BINS * w / w.sum(), rtol=1e-9)
        assert _bin_density(*q, p, u[2] + 0.4 / CURVE_BINS) == f[2]


def _stage(placements=((1.0, (0.0, 0.0, 0.0)),), dome=0.05, specular=True, widths=WIDTHS):
    """An emissive gprim of two cubic curves (two segments and one; tapering, wavy) above a grey floor under a dim
    dome, placed (uniform scale, offset) once per entry of `placements` (instances of one prototype); its material
    reflects as a default UsdPreviewSurface's specular layer does, or (not `specular`) nothing."""
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    floor = UsdGeom.Mesh.Define(st, '/World/Floor')
    floor.CreatePointsAttr([(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    black = {} if specular else {'useSpecularWorkflow': 1, 'specularColor': (0.0, 0.0, 0.0)}
    glow = _material(st, '/World/Glow', diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(4.0, 3.0, 2.0), **black)
    grey = _material(st, '/World/Grey', diffuseColor=(0.7, 0.7, 0.7), roughness=0.9)
    UsdShade.MaterialBindingAPI.Apply(floor.GetPrim()).Bind(grey)
    proto = st.CreateClassPrim('/Lamp')
    tube = UsdGeom.BasisCurves.Define(st, '/Lamp/Tube')
    tube.CreateTypeAttr('cubic')
    tube.CreateBasisAttr('bezier')
    second = WAVY[:, :3] * (1.0, 0.6, -1.0) + (0.3, 0.4, 0.8)
    points = np.concatenate([WAVY[:, :3], [(2.5, 1.2, 0.0), (3.0, 0.5, 0.5), (3.5, 1.0, 1.0)], second])
    tube.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    tube.CreateCurveVertexCountsAttr([7, 4])
    tube.CreateWidthsAttr(list(widths))
    tube.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    UsdShade.MaterialBindingAPI.Apply(tube.GetPrim()).Bind(glow)
    for k, (scale, at) in enumerate(placements):
        xf = UsdGeom.Xform.Define(st, f'/World/Lamp{k}')
        xf.GetPrim().GetReferences().AddInternalReference(proto.GetPath())
        xf.GetPrim().SetInstanceable(True)
        xf.AddTranslateOp().Set(Gf.Vec3d(*at))
        xf.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
    UsdLux.DomeLight.Define(st, '/World/Sky').CreateIntensityAttr(dome)
    cam = UsdGeom.Camera.Define(st, '/World/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.5, 3.0, 6.0))
    cam.AddRotateXOp().Set(-28.0)
    return st


def _material(st, path, **inputs):
    mat = UsdShade.Material.Define(st, path)
    sh = UsdShade.Shader.Define(st, path + '/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    for name, value in inputs.items():
        kind = {tuple: Sdf.ValueTypeNames.Color3f, int: Sdf.ValueTypeNames.Int}.get(type(value),
                                                                                   Sdf.ValueTypeNames.Float)
        sh.CreateInput(name, kind).Set(value)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _mean(r, strategy, spp, seeds=2, depth=2):
    return np.mean([r.render(RenderOptions(width=40, height=30, spp=spp, seed=s, integrator='path', max_depth=depth,
                                           strategy=strategy, sampler='independent')).image.astype(np.float64)
                    for s in range(seeds)], 0)


@pytest.mark.parametrize('specular', [False, True])
def test_light_sampling_and_bsdf_sampling_find_the_same_curve_lights(specular):
    """Two placements (one scaled 0.7), three segments each: light k of a hit is its placement's first plus the
    segment (a wrong one, or a wrong density, would bias the MIS image away from BSDF sampling's); with a specular
    layer, the tube also lights itself (its concave side sees the rest of it)."""
    _three_estimators_agree(read_stage(_stage(((1.0, (0.0, 0.0, 0.0)), (0.7, (-1.0, 0.2, -1.5))), specular=specular)),
                            [CURVE_CUBIC] * 6)


def _three_estimators_agree(desc, kinds):
    """The stage reads without a warning, its surface lights are curve segments of `kinds` (SLI_CURVE), and light
    sampling alone, BSDF sampling alone and MIS agree within 1.5 % on the mean of the pixels that do not see the
    curves themselves (whose emission, seen from the camera, every strategy counts alike: it would dilute a bias)."""
    assert desc.warnings == []
    built = build(desc)
    try:
        tables = surface_lights(built.data, 0)
    finally:
        built.close()
    assert list(tables.sl_i[:, SLI_CURVE]) == kinds
    with Renderer(desc) as r:
        lit = _mean(r, 'mis', 16, 1, depth=0).mean(-1) < 0.5
        nee, bsdf, mis = (_mean(r, s, spp, seeds)[lit].mean() for s, spp, seeds in (('nee', 256, 4), ('bsdf', 1024, 2),
                                                                                  ('mis', 256, 2)))
    assert lit.mean() > 0.5 and mis > 0.05
    assert nee == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)
    assert bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def test_each_segment_is_its_own_light():
    """A hair-thin segment beside thick ones in one gprim: were a hit on a thick segment weighed as a sample of the
    thin one's light (its density there, its probability in the tree), MIS would lose most of what BSDF sampling
    finds on it."""
    desc = read_stage(_stage(widths=(0.01, 0.01, 0.01, 0.9, 0.9, 0.9, 0.9, 0.01, 0.01, 0.01, 0.01), specular=False))
    with Renderer(desc) as r:
        bsdf, mis = (_mean(r, s, spp) for s, spp in (('bsdf', 1024), ('mis', 256)))
    assert bsdf.mean() == pytest.approx(mis.mean(), rel=0.01), (bsdf.mean(), mis.mean())


# --------------------------------------------------------------------------- linear curves: their cones' sides
def test_a_linear_segments_side_drawn_by_light_samples_lies_on_embrees_cone():
    """A segment of radius 0.4 tapering to 0.15 over a length 2, placed by a rotation: the straight Bezier of its side
    (`cone_sides`) puts every point a light sample draws on the surface Embree intersects, with its normal (rays cast
    back along the normal from outside hit the point), and no light sample on the spheres of its ends; a segment with
    no side (one end's sphere holding the other's) has no area."""
    c, s = math.cos(0.6), math.sin(0.6)
    ends = np.array([[[-c, -s, 0.2, 0.4], [c, s, 0.2, 0.15]]])
    side = cone_sides(ends)[0]
    q = tuple(tuple(float(x) for x in row) for row in side)
    rng = np.random.default_rng(11)
    pts, nrm = [], []
    for u, a in rng.random((1500, 2)):
        p, n, jac = tube_point(*q, u, turn(a))
        assert jac > 0.0
        pts.append(p)
        nrm.append(n)
    pts, nrm = np.array(pts), np.array(nrm)
    curve = D.Curves('/c', vertices=np.array([[-1.0, 0, 0, 0.4], [1.0, 0, 0, 0.15]]), segments=np.array([0]),
                     linear=True, material=0, flags=np.zeros(1, np.uint8))
    m = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0.2], [0, 0, 0, 1]])
    hit, P, N = _cast([curve], pts + 3.0 * nrm, -nrm, matrix=m)
    assert hit.all()
    np.testing.assert_allclose(P, pts, atol=2e-5)
    np.testing.assert_allclose(N, nrm, atol=2e-5)
    axis = np.array([c, s, 0.0])
    foot = (pts - (0.0, 0.0, 0.2)) @ axis                  # the side ends before the end spheres' caps begin
    assert foot.min() > -1.0 + 0.4 * 0.125 - 1e-9 and foot.max() < 1.0 + 0.15 * 0.125 + 1e-9
    assert tube_areas(cone_sides(np.array([[[0, 0, 0, 1.0], [0.5, 0, 0, 0.2]]])))[0] == 0.0
    assert tube_areas(cone_sides(np.array([[[0, 0, 0, 0.3], [0, 0, 0, 0.3]]])))[0] == 0.0


def _linear_stage(points, widths):
    """An emissive linear curve (vertex widths) over the grey floor of `_stage`, under a dim dome."""
    st = _stage(placements=(), specular=False)
    tube = UsdGeom.BasisCurves.Define(st, '/World/Wire')
    tube.CreateTypeAttr('linear')
    tube.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    tube.CreateCurveVertexCountsAttr([len(points)])
    tube.CreateWidthsAttr(list(widths))
    tube.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    UsdShade.MaterialBindingAPI.Apply(tube.GetPrim()).Bind(UsdShade.Material.Get(st, '/World/Glow'))
    return st


@pytest.mark.parametrize('points, widths, caps', [
    (((-1.5, 0.8, 0.0), (-0.5, 1.4, 0.5), (0.5, 0.5, -0.5), (1.5, 1.0, 0.2), (2.0, 0.9, 1.0)),
     (0.2, 0.6, 0.3, 0.5, 0.1), 5),
    (((-0.6, 0.9, 0.0), (0.6, 0.9, 0.3)), (0.9, 0.3), 2),
    (((-0.6, 0.9, 0.0), (0.6, 0.9, 0.3)), (0.6, 0.0), 1)])
def test_light_sampling_and_bsdf_sampling_find_the_same_linear_curve_lights(points, widths, caps):
    """A bent wire of changing radius (four cones, round joints between cones of other slopes, round ends), one
    short thick cone whose round ends are 43 % of its area, and a cone tapering to a point (its tip no light): light
    samples draw the cones' sides and the ends' and joints' parts outside them, so light sampling alone, BSDF sampling
    alone and MIS converge to one image (a joint or an end weighed as a side's point, or drawn where it lies inside a
    cone, would bias light sampling or MIS away from BSDF sampling)."""
    _three_estimators_agree(read_stage(_linear_stage(points, widths)),
                            [CURVE_LINEAR] * (len(points) - 1) + [CURVE_CAP] * caps)


# --------------------------------------------------------------------------- linear curves: their ends and joints
def _ends(points, radii):
    """(1, n, 2, 4): the segments' ends (x, y, z, radius) of one linear curve through `points`."""
    v = np.column_stack([np.asarray(points, float), np.asarray(radii, float)])
    return np.stack([v[:-1], v[1:]], 1)[None]


def _inside_hull(x, seg):
    """Whether points x (k, 3) are strictly inside the round cone of segment seg (2, 4): min over t of
    |x - c(t)| - r(t) < 0, minimised in closed form (a convex function of t) - independent of `curve_caps`."""
    (p0, r0), (p1, r1) = (seg[0, :3], seg[0, 3]), (seg[1, :3], seg[1, 3])
    length = np.linalg.norm(p1 - p0)
    w = x - p0
    if length == 0.0:
        return np.linalg.norm(w, axis=1) - max(r0, r1) < 0.0
    d, s = (p1 - p0) / length, (r1 - r0) / length
    a = w @ d
    h = np.sqrt(np.maximum((w * w).sum(1) - a * a, 0.0))
    t = np.clip((a + s * h / math.sqrt(1.0 - s * s)) / length if abs(s) < 1.0 else np.where(s > 0, 1.0, 0.0), 0, 1)
    f = np.linalg.norm(x - (p0 + t[:, None] * length * d), axis=1) - (r0 + t * (r1 - r0))
    return f < -1e-9 * max(r0, r1)


def _exposed_area(ends, centre, radius, seen_from=None, n=100000):
    """The area of the sphere (centre, radius) outside every segment's round cone (with `seen_from`: the solid angle
    its part facing that point subtends there): a Fibonacci lattice of n points."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * k
    nrm = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    x = centre + radius * nrm
    out = np.ones(n, bool) if seen_from is None else ((seen_from - x) * nrm).sum(1) > 0.0
    for seg in ends[0]:
        out &= ~_inside_hull(x, seg)
    if seen_from is not None:
        v = seen_from - x
        out = out * (v * nrm).sum(1) / np.linalg.norm(v, axis=1) ** 3          # cos / d^2
    return 4.0 * math.pi * radius * radius * out.mean()


BENT = (((-1.5, 0.8, 0.0), (-0.5, 1.4, 0.5), (0.5, 0.5, -0.5), (1.5, 1.0, 0.2), (2.0, 0.9, 1.0)),
        (0.1, 0.3, 0.15, 0.25, 0.05))


@pytest.mark.parametrize('points, radii', [BENT, (((-0.6, 0.9, 0.0), (0.6, 0.9, 0.3)), (0.45, 0.15)),
                                           (((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 0.2, 0.1), (0, 0, 0)),
                                            (0.2, 0.3, 0.25, 0.1, 0.2))])
def test_the_lights_of_ends_and_joints_draw_what_the_cones_leave_of_their_spheres(points, radii):
    """A bent wire of changing radius, a thick cone, a closed loop (its first and last ends one joint): the points the
    kernel draws on a cap light (`_cap_point`) from inside its sphere (by area), weighed by the inverse of their
    density where they are past its planes, integrate to the area of its sphere outside every segment's round cone (an
    independent lattice and a closed-form distance to each cone) within 1 %; drawn in the cone of directions from a
    point outside (near and far), to the solid angle that area's part facing the point subtends there; the tree's
    share of each within 5 %."""
    ends = _ends(points, radii)
    spheres, planes, area, share, caps = round_caps(ends)
    assert caps.shape == (len(points) - 1, 2) and (caps >= 0).all()
    if np.array_equal(points[0], points[-1]):
        assert caps[0, 0] == caps[-1, 1] and spheres.shape[1] == len(points) - 1
    light = namedtuple('L', 'sl_f')(np.zeros((spheres.shape[1], SURFACE_LIGHT_F.width)))
    SURFACE_LIGHT_F.write_rows(light.sl_f, AREA=area[0], CENTER=spheres[0, :, :3], RADIUS=spheres[0, :, 3],
                               CTRL=planes[0].reshape(-1, 16))
    u = np.random.default_rng(3).random((400000, 2))
    for j in range(spheres.shape[1]):
        c, r = spheres[0, j, :3], spheres[0, j, 3]
        exact = _exposed_area(ends, c, r)
        q, nrm, w = _draw_caps(light, j, c, u)
        assert w.mean() == pytest.approx(exact, rel=0.01, abs=1e-3 * r * r)
        assert area[0, j] * share[j] == pytest.approx(exact, rel=0.05, abs=1e-2 * r * r)
        np.testing.assert_allclose(np.linalg.norm(q - c, axis=1), r, rtol=1e-12)
        np.testing.assert_allclose(q, c + r * nrm, atol=1e-12)
        a = planes[0, j, 0, :3]
        tilt = np.cross(a, (0.0, 0.6, 0.8) if abs(a[0]) > 0.5 else (1.0, 0.0, 0.0))
        for far in (1.3, 3.0, 200.0):                   # off the drawn cap's axis, towards its side
            p = c + far * r * (a + 0.7 * tilt / np.linalg.norm(tilt)) / math.sqrt(1.49)
            q, nrm, w = _draw_caps(light, j, p, u)
            v = p - q
            facing = (v * nrm).sum(1)
            assert (facing[w > 0] > 0.0).all()
            np.testing.assert_allclose(np.linalg.norm(q - c, axis=1), r, rtol=1e-9)
            solid = np.mean(w * facing / np.linalg.norm(v, axis=1) ** 3)
            assert solid == pytest.approx(_exposed_area(ends, c, r, p), rel=0.01)


@nb.njit
def _draw_caps(light, j, p, u):
    """`_cap_point` of cap light j seen from p at each (u1, u2) row of u: points, normals, and their weights (the
    inverse of their density per unit area, or 0)."""
    q, nrm, w = np.empty((len(u), 3)), np.empty((len(u), 3)), np.empty(len(u))
    for i in range(len(u)):
        x, n, w[i] = _cap_point(light, j, (p[0], p[1], p[2]), u[i, 0], u[i, 1])
        q[i, 0], q[i, 1], q[i, 2] = x
        nrm[i, 0], nrm[i, 1], nrm[i, 2] = n
    return q, nrm, w


def test_ends_and_joints_that_are_no_lights():
    """A straight capsule's joint lies inside its two cones (no light), its ends are half spheres (2 pi r^2); a
    segment whose one end's sphere holds the other's hides the smaller (no light) and leaves the larger whole; an end
    of radius 0 is no light."""
    spheres, planes, area, share, caps = round_caps(_ends(((0, 0, 0), (1, 0, 0), (2, 0, 0)), (0.3, 0.3, 0.3)))
    assert caps.tolist() == [[0, -1], [-1, 1]]
    np.testing.assert_allclose(area[0], 2 * math.pi * 0.09, rtol=1e-12)
    assert share.tolist() == [1.0, 1.0]
    spheres, planes, area, share, caps = round_caps(_ends(((0, 0, 0), (0.2, 0, 0)), (0.5, 0.1)))
    assert caps.tolist() == [[0, -1]] and spheres[0, 0, 3] == 0.5
    np.testing.assert_allclose(area[0], 4 * math.pi * 0.25, rtol=1e-12)
    assert round_caps(_ends(((0, 0, 0), (1, 0, 0)), (0.3, 0.0)))[4].tolist() == [[0, -1]]


def test_the_points_drawn_on_ends_and_joints_lie_on_embrees_surface():
    """A wire bent at 120 degrees, placed by a rotation: rays cast back along the normal of every point the kernel
    draws past its planes (from outside) hit Embree's round linear curve at that point, within 2e-5."""
    points = np.array([(-1.0, -0.6, 0.0), (0.0, 0.0, 0.0), (1.0, -0.6, 0.1)])
    radii = np.array([0.3, 0.4, 0.2])
    c, s = math.cos(0.6), math.sin(0.6)
    m = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0.2], [0, 0, 0, 1]])
    world = points @ m[:3, :3].T + m[:3, 3]
    spheres, planes, area, share, caps = round_caps(_ends(world, radii))
    assert spheres.shape[1] == 3
    light = namedtuple('L', 'sl_f')(np.zeros((3, SURFACE_LIGHT_F.width)))
    SURFACE_LIGHT_F.write_rows(light.sl_f, AREA=area[0], CENTER=spheres[0, :, :3], RADIUS=spheres[0, :, 3],
                               CTRL=planes[0].reshape(-1, 16))
    drawn = [_draw_caps(light, j, spheres[0, j, :3], np.random.default_rng(5).random((500, 2))) for j in range(3)]
    pts = np.concatenate([q[w > 0] for q, _, w in drawn])
    nrm = np.concatenate([n[w > 0] for _, n, w in drawn])
    assert len(pts) > 500
    curve = D.Curves('/c', vertices=np.column_stack([points, radii]), segments=np.array([0, 1]), linear=True,
                     material=0, flags=np.array([2, 1], np.uint8))
    hit, P, N = _cast([curve], pts + 3.0 * nrm, -nrm, matrix=m)
    assert hit.all()
    np.testing.assert_allclose(P, pts, atol=2e-5)
    np.testing.assert_allclose(N, nrm, atol=2e-5)


def test_every_placement_of_a_gprim_has_its_caps_turned_with_it():
    """Two placements of the bent wire (as is; turned, scaled 1.7 and moved) give, together, what each gives alone:
    the same spheres placed, the planes turned, the areas scaled by 1.7^2, the same shares and the same lights."""
    ends = _ends(*BENT)[0]
    c, s = math.cos(0.7), math.sin(0.7)
    placed = ends.copy()
    placed[..., :3] = ends[..., :3] @ (1.7 * np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])).T + (1.0, 2.0, 3.0)
    placed[..., 3] *= 1.7
    both = round_caps(np.stack([ends, placed]))
    for k, alone in enumerate((round_caps(ends[None]), round_caps(placed[None]))):
        for x, y in zip(both[:3], alone[:3]):
            np.testing.assert_allclose(x[k], y[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(both[3], alone[3], rtol=1e-12)
        assert both[4].tolist() == alone[4].tolist()
    np.testing.assert_allclose(both[2][1], 1.7 ** 2 * both[2][0], rtol=1e-12)
