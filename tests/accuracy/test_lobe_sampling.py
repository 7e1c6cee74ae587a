"""Rect and disk lights' samples drawn towards a glossy vertex's GGX lobe (`kernel/lobe_sampling.py`,
`light_sampling.sample_ld_lobe`): the truncated Cauchy distributions are sampled as their density says,
however far their centre lies outside the light; the strategy's pdf is a density over the light's solid
angle (E[1 / pdf], over the samples that land on the light, = its solid angle: the rect's by Van Oosterom
and Strackee's formula, the disk's by integrating cos / d^2 over it); and a
BSDF-sampled ray that meets the light is weighed by the same pdf as the light sample that drew its point
(`shape_emission`: the two MIS weights sum to 1)."""
import math

import numba as nb
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.light_selection import path_lights
from rtc.renderer.kernel import lobe_sampling as R
from rtc.renderer.kernel.bsdf import preview_bsdf, seen_from
from rtc.renderer.kernel.integrator import new_tile_lights
from rtc.renderer.kernel.light_sampling import hit_shape, light_window, sample_ld_lobe, shape_emission
from rtc.renderer.kernel.light_tree import light_pmf
from rtc.renderer.kernel.records import Vertex
from rtc.renderer.kernel.tables import LF_M, LF_RAD
from tests.renderer.handmade import look_at, quad, rect_light, scene

CENTRE = np.array([0.0, 3.0, -5.0])            # the light's centre (rect and disk emitting along -Y)
W, H = 2.0, 1.0                                 # the rect's sides
R_DISK = 0.8


@pytest.mark.parametrize('x0, s, half', [(0.3, 0.05, 1.0), (5.0, 0.02, 1.0), (0.0, 1e-3, 1.0), (0.9, 1e-4, 1.0),
                                         (1e6, 0.01, 0.5), (-1e9, 1e-3, 0.5), (-0.2, 3.0, 1.0)])
def test_the_truncated_cauchy_is_sampled_as_its_density_says(x0, s, half):
    """The samples' CDF at five points, and the density there, equal those of g(x) = 1 / (1 + ((x - x0) / s)^2)
    normalised over [-half, half] by the trapezoid rule on a grid dense where g varies (not by the arctangents
    `lobe_sampling` uses)."""
    cw = R._cauchy.py_func(x0, s, half)
    u = (np.arange(20000) + 0.5) / 20000
    xs = np.array([R.cauchy_sample.py_func(cw, v) for v in u])
    assert xs.min() >= -half and xs.max() <= half
    grid = np.linspace(-half, half, 400001)
    near = x0 + s * np.tan(np.linspace(-1.55, 1.55, 200001))
    grid = np.unique(np.concatenate([grid, near[(near > -half) & (near < half)]]))
    g = 1.0 / (1.0 + ((grid - x0) / s) ** 2)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(grid))])
    total = cum[-1]
    for m in np.linspace(-0.8, 0.8, 5) * half:
        assert (xs < m).mean() == pytest.approx(np.interp(m, grid, cum) / total, abs=2e-4), m
        dens = 1.0 / (1.0 + ((m - x0) / s) ** 2) / total
        assert R.cauchy_pdf.py_func(cw, m) == pytest.approx(dens, rel=1e-4), m


def solid_angle(p, corners):
    """Solid angle of the planar quad `corners` seen from p: two triangles by Van Oosterom and Strackee."""
    total = 0.0
    for tri in ((0, 1, 2), (0, 2, 3)):
        r = [np.asarray(corners[i]) - p for i in tri]
        n = [np.linalg.norm(v) for v in r]
        num = abs(np.dot(r[0], np.cross(r[1], r[2])))
        den = n[0] * n[1] * n[2] + np.dot(r[0], r[1]) * n[2] + np.dot(r[0], r[2]) * n[1] + np.dot(r[1], r[2]) * n[0]
        total += 2.0 * math.atan2(num, den)
    return total


def light(kind):
    if kind == 'rect':
        return rect_light(tuple(CENTRE), W, H, (5.0,) * 3)
    m = rect_light(tuple(CENTRE), 1.0, 1.0, (5.0,) * 3).matrix
    return D.Light(path='/disk', type=D.DISK, matrix=m, radiance=(5.0,) * 3, radius=R_DISK)


