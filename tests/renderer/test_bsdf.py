"""The path integrator's BSDFs (renderer/kernel/bsdf.py): pdfs that integrate to what the sampler
produces, sampled directions distributed as the pdf says (chi-square), sampling weights whose mean
is the albedo computed by quadrature, energy <= 1, reciprocity, Fresnel-chosen dielectric lobes."""
import math

import numba as nb
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.kernel import bsdf as B

BLACK = (0.0, 0.0, 0.0)
WHITE = (1.0, 1.0, 1.0)


def preview(kd=(0.8, 0.8, 0.8), f0=(0.04, 0.04, 0.04), f90=WHITE, rough=0.5, cc=0.0, cc_rough=0.1):
    return B.preview_bsdf(kd, f0, f90, rough * rough, cc, cc_rough * cc_rough)


def course(model, kd=(0.5, 0.5, 0.5), ks=(0.4, 0.4, 0.4), exp=20.0, m=0.3, rough=0.0, ior=1.5, front=True,
           cool=(0.1, 0.1, 0.5)):
    return B.course_bsdf(model, kd, ks, exp, m, rough, ior, front, cool)


CASES = {
    'lambert': course(D.LAMBERTIAN),
    'blinn_phong': course(D.BLINN_PHONG),
    'blinn_phong_sharp': course(D.BLINN_PHONG, exp=200.0),
    'glossy_mirrored': course(D.BLINN_PHONG_MIRRORED, rough=0.4),
    'cool_to_warm': course(D.COOL_TO_WARM, kd=(0.9, 0.8, 0.3)),
    'plastic': preview(rough=0.5),
    'plastic_rough': preview(rough=0.9),
    'metal': preview(kd=BLACK, f0=(0.9, 0.6, 0.3), rough=0.4),
    'clearcoat': preview(kd=(0.2, 0.3, 0.8), rough=0.7, cc=1.0, cc_rough=0.4),
}
ANGLES = (0.95, 0.5, 0.15)          # cos_o


def wo_of(c):
    return (math.sqrt(1.0 - c * c), 0.0, c)


@nb.njit(cache=False)
def _draw(b, wo, n, seed):
    np.random.seed(seed)
    wi = np.zeros((n, 3))
    w = np.zeros((n, 3))
    pdf = np.zeros(n)
    delta = np.zeros(n, np.bool_)
    for i in range(n):
        d, wt, p, dl = B.sample(b, wo, np.random.random(), np.random.random(), np.random.random())
        wi[i, 0], wi[i, 1], wi[i, 2] = d
        w[i, 0], w[i, 1], w[i, 2] = wt
        pdf[i] = p
        delta[i] = dl
    return wi, w, pdf, delta


@nb.njit(cache=False)
def _grid(b, wo, nt, nphi):
    """f cos and pdf on a midpoint grid of (cos_theta, phi) over the upper hemisphere (equal solid angle)."""
    f = np.zeros((nt, nphi, 3))
    pdf = np.zeros((nt, nphi))
    for i in range(nt):
        ct = (i + 0.5) / nt
        st = math.sqrt(1.0 - ct * ct)
        for j in range(nphi):
            ph = 2.0 * math.pi * (j + 0.5) / nphi
            c, p = B.evaluate(b, wo, (st * math.cos(ph), st * math.sin(ph), ct))
            f[i, j, 0], f[i, j, 1], f[i, j, 2] = c
            pdf[i, j] = p
    return f, pdf


def quadrature(b, wo, nt=1024, nphi=512):
    f, pdf = _grid(b, wo, nt, nphi)
    dw = 2.0 * np.pi / (nt * nphi)
    return f.sum((0, 1)) * dw, pdf.sum() * dw, f, pdf


@pytest.mark.parametrize('name', CASES)
@pytest.mark.parametrize('cos_o', ANGLES)
def test_pdf_integrates_to_the_fraction_of_non_delta_samples(name, cos_o):
    b = CASES[name]
    _, integral, _, _ = quadrature(b, wo_of(cos_o))
    wi, w, pdf, delta = _draw(b, wo_of(cos_o), 200000, 1)
    produced = np.mean((pdf > 0) & ~delta)
    assert integral == pytest.approx(produced, abs=0.01), (integral, produced)
    assert integral <= 1.0 + 2e-3


