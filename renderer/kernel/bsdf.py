"""BSDFs of the path integrator: sample a direction, evaluate, report the pdf.

One record, `Bsdf`, holds a mixture of lobes in the local shading frame (z = shading normal on the
viewer's side); every material model sets the lobes it has and zeroes the others:

* diffuse      Lambert, albedo `kd`; with `coupled` (UsdPreviewSurface) scaled by
               (1 - F(cos_o)) (1 - F(cos_i)) per channel so that diffuse + specular stays <= 1 and the
               BSDF stays reciprocal (symmetric in wo, wi);
* gooch        (cool-to-warm) diffuse whose colour blends from `cool` to `kd` (warm) by
               (1 + cos_i)(1 + cos_o) / 4: the course's tone ramp made symmetric;
* ggx          GGX microfacet reflection, alpha = roughness^2, Schlick Fresnel F0 = `f0`, F90 = `f90`,
               height-correlated Smith masking-shadowing; sampled from the distribution of visible
               normals (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4));
* clearcoat    a second, white GGX layer (F0 = 0.04) of weight `cc`; the layers below are scaled by
               (1 - cc F_c(cos_o)) (1 - cc F_c(cos_i));
* phong        the course's Blinn-Phong highlight as a microfacet lobe: D(h) = (e + 1)/(2 pi) cos^e(h),
               f = ks D / (4 (wo.h) max(cos_i, cos_o)), whose albedo is <= ks for every wo and whose
               sampling weight is ks cos_i / max(cos_i, cos_o) <= ks;
* mirror       perfect reflection of colour `mirror` (a delta lobe);
* dielectric   smooth dielectric of relative index `eta` (= n_t / n_i seen from the viewer's side):
               Fresnel-chosen delta reflection or refraction (radiance scaled by 1 / eta^2).

Lobes are chosen by their estimated albedo at wo; the pdf of a non-delta direction is the mixture
sum_l P(l) pdf_l(wi), so `sample` returns f cos / pdf of the whole non-delta BSDF.

A path vertex evaluates its BSDF for every light sample and once more for its BSDF sample, always from
the same wo: `seen_from(b, wo)` computes what depends on wo alone once (the lobe probabilities, Schlick's
F(cos_o), the Smith terms of wo), and `evaluate_seen`, `sample_seen` take that record.  The microfacet
terms are computed without normalising the half vector (`_microfacet`): one square root and one
division for D, G2 and the pdf together, where the textbook form takes four of each (the path
integrator's shading is bound by the latency of square roots and divisions).  `evaluate(b, wo, wi)` and
`sample(b, wo, ...)` are the same on a `Bsdf` and one direction.
"""
import math
from collections import namedtuple

import numba as nb

from .. import description as D
from .features import (B_BLINN_PHONG, B_BLINN_PHONG_MIRRORED, B_COOL_TO_WARM, B_DIELECTRIC, B_GLAZE, B_LAMBERTIAN,
                       B_MIRROR, B_MIRRORING, B_PHONG, B_GGX, B_PREVIEW_SURFACE, F_CLEARCOAT, F_MODELS)
from .jit import SHADING_INLINE_JIT as _JIT
from .vecmath import turn

Bsdf = namedtuple('Bsdf', ['kd', 'coupled', 'cool', 'gooch', 'f0', 'f90', 'alpha', 'cc', 'cc_alpha',
                           'ks', 'exp', 'mirror', 'eta'])
# A Bsdf seen from wo (`seen_from`): b, wo, p the lobe probabilities at wo, fo Schlick's F(cos_o) rgb (the
# coupled diffuse's), g and gc the `_smith_o` terms of wo for the GGX and the clearcoat lobe.
Seen = namedtuple('Seen', ['b', 'wo', 'p', 'fo', 'g', 'gc'])
# lobes (index into the probabilities returned by `lobe_probabilities`)
L_DIFFUSE, L_GGX, L_CLEARCOAT, L_PHONG, L_MIRROR, L_DIELECTRIC = range(6)
N_LOBES = 6
BLACK = (0.0, 0.0, 0.0)
MIN_ALPHA = 1e-4          # roughness 0.01: below it GGX's D overflows nothing but stops being sampled usefully
CC_F0 = 0.04