@pytest.fixture(scope='module', params=['rect', 'disk'])
def lit(request):
    desc = scene([D.Container('/', meshes=[quad(20.0)])], [D.Material('/m')], [light(request.param)],
                 D.Camera(path='/cam', matrix=look_at((0.0, 2.0, 6.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:
        yield built.data, L, request.param
    finally:
        built.close()


def solid_angle_of(kind, p):
    """The light's solid angle seen from p, by a method of its own."""
    c = CENTRE
    if kind == 'rect':
        return solid_angle(p, [c + (-W / 2, 0, -H / 2), c + (W / 2, 0, -H / 2), c + (W / 2, 0, H / 2),
                               c + (-W / 2, 0, H / 2)])
    n_r, n_t = 1500, 3000                       # the disk: cos / d^2 over its area, by the midpoint rule
    r = (np.arange(n_r) + 0.5) / n_r * R_DISK
    t = (np.arange(n_t) + 0.5) / n_t * 2.0 * math.pi
    rr, tt = np.meshgrid(r, t, indexing='ij')
    q = np.stack([c[0] + rr * np.cos(tt), np.full_like(rr, c[1]), c[2] + rr * np.sin(tt)], -1) - p
    d2 = np.sum(q * q, -1)
    cos = q[..., 1] / np.sqrt(d2)
    return float(np.sum(cos / d2 * rr) * (R_DISK / n_r) * (2.0 * math.pi / n_t))


def vertex(S, p_world, aim_world, alpha, metallic):
    """(Vertex, Seen) of a floor point (normal +Y) whose GGX lobe's mirror direction points at aim_world, in
    the kernels' camera-relative frame (the light's centre read back from its table row)."""
    shift = np.array([S.li_f[0, LF_M + 3], S.li_f[0, LF_M + 7], S.li_f[0, LF_M + 11]]) - CENTRE
    p = np.asarray(p_world, np.float64) + shift
    r = np.asarray(aim_world, np.float64) - np.asarray(p_world, np.float64)
    r /= np.linalg.norm(r)
    n = np.array([0.0, 1.0, 0.0])
    wo = 2.0 * np.dot(r, n) * n - r                        # r mirrored about n
    tt, bb = (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)              # (tt, bb, n) right-handed
    wl = (float(np.dot(wo, tt)), float(np.dot(wo, bb)), float(wo[1]))
    diff = (0.0, 0.0, 0.0) if metallic else (0.5, 0.5, 0.5)
    f0 = (0.9, 0.7, 0.3) if metallic else (0.04, 0.04, 0.04)
    b = preview_bsdf(diff, f0, (1.0, 1.0, 1.0), alpha, 0.0, 1e-6)
    pt = tuple(float(x) for x in p)
    sb = seen_from(b, wl)
    lobe = R.glossy_lobe(sb, (tt, bb, (0.0, 1.0, 0.0)))
    vtx = Vertex(pt, (0.0, 1.0, 0.0), (0.0, 1.0, 0.0), tt, bb, wl, pt, 0.0, (1.0, 1.0, 1.0), 0, lobe)
    return vtx, sb, shift


CASES = {           # (floor point, where the lobe's mirror direction aims, alpha, metallic)
    'inside, near': ((0.3, 0.0, -4.0), (0.2, 3.0, -5.1), 0.0225, True),
    'edge, near': ((0.3, 0.0, -4.0), (1.0, 3.0, -5.2), 0.0225, True),
    'edge, sharp': ((0.3, 0.0, -4.0), (-0.3, 3.0, -4.5), 0.01, True),
    'just outside': ((0.3, 0.0, -4.0), (1.3, 3.0, -5.0), 0.0225, True),
    'outside the disk': ((0.3, 0.0, -4.0), (0.95, 3.0, -5.0), 0.0225, True),
    'far outside': ((0.3, 0.0, -4.0), (9.0, 3.0, -5.0), 0.0625, True),
    'edge, far from the light': ((1.0, 0.0, 9.0), (-1.0, 3.0, -5.45), 0.0225, True),
    'rough, far': ((-3.0, 0.0, 6.0), (0.0, 3.0, -5.0), 0.25, True),
    'grazing': ((0.3, 0.0, -4.0), (0.2, 3.0, -30.0), 0.0225, True),
}


@nb.njit
def mean_inverse_pdf(S, L, vtx, sb, n):
    """(mean of 1 / pdf over n x n stratified samples of light 0, a sample of no light counting 0; the number
    of those).  (Where a disk's edge cuts the strata, the mean's error falls as 1 / n: 160 x 160 samples
    were 2.9 % off on the sharpest lobe, 640 x 640 0.56 %.)"""
    total = 0.0
    lost = 0
    for i in range(n):
        for j in range(n):
            pdf = sample_ld_lobe(S, L, 0, vtx, ((i + 0.5) / n, (j + 0.5) / n))[3]
            if pdf > 0.0:
                total += 1.0 / pdf
            else:
                lost += 1
    return total / (n * n), lost


# the cases whose lobe is narrower than the disk's radius and meets it (the rect takes the strategy in all)
ROUND = {'inside, near', 'edge, near', 'edge, sharp', 'outside the disk'}


@pytest.mark.parametrize('case', CASES)
def test_the_lobe_pdf_is_a_density_over_the_lights_solid_angle(lit, case):
    """E[1 / pdf] over stratified samples (a sample that falls outside a disk counting 0) equals the light's
    solid angle (an independent formula): the pdf that weighs the light sample is the density it is drawn
    from (a wrong one biases the light)."""
    S, L, kind = lit
    p_world, aim, alpha, metallic = CASES[case]
    vtx, sb, shift = vertex(S, p_world, aim, alpha, metallic)
    lobe = R.glossy_lobe(sb, (vtx.tt, vtx.bb, vtx.ns))
    assert lobe[4] == 1.0 and lobe[3] == pytest.approx(2 * alpha)
    used = light_window(S, 0, vtx.p, lobe)[0][0]
    assert used == (kind == 'rect' or case in ROUND), (kind, case)
    mean, lost = mean_inverse_pdf(S, L, vtx, sb, 1000)
    assert lost == 0 or (used and kind != 'rect')
    omega = solid_angle_of(kind, np.asarray(p_world, np.float64))
    assert mean == pytest.approx(omega, rel=0.01), (case, mean, omega)


@pytest.mark.parametrize('case', CASES)
def test_a_bsdf_ray_meeting_the_light_is_weighed_by_the_light_samples_pdf(lit, case):
    """For each light sample, a ray from the vertex along its direction meets the light (`hit_shape`) at
    its distance, and the emission `shape_emission` gives that ray, when the BSDF drew it with the light
    sample's pdf, is half the light's radiance: it weighs the ray by the light sample's pdf, and the two
    strategies' MIS weights sum to 1."""
    S, L, kind = lit
    p_world, aim, alpha, metallic = CASES[case]
    vtx, sb, _ = vertex(S, p_world, aim, alpha, metallic)
    lobe = R.glossy_lobe(sb, (vtx.tt, vtx.bb, vtx.ns))
    pmf = light_pmf(L, vtx.p, vtx.ns, 0)
    rng = np.random.default_rng(5)
    met = 0
    for u in rng.random((300, 2)):
        wi, dist, Le, pdf, delta = sample_ld_lobe(S, L, 0, vtx, (float(u[0]), float(u[1])))
        if not pdf > 0.0:
            continue
        t, pu = hit_shape(S, L, 0, vtx.p, wi, math.inf, vtx.p)
        assert t == pytest.approx(dist, rel=1e-9)
        pb = pmf * pdf
        e = shape_emission(S, L, 0, (vtx.p, wi), t, (vtx.p, vtx.ns, pb, 0, lobe, (-1.0, -1.0, -1.0), False),
                           new_tile_lights())
        assert e[0] == pytest.approx(0.5 * S.li_f[0, LF_RAD], rel=1e-6)
        met += 1
    assert met > 50


def test_no_lobe_no_change(lit):
    """A plastic (its GGX lobe less than half its albedo), or a GGX lobe wider than LOBE_ALPHA_MAX, has no
    lobe strategy: its light samples are `sample_ld`'s."""
    S, L, _ = lit
    from rtc.renderer.kernel.light_sampling import sample_ld
    for alpha, metallic in ((0.01, False), (0.3, False), (0.3, True), (1.0, True)):
        vtx, sb, _ = vertex(S, (0.3, 0.0, -4.0), (0.2, 3.0, -5.1), alpha, metallic)
        assert R.glossy_lobe(sb, (vtx.tt, vtx.bb, vtx.ns))[4] == 0.0
        for u in ((0.1, 0.2), (0.7, 0.9)):
            assert sample_ld_lobe(S, L, 0, vtx, u) == sample_ld(S, L, 0, vtx.p, vtx.ns, u[0], u[1])