@pytest.mark.parametrize('name', ['lambert', 'blinn_phong', 'glossy_mirrored', 'plastic', 'metal', 'clearcoat'])
def test_sampled_directions_follow_the_pdf_chi_square(name):
    b = CASES[name]
    wo = wo_of(0.6)
    nt, nphi, n = 16, 32, 100000
    _, _, _, pdf = quadrature(b, wo, nt * 32, nphi * 16)
    expected = pdf.reshape(nt, 32, nphi, 16).sum((1, 3)) * (2.0 * np.pi / (nt * 32 * nphi * 16)) * n
    wi, _, p, delta = _draw(b, wo, n, 7)
    ok = (p > 0) & ~delta
    ti = np.minimum((wi[ok, 2] * nt).astype(int), nt - 1)
    pj = np.minimum(((np.arctan2(wi[ok, 1], wi[ok, 0]) % (2 * np.pi)) / (2 * np.pi) * nphi).astype(int), nphi - 1)
    observed = np.zeros((nt, nphi))
    np.add.at(observed, (ti, pj), 1)
    keep = expected > 5
    # pool the sparse cells into one
    obs = np.append(observed[keep], observed[~keep].sum())
    exp = np.append(expected[keep], expected[~keep].sum())
    exp *= obs.sum() / exp.sum()
    chi2 = ((obs - exp) ** 2 / np.maximum(exp, 1e-9)).sum()
    k = len(obs) - 1
    # Wilson-Hilferty: (chi2/k)^(1/3) is normal with mean 1 - 2/(9k), variance 2/(9k); z < 4 ~ p > 3e-5
    z = ((chi2 / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k))
    assert z < 4.0, (chi2, k, z)


@pytest.mark.parametrize('name', CASES)
@pytest.mark.parametrize('cos_o', ANGLES)
def test_mean_sample_weight_is_the_quadrature_albedo(name, cos_o):
    b = CASES[name]
    albedo, _, _, _ = quadrature(b, wo_of(cos_o))
    _, w, pdf, delta = _draw(b, wo_of(cos_o), 200000, 3)
    mc = np.where(delta[:, None], 0.0, w).mean(0)
    sd = np.where(delta[:, None], 0.0, w).std(0) / np.sqrt(len(w))
    assert np.all(np.abs(mc - albedo) < 5 * sd + 2e-3), (mc, albedo, sd)


@pytest.mark.parametrize('name', CASES)
@pytest.mark.parametrize('cos_o', ANGLES)
def test_white_furnace_energy_at_most_one(name, cos_o):
    b = CASES[name]._replace(kd=WHITE) if name in ('lambert', 'plastic', 'plastic_rough', 'clearcoat') else CASES[name]
    if name == 'metal':
        b = b._replace(f0=WHITE)
    albedo, _, _, _ = quadrature(b, wo_of(cos_o))
    _, w, _, delta = _draw(b, wo_of(cos_o), 100000, 5)
    total = w.mean(0)          # delta and non-delta lobes together
    assert np.all(albedo <= 1.0 + 2e-3), albedo
    assert np.all(total <= 1.0 + 0.01), total
    if name == 'lambert':
        assert albedo == pytest.approx([1.0] * 3, abs=2e-3)


@pytest.mark.parametrize('name', CASES)
def test_reciprocity(name):
    b = CASES[name]
    rng = np.random.default_rng(4)
    for _ in range(200):
        a, c = rng.normal(size=3), rng.normal(size=3)
        a[2], c[2] = abs(a[2]), abs(c[2])
        a /= np.linalg.norm(a)
        c /= np.linalg.norm(c)
        f1, _ = B.evaluate(b, tuple(a), tuple(c))
        f2, _ = B.evaluate(b, tuple(c), tuple(a))
        np.testing.assert_allclose(np.array(f1) / c[2], np.array(f2) / a[2], rtol=1e-9, atol=1e-12)