@nb.njit(**_JIT)
def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


@nb.njit(**_JIT)
def schlick(f0, f90, c):
    x = 1.0 - min(max(c, 0.0), 1.0)
    x2 = x * x
    return f0 + (f90 - f0) * (x2 * x2 * x)


@nb.njit(**_JIT)
def schlick3(f0, f90, c):
    return schlick(f0[0], f90[0], c), schlick(f0[1], f90[1], c), schlick(f0[2], f90[2], c)


@nb.njit(**_JIT)
def smith_lambda(cos_t, alpha):
    c2 = cos_t * cos_t
    if c2 >= 1.0:
        return 0.0
    t2 = (1.0 - c2) / max(c2, 1e-300)
    return 0.5 * (math.sqrt(1.0 + alpha * alpha * t2) - 1.0)


@nb.njit(**_JIT)
def sample_vndf(wo, alpha, u1, u2):
    """A microfacet normal from the GGX distribution of normals visible from wo (Heitz 2018)."""
    vx = alpha * wo[0]
    vy = alpha * wo[1]
    vz = wo[2]
    inv = 1.0 / math.sqrt(vx * vx + vy * vy + vz * vz)
    vx *= inv
    vy *= inv
    vz *= inv
    lensq = vx * vx + vy * vy
    if lensq > 0.0:
        il = 1.0 / math.sqrt(lensq)
        t1 = (-vy * il, vx * il, 0.0)
    else:
        t1 = (1.0, 0.0, 0.0)
    t2 = (vy * t1[2] - vz * t1[1], vz * t1[0] - vx * t1[2], vx * t1[1] - vy * t1[0])
    r = math.sqrt(u1)
    cp, sp = turn(u2)
    p1 = r * cp
    p2 = r * sp
    s = 0.5 * (1.0 + vz)
    p2 = (1.0 - s) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1[0] + p2 * t2[0] + p3 * vx
    ny = p1 * t1[1] + p2 * t2[1] + p3 * vy
    nz = p1 * t1[2] + p2 * t2[2] + p3 * vz
    hx = alpha * nx
    hy = alpha * ny
    hz = max(nz, 0.0)
    inv = 1.0 / math.sqrt(hx * hx + hy * hy + hz * hz)
    return hx * inv, hy * inv, hz * inv


@nb.njit(**_JIT)
def _reflect(wo, h):
    c = 2.0 * (wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2])
    return c * h[0] - wo[0], c * h[1] - wo[1], c * h[2] - wo[2]


@nb.njit(**_JIT)
def is_delta(b):
    """True if the BSDF has no lobe but delta ones (next-event estimation is useless)."""
    return (b.kd[0] <= 0.0 and b.kd[1] <= 0.0 and b.kd[2] <= 0.0 and not b.gooch and b.alpha <= 0.0
            and b.cc <= 0.0 and b.exp < 0.0)


@nb.njit(**_JIT)
def lobe_probabilities(b, cos_o, fs):
    """Probabilities of the six lobes at cos_o, proportional to their estimated albedo; fs = Schlick's
    F(cos_o) of the GGX lobe (black without one)."""
    fc = b.cc * schlick(CC_F0, 1.0, cos_o)
    if b.gooch:
        a_d = 0.5 * (lum(b.kd) + lum(b.cool))
    elif b.coupled:
        a_d = lum(((1.0 - fs[0]) * b.kd[0], (1.0 - fs[1]) * b.kd[1], (1.0 - fs[2]) * b.kd[2]))
    else:
        a_d = lum(b.kd)
    a_d *= 1.0 - fc
    a_g = lum(fs) * (1.0 - fc)
    a_p = lum(b.ks) if b.exp >= 0.0 else 0.0
    a_m = lum(b.mirror)
    a_t = 1.0 if b.eta > 0.0 else 0.0
    tot = a_d + a_g + fc + a_p + a_m + a_t
    if not tot > 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    s = 1.0 / tot
    return a_d * s, a_g * s, fc * s, a_p * s, a_m * s, a_t * s


@nb.njit(**_JIT)
def _smith_o(cos_o, alpha):
    """The terms of wo in `_microfacet`: (1/2 + Lambda(wo), 1 / ((1 + Lambda(wo)) 4 cos_o))."""
    lam = smith_lambda(cos_o, alpha)
    return 0.5 + lam, 1.0 / ((1.0 + lam) * 4.0 * cos_o)


@nb.njit(**_JIT)
def seen_from(b, wo):
    """The `Seen` record of b from wo (local, unit): what every evaluation from wo shares."""
    c = wo[2]
    if c <= 0.0:
        return Seen(b, wo, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), BLACK, (0.0, 0.0), (0.0, 0.0))
    fo = schlick3(b.f0, b.f90, c) if (b.alpha > 0.0 or b.coupled) else BLACK
    p = lobe_probabilities(b, c, fo if b.alpha > 0.0 else BLACK)
    g = _smith_o(c, b.alpha) if F_MODELS & B_GGX and b.alpha > 0.0 else (0.0, 0.0)
    gc = _smith_o(c, b.cc_alpha) if F_CLEARCOAT and b.cc > 0.0 else (0.0, 0.0)
    return Seen(b, wo, p, fo, g, gc)


@nb.njit(**_JIT)
def _microfacet(wo, wi, hxy2, hz, alpha, g):
    """(D G2 / (4 cos_o cos_i), the visible-normal pdf of wi: G1(wo) D / (4 cos_o)) of a GGX lobe, g its
    `_smith_o` terms; hxy2, hz the squared tangential length and the normal component of the unnormalised
    half vector wo + wi (cos_i > 0, cos_o > 0).  With |h|^2 = hxy2 + hz^2 and m = hxy2 + alpha^2 hz^2,
    D = alpha^2 |h|^4 / (pi m^2) (no normalisation: m has no cancellation, and m >= alpha^2 hz^2 > 0), and
    cos_i (1 + Lambda(wo) + Lambda(wi)) = s = cos_i g[0] + sqrt(cos_i^2 + alpha^2 (1 - cos_i^2)) / 2, so
    G2 / cos_i = 1 / s: one square root and one division for both values."""
    a2 = alpha * alpha
    ci = wi[2]
    n2 = hxy2 + hz * hz
    m = hxy2 + a2 * hz * hz
    q = 4.0 * wo[2] * (ci * g[0] + 0.5 * math.sqrt(ci * ci + a2 * (1.0 - ci * ci)))
    spec = a2 * n2 * n2 / (math.pi * m * m * q)
    return spec, spec * q * g[1]


@nb.njit(**_JIT)
def evaluate_seen(sb, wi):
    """(f(wo, wi) cos_i rgb, mixture pdf of wi) of the non-delta lobes of sb = `seen_from(b, wo)`; wi a
    local unit vector."""
    fc, _, pdf = evaluate_parts(sb, wi)
    return fc, pdf