def _textbook(b, wo, wi):
    """f cos_i and the mixture pdf of b in the textbook form, in extended precision (numpy longdouble):
    the normalised half vector h, D(h) = a^2 / (pi (cos_h^2 (a^2 - 1) + 1)^2), Smith's Lambda from tan^2,
    height-correlated G2 = 1 / (1 + Lambda_o + Lambda_i), the visible-normal pdf G1(wo) D / (4 cos_o) (Heitz
    2018, eq. 17 with the reflection's Jacobian); the lobe probabilities are the BSDF's own."""
    X = np.longdouble
    wo, wi = np.array(wo, X), np.array(wi, X)
    co, ci = wo[2], wi[2]
    h = (wo + wi) / np.sqrt(np.sum((wo + wi) ** 2))
    vh = np.sum(wo * h)
    pi = X(np.pi)

    def schlick(f0, f90, c):
        return X(f0) + (X(f90) - X(f0)) * (1 - c) ** 5

    def lam(c, a):
        return (np.sqrt(1 + X(a) ** 2 * (1 - c * c) / (c * c)) - 1) / 2

    def ggx(a):                                  # (D G2 / (4 co ci), pdf)
        a2 = X(a) ** 2
        d = a2 / (pi * (h[2] ** 2 * (a2 - 1) + 1) ** 2)
        return d / (1 + lam(co, a) + lam(ci, a)) / (4 * co * ci), d / (1 + lam(co, a)) / (4 * co)

    fo = [schlick(b.f0[k], b.f90[k], co) for k in range(3)]
    p = B.lobe_probabilities(b, float(co), tuple(float(x) for x in fo) if b.alpha > 0 else B.BLACK)
    f = np.zeros(3, X)
    pdf = X(p[B.L_DIFFUSE]) * ci / pi
    for k in range(3):
        if b.coupled:
            f[k] = X(b.kd[k]) * (1 - fo[k]) * (1 - schlick(b.f0[k], b.f90[k], ci)) / pi
        else:
            f[k] = X(b.kd[k]) / pi
    if b.alpha > 0:
        s, ps = ggx(b.alpha)
        f += np.array([schlick(b.f0[k], b.f90[k], vh) for k in range(3)]) * s
        pdf += X(p[B.L_GGX]) * ps
    if b.cc > 0:
        s, ps = ggx(b.cc_alpha)
        f = f * (1 - X(b.cc) * schlick(0.04, 1, co)) * (1 - X(b.cc) * schlick(0.04, 1, ci)) \
            + X(b.cc) * schlick(0.04, 1, vh) * s
        pdf += X(p[B.L_CLEARCOAT]) * ps
    if b.exp >= 0:
        dh = (X(b.exp) + 1) / (2 * pi) * h[2] ** X(b.exp)
        f += np.array(b.ks, X) * dh / (4 * vh * max(ci, co))
        pdf += X(p[B.L_PHONG]) * dh / (4 * vh)
    return f * ci, pdf


@pytest.mark.parametrize('name', ['plastic', 'plastic_rough', 'metal', 'clearcoat', 'blinn_phong', 'glossy_mirrored',
                                  'mirror_like'])
def test_evaluate_is_the_textbook_microfacet_form(name):
    """`evaluate`'s microfacet terms (no normalised half vector: one square root and one division for D,
    G2 and the pdf) equal the textbook form to 1e-9 relative, at random directions, grazing ones (cos
    1e-4) and directions within 1e-5 rad of the mirror direction (where D peaks: alpha 1e-4 for
    'mirror_like')."""
    b = preview(kd=(0.3, 0.5, 0.2), f0=(0.9, 0.6, 0.3), rough=0.01) if name == 'mirror_like' else CASES[name]
    rng = np.random.default_rng(21)
    pairs = []
    for _ in range(300):
        a, c = rng.normal(size=3), rng.normal(size=3)
        a[2], c[2] = abs(a[2]), abs(c[2])
        pairs.append((a / np.linalg.norm(a), c / np.linalg.norm(c)))
    for cz in (1e-4, 1e-2, 0.3):                  # grazing wo and wi
        for phi in rng.uniform(0, 2 * np.pi, 20):
            a = np.array([math.sqrt(1 - cz * cz) * math.cos(phi), math.sqrt(1 - cz * cz) * math.sin(phi), cz])
            pairs += [(a, c) for c in (a * [1, -1, 1], a * [-1, -1, 1], np.array([0.0, 0.6, 0.8]))]
    for c in (0.99, 0.7, 0.2):                     # near the mirror direction
        wo = np.array(wo_of(c))
        for eps in (0.0, 1e-7, 1e-5):
            wi = np.array([-wo[0] * math.cos(eps), math.sin(eps), 0.0])
            wi[2] = math.sqrt(1 - wi[0] ** 2 - wi[1] ** 2)
            pairs.append((wo, wi))
    for wo, wi in pairs:
        f, pdf = B.evaluate(b, tuple(wo), tuple(wi))
        fr, pr = _textbook(b, wo, wi)
        np.testing.assert_allclose(f, fr.astype(float), rtol=1e-9, atol=1e-300, err_msg=str((wo, wi)))
        assert pdf == pytest.approx(float(pr), rel=1e-9), (wo, wi, pdf, pr)