@nb.njit(**_JIT)
def evaluate_parts(sb, wi):
    """(f(wo, wi) cos_i rgb, its diffuse part rgb, mixture pdf of wi): `evaluate_seen` and the part of its
    value that the diffuse lobe gives (Lambert, cool-to-warm; under a clearcoat, as the coat lets it through),
    the rest being specular (GGX, clearcoat, Blinn-Phong): what a light's `inputs:diffuse` and
    `inputs:specular` weigh (`lights.lobe_gains`)."""
    b, wo, p = sb.b, sb.wo, sb.p
    if wo[2] <= 0.0 or wi[2] <= 0.0:
        return BLACK, BLACK, 0.0
    ci = wi[2]
    fr = 0.0
    fg = 0.0
    fb = 0.0
    pdf = 0.0
    micro = (F_MODELS & B_GGX and b.alpha > 0.0) or (F_CLEARCOAT and b.cc > 0.0) or (F_MODELS & B_PHONG and b.exp >= 0.0)
    hz, hxy2, vh = 1.0, 0.0, 1.0
    if micro:                                   # the half vector wo + wi only where a microfacet lobe needs it
        hx, hy, hz = wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]
        hxy2 = hx * hx + hy * hy
        vh = 0.5 * math.sqrt(hxy2 + hz * hz)   # wo.h = |wo + wi| / 2 for unit wo, wi
    if p[L_DIFFUSE] > 0.0:
        pdf += p[L_DIFFUSE] * ci / math.pi
        if F_MODELS & B_COOL_TO_WARM and b.gooch:
            t = 0.25 * (1.0 + ci) * (1.0 + wo[2])
            fr = (b.cool[0] + t * (b.kd[0] - b.cool[0])) / math.pi
            fg = (b.cool[1] + t * (b.kd[1] - b.cool[1])) / math.pi
            fb = (b.cool[2] + t * (b.kd[2] - b.cool[2])) / math.pi
        elif F_MODELS & B_PREVIEW_SURFACE and b.coupled:
            fo = sb.fo
            fi = schlick3(b.f0, b.f90, ci)
            fr = b.kd[0] * (1.0 - fo[0]) * (1.0 - fi[0]) / math.pi
            fg = b.kd[1] * (1.0 - fo[1]) * (1.0 - fi[1]) / math.pi
            fb = b.kd[2] * (1.0 - fo[2]) * (1.0 - fi[2]) / math.pi
        else:
            fr = b.kd[0] / math.pi
            fg = b.kd[1] / math.pi
            fb = b.kd[2] / math.pi
    dr, dg, db = fr, fg, fb                     # (the diffuse part)
    if F_MODELS & B_GGX and b.alpha > 0.0:
        F = schlick3(b.f0, b.f90, vh)
        s, ps = _microfacet(wo, wi, hxy2, hz, b.alpha, sb.g)
        fr += F[0] * s
        fg += F[1] * s
        fb += F[2] * s
        pdf += p[L_GGX] * ps
    if F_CLEARCOAT and b.cc > 0.0:
        layer = (1.0 - b.cc * schlick(CC_F0, 1.0, wo[2])) * (1.0 - b.cc * schlick(CC_F0, 1.0, ci))
        s, ps = _microfacet(wo, wi, hxy2, hz, b.cc_alpha, sb.gc)
        c = b.cc * schlick(CC_F0, 1.0, vh) * s
        fr = fr * layer + c
        fg = fg * layer + c
        fb = fb * layer + c
        dr, dg, db = dr * layer, dg * layer, db * layer
        pdf += p[L_CLEARCOAT] * ps
    if F_MODELS & B_PHONG and b.exp >= 0.0:
        cos_h = hz / (2.0 * vh)
        dh = (b.exp + 1.0) / (2.0 * math.pi) * cos_h ** b.exp
        s = dh / (4.0 * vh * max(ci, wo[2]))
        fr += b.ks[0] * s
        fg += b.ks[1] * s
        fb += b.ks[2] * s
        pdf += p[L_PHONG] * dh / (4.0 * vh)
    return (fr * ci, fg * ci, fb * ci), (dr * ci, dg * ci, db * ci), pdf


@nb.njit(**_JIT)
def diffuse_share(sb, wi, delta):
    """The share (rgb) of the BSDF value of sb towards the sampled wi that its diffuse lobe gives (0 for a
    delta lobe's direction): how a light that wi finds weighs its `lights.lobe_gains`."""
    if delta:
        return BLACK
    fc, fd, _ = evaluate_parts(sb, wi)
    return (fd[0] / fc[0] if fc[0] != 0.0 else 0.0, fd[1] / fc[1] if fc[1] != 0.0 else 0.0,
            fd[2] / fc[2] if fc[2] != 0.0 else 0.0)


@nb.njit(**_JIT)
def evaluate(b, wo, wi):
    """(f(wo, wi) cos_i rgb, mixture pdf of wi) of the non-delta lobes; wo, wi local unit vectors."""
    return evaluate_seen(seen_from(b, wo), wi)


@nb.njit(**_JIT)
def _lambert_only(b, p):
    """True if plain Lambert (albedo kd, not the coupled or cool-to-warm diffuse) is the BSDF's only
    non-delta lobe and no delta lobe can be chosen: a sample's weight is then kd and its pdf cos_i / pi,
    with no mixture to evaluate (the course's Lambertian model, a diffuse-only material)."""
    return (b.alpha <= 0.0 and b.cc <= 0.0 and b.exp < 0.0 and p[L_MIRROR] == 0.0 and p[L_DIELECTRIC] == 0.0
            and not (F_MODELS & B_COOL_TO_WARM and b.gooch) and not (F_MODELS & B_PREVIEW_SURFACE and b.coupled))


@nb.njit(**_JIT)
def _pick(p, u):
    """Lobe index for u in [0, 1) and u rescaled to [0, 1) within the chosen lobe's interval."""
    acc = 0.0
    last = -1
    for k in range(N_LOBES):
        if p[k] > 0.0:
            last = k
            if u < acc + p[k]:
                return k, min((u - acc) / p[k], 0.99999994)
            acc += p[k]
    return last, 0.5


@nb.njit(**_JIT)
def sample_seen(sb, ul, u1, u2):
    """Sample wi from sb = `seen_from(b, wo)`: (wi, weight rgb, pdf, delta).  weight = f cos / pdf for the
    non-delta lobes (pdf > 0), the lobe's weight / its probability for a delta lobe (delta True, pdf 0);
    weight 0 = absorbed."""
    b, wo, p = sb.b, sb.wo, sb.p
    dead = ((0.0, 0.0, 1.0), BLACK, 0.0, False)
    if wo[2] <= 0.0:
        return dead
    k, ur = _pick(p, ul)
    if k < 0:
        return dead
    if F_MODELS & B_DIELECTRIC and k == L_DIELECTRIC:
        return _sample_dielectric(b, wo, ur)
    if F_MODELS & B_MIRRORING and k == L_MIRROR:
        q = 1.0 / p[L_MIRROR]
        return (-wo[0], -wo[1], wo[2]), (b.mirror[0] * q, b.mirror[1] * q, b.mirror[2] * q), 0.0, True
    if k == L_DIFFUSE:
        r = math.sqrt(u1)
        cp, sp = turn(u2)
        wi = (r * cp, r * sp, math.sqrt(max(0.0, 1.0 - u1)))
        if _lambert_only(b, p) and wi[2] > 0.0:     # f cos / pdf = kd exactly: no mixture to evaluate
            return wi, b.kd, wi[2] / math.pi, False
    elif F_MODELS & B_GGX and (k == L_GGX or k == L_CLEARCOAT):
        h = sample_vndf(wo, b.alpha if k == L_GGX else b.cc_alpha, u1, u2)
        wi = _reflect(wo, h)
    elif F_MODELS & B_PHONG:
        ct = u1 ** (1.0 / (b.exp + 1.0))
        st = math.sqrt(max(0.0, 1.0 - ct * ct))
        cp, sp = turn(u2)
        wi = _reflect(wo, (st * cp, st * sp, ct))
    else:
        return dead
    if wi[2] <= 0.0:
        return dead
    f, pdf = evaluate_seen(sb, wi)
    if not pdf > 0.0:
        return dead
    r = 1.0 / pdf
    return wi, (f[0] * r, f[1] * r, f[2] * r), pdf, False


@nb.njit(**_JIT)
def sample(b, wo, ul, u1, u2):
    """`sample_seen` of b seen from wo."""
    return sample_seen(seen_from(b, wo), ul, u1, u2)