def test_lambert_is_albedo_over_pi():
    f, pdf = B.evaluate(course(D.LAMBERTIAN, kd=(0.2, 0.4, 0.6)), wo_of(0.3), (0.0, 0.6, 0.8))
    np.testing.assert_allclose(f, np.array([0.2, 0.4, 0.6]) / np.pi * 0.8)
    assert pdf == pytest.approx(0.8 / np.pi)


@pytest.mark.parametrize('name', CASES)
@pytest.mark.parametrize('cos_o', ANGLES)
def test_a_sample_reports_what_evaluate_gives_for_its_direction(name, cos_o):
    """The weight and pdf `sample` returns for a non-delta direction are f cos / pdf and pdf of the whole
    mixture at that direction, as `evaluate` computes them (Lambert alone takes a shortcut: weight kd)."""
    b = CASES[name]
    wo = wo_of(cos_o)
    wi, w, pdf, delta = _draw(b, wo, 2000, 11)
    checked = 0
    for k in range(len(wi)):
        if delta[k] or pdf[k] == 0.0:
            continue
        f, p = B.evaluate(b, wo, tuple(wi[k]))
        assert pdf[k] == pytest.approx(p, rel=1e-12), (k, pdf[k], p)
        np.testing.assert_allclose(w[k], np.array(f) / p, rtol=1e-12)
        checked += 1
    assert checked > 1000


def test_ggx_visible_normal_pdf_is_normalised_over_the_sphere():
    """Integral over all of h of D(h) G1(wo) max(0, wo.h) / cos_o = 1 (Heitz 2018, eq. 2)."""
    for alpha in (0.05, 0.3, 0.8):
        for c in ANGLES:
            wo = wo_of(c)
            n = 4000
            ct = (np.arange(n) + 0.5) / n                        # h in the upper hemisphere only
            tot = 0.0
            for ph in np.linspace(0, 2 * np.pi, 256, endpoint=False) + np.pi / 256:
                h = np.stack([np.sqrt(1 - ct ** 2) * np.cos(ph), np.sqrt(1 - ct ** 2) * np.sin(ph), ct], 1)
                vh = np.maximum(h @ np.array(wo), 0.0)
                a2 = alpha * alpha
                d = a2 / (np.pi * (ct ** 2 * (a2 - 1) + 1) ** 2)
                tot += np.sum(d * vh) / (1 + B.smith_lambda(c, alpha)) / c
            tot *= 2 * np.pi / (n * 256)
            assert tot == pytest.approx(1.0, abs=0.01 if alpha < 0.1 else 2e-3), (alpha, c, tot)


@pytest.mark.parametrize('front', [True, False])
def test_dielectric_reflects_with_the_fresnel_probability(front):
    b = course(D.DIELECTRIC, ior=1.5, front=front)
    c = 0.9                              # inside the glass: below the critical angle
    wi, w, pdf, delta = _draw(b, wo_of(c), 100000, 9)
    assert delta.all() and (pdf == 0).all()
    eta = 1.5 if front else 1 / 1.5
    ct = math.sqrt(1 - (1 - c * c) / eta ** 2)
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    F = 0.5 * (rs * rs + rp * rp)
    refl = wi[:, 2] > 0
    assert refl.mean() == pytest.approx(F, abs=4 * math.sqrt(F * (1 - F) / len(wi)))
    np.testing.assert_allclose(w[~refl], 1 / eta ** 2)
    # Snell's law on the refracted directions
    sin_t = np.hypot(wi[~refl, 0], wi[~refl, 1])
    np.testing.assert_allclose(sin_t, math.sqrt(1 - c * c) / eta, rtol=1e-12)


def test_course_colours_above_one_are_scaled_to_conserve_energy():
    b = course(D.BLINN_PHONG, kd=(0.9, 0.9, 0.9), ks=(0.6, 0.6, 0.6))
    assert b.kd[0] + b.ks[0] == pytest.approx(1.0)
    assert b.kd[0] / b.ks[0] == pytest.approx(1.5)