@nb.njit(**_JIT)
def _sample_dielectric(b, wo, u):
    eta = b.eta
    ci = wo[2]
    s2 = (1.0 - ci * ci) / (eta * eta)
    if s2 >= 1.0:
        F = 1.0
        ct = 0.0
    else:
        ct = math.sqrt(1.0 - s2)
        rs = (ci - eta * ct) / (ci + eta * ct)
        rp = (eta * ci - ct) / (eta * ci + ct)
        F = 0.5 * (rs * rs + rp * rp)
    if u < F:
        return (-wo[0], -wo[1], wo[2]), (1.0, 1.0, 1.0), 0.0, True
    k = 1.0 / eta
    w = k * k
    return (-k * wo[0], -k * wo[1], -ct), (w, w, w), 0.0, True


# ----------------------------------------------------------------------------- materials -> Bsdf
@nb.njit(**_JIT)
def _scaled(c, s):
    return c[0] * s, c[1] * s, c[2] * s


@nb.njit(**_JIT)
def preview_bsdf(diff, f0, f90, alpha, cc, cc_alpha):
    """A UsdPreviewSurface's lobes from `materials.preview_params` (diffuse, F0, F90, alpha) and its
    clearcoat (weight, alpha)."""
    return Bsdf(diff, True, BLACK, False, f0, f90, max(alpha, MIN_ALPHA), cc, max(cc_alpha, MIN_ALPHA),
                BLACK, -1.0, BLACK, 0.0)


@nb.njit(**_JIT)
def course_bsdf(model, kd, ks, exp, m, rough, ior, front, cool):
    """The physically plausible reading of a course model (README, "How course models are read by
    path"): model ids from `description`; kd, ks course colours; m the mirror coefficient, rough the
    glossy roughness, ior the dielectric's index, front whether the viewer is outside, cool the
    cool-to-warm model's cool colour (kd is then its warm colour).  Colours whose sum of lobe weights
    exceeds 1 are scaled down to 1 (energy conservation)."""
    mirror = BLACK
    alpha = 0.0
    e = -1.0
    eta = 0.0
    gooch = False
    if F_MODELS & B_LAMBERTIAN and model == D.LAMBERTIAN:
        ks = BLACK
    elif F_MODELS & B_BLINN_PHONG and model == D.BLINN_PHONG:
        e = exp
    elif F_MODELS & B_MIRROR and model == D.MIRROR:
        mirror = ks if (ks[0] > 0.0 or ks[1] > 0.0 or ks[2] > 0.0) else (1.0, 1.0, 1.0)
        kd = BLACK
        ks = BLACK
    elif F_MODELS & B_GLAZE and model == D.GLAZE:
        kd = _scaled(kd, 1.0 - m)
        ks = BLACK
        mirror = (m, m, m)
    elif F_MODELS & B_BLINN_PHONG_MIRRORED and model == D.BLINN_PHONG_MIRRORED:
        kd = _scaled(kd, 1.0 - m)
        ks = _scaled(ks, 1.0 - m)
        e = exp
        if rough > 0.0:
            alpha = max(rough * rough, MIN_ALPHA)
        else:
            mirror = (m, m, m)
    elif F_MODELS & B_DIELECTRIC and model == D.DIELECTRIC:
        kd = BLACK
        ks = BLACK
        eta = ior if front else 1.0 / ior
    else:                                           # COOL_TO_WARM
        ks = BLACK
        gooch = True
    tot = 0.0
    for c in range(3):
        w = kd[c] + (ks[c] if e >= 0.0 else 0.0) + mirror[c] + (m if alpha > 0.0 else 0.0)
        tot = max(tot, w, cool[c] if gooch else 0.0)
    s = 1.0 / tot if tot > 1.0 else 1.0
    mm = m * s
    return Bsdf(_scaled(kd, s), False, _scaled(cool, s), gooch, (mm, mm, mm), (mm, mm, mm), alpha, 0.0, 0.0,
                _scaled(ks, s), e, _scaled(mirror, s), eta)
