"""Surface reflection models.

Course models (exact `rtc:` parameters; the course's shading equations, which treat each light
sample as a point source with irradiance `E_perp` normal to the light direction):

* Lambertian          kd E cos
* Blinn-Phong         kd E cos + ks E max(0, n.h)^p
* Glaze               (1 - m) kd E cos                         + m x mirror reflection
* Blinn-Phong mirrored (1 - m) kd E cos + ks E max(0, n.h)^p   + m x glossy reflection
* Mirror              perfect reflection (weight ks if given, else 1)
* Dielectric          Fresnel-weighted reflection / refraction, Beer attenuation inside
* Cool-to-warm        Gooch et al. 1998 tone blend of kd between a cool and a warm colour

`UsdPreviewSurface` (every other material) follows the reference implementation shipped with USD
(`usdShaders/previewSurface.glslfx`): GGX distribution with alpha = roughness^2 (roughness clamped
to >= 0.001), Smith-Schlick visibility with k = alpha/2, Schlick Fresnel; specular workflow
F0 = specularColor, F90 = 1; metallic workflow F0 = lerp(0.04-ish dielectric F0 from ior, base, metallic).
"""
import math

import numba as nb

from .. import description as D
from .features import B_COOL_TO_WARM, B_PREVIEW_SURFACE, F_CLEARCOAT, F_LIGHT_GAINS, F_MODELS, F_TEXTURES
from .jit import JIT, SHADING_INLINE_JIT
from .tables import (MF_CC_ROUGH, MF_CLEARCOAT, MF_EMIT, MF_EXP, MF_GAIN, MF_IOR, MF_KD, MF_KS, MF_METAL, MF_MIRROR,
                     MF_OPACITY, MF_OPACITY_CUT, MF_ROUGH, MF_SPECWF, MI_DIFFUSE_TEX, MI_EMISSION_TEX, MI_MODEL,
                     MI_SCALAR_CH, MI_SCALAR_TEX, MI_SPECULAR_TEX, S_CC_ROUGH, S_CLEARCOAT, S_METAL, S_OPACITY, S_ROUGH)
from .textures import sample_channel, sample_texture
from .vecmath import dot, normalize

GOOCH_BLUE, GOOCH_YELLOW, GOOCH_ALPHA, GOOCH_BETA = 0.4, 0.4, 0.2, 0.6


@nb.njit(**SHADING_INLINE_JIT)
def colors(S, mat, st):
    """(kd, ks) with textures applied."""
    mf = S.mat_f
    kd = (float(mf[mat, MF_KD]), float(mf[mat, MF_KD + 1]), float(mf[mat, MF_KD + 2]))
    ks = (float(mf[mat, MF_KS]), float(mf[mat, MF_KS + 1]), float(mf[mat, MF_KS + 2]))
    td = S.mat_i[mat, MI_DIFFUSE_TEX]
    if F_TEXTURES and td >= 0:
        c = sample_texture(S, td, st[0], st[1])
        kd = (kd[0] * c[0], kd[1] * c[1], kd[2] * c[2])
    ts = S.mat_i[mat, MI_SPECULAR_TEX]
    if F_TEXTURES and ts >= 0:
        c = sample_texture(S, ts, st[0], st[1])
        ks = (ks[0] * c[0], ks[1] * c[1], ks[2] * c[2])
    return kd, ks


@nb.njit(**SHADING_INLINE_JIT)
def scalar(S, mat, st, col, k):
    """Material mat's scalar input in column col of mat_f, times its texture's channel at st where one drives
    it (input k of MI_SCALAR_TEX: S_ROUGH, S_METAL, S_OPACITY)."""
    v = float(S.mat_f[mat, col])
    t = S.mat_i[mat, MI_SCALAR_TEX + k]
    if F_TEXTURES and t >= 0:
        v *= sample_channel(S, t, st[0], st[1], S.mat_i[mat, MI_SCALAR_CH + k])
    return v


@nb.njit(**SHADING_INLINE_JIT)
def scalars(S, mat, st, corner):
    """(roughness, metallic, opacity) of material mat at texture coordinates st: its inputs, times their
    textures there where textures drive them (`ShadingPoint.rmo`); `corner`: as `opacity`."""
    return (scalar(S, mat, st, MF_ROUGH, S_ROUGH), scalar(S, mat, st, MF_METAL, S_METAL),
            opacity(S, mat, st, corner))


@nb.njit(**SHADING_INLINE_JIT)
def opacity(S, mat, st, corner):
    """Material mat's opacity at texture coordinates st (its texture's channel there where one drives it), times
    `corner`, the gprim's per-corner opacity there (`shapes.corner_opacity`: 1 where it has none); with an
    opacityThreshold > 0, 0 below the threshold and 1 at or above it (a cut-out, as Storm masks)."""
    a = scalar(S, mat, st, MF_OPACITY, S_OPACITY) * corner
    cut = float(S.mat_f[mat, MF_OPACITY_CUT])
    if cut > 0.0:
        a = 1.0 if a >= cut else 0.0
    return a


@nb.njit(**SHADING_INLINE_JIT)
def material_gains(S, mat):
    """(diffuse, specular) multipliers of material mat's emission's effect on the surfaces it lights (a MeshLightAPI
    mesh's inputs:diffuse and inputs:specular, `lights.gained_by`); (1, 1) where the scene has none other."""
    if not F_LIGHT_GAINS:
        return 1.0, 1.0
    return float(S.mat_f[mat, MF_GAIN]), float(S.mat_f[mat, MF_GAIN + 1])


@nb.njit(**SHADING_INLINE_JIT)
def emission(S, mat, st):
    """Emitted radiance of material mat at texture coordinates st: its emissiveColor, times its texture
    there where one drives it."""
    mf = S.mat_f
    em = (float(mf[mat, MF_EMIT]), float(mf[mat, MF_EMIT + 1]), float(mf[mat, MF_EMIT + 2]))
    te = S.mat_i[mat, MI_EMISSION_TEX]
    if F_TEXTURES and te >= 0:
        c = sample_texture(S, te, st[0], st[1])
        em = (em[0] * c[0], em[1] * c[1], em[2] * c[2])
    return em


@nb.njit(**JIT)
def has_diffuse_lobe(model):
    return (model == D.LAMBERTIAN or model == D.BLINN_PHONG or model == D.GLAZE
            or model == D.BLINN_PHONG_MIRRORED or model == D.COOL_TO_WARM or model == D.PREVIEW_SURFACE)


@nb.njit(**JIT)
def _schlick(f0, f90, c):
    x = 1.0 - c
    x5 = x * x * x * x * x
    return f0 + (f90 - f0) * x5


@nb.njit(**SHADING_INLINE_JIT)
def preview_params(S, mat, kd, ks, rmo):
    """-> (diffuse rgb, F0 rgb, F90 rgb, alpha) of a UsdPreviewSurface whose colours are kd, ks and its
    roughness and metallic rmo[0], rmo[1] (`scalars`)."""
    mf = S.mat_f
    rough = max(rmo[0], 0.001)
    alpha = rough * rough
    if mf[mat, MF_SPECWF] != 0.0:
        return kd, ks, (1.0, 1.0, 1.0), alpha
    metal = rmo[1]
    ior = float(mf[mat, MF_IOR])
    r = (1.0 - ior) / (1.0 + ior)
    r *= r
    c0 = 1.0 + (kd[0] - 1.0) * metal
    c1 = 1.0 + (kd[1] - 1.0) * metal
    c2 = 1.0 + (kd[2] - 1.0) * metal
    f0 = (r * c0 + (kd[0] - r * c0) * metal, r * c1 + (kd[1] - r * c1) * metal, r * c2 + (kd[2] - r * c2) * metal)
    diff = (kd[0] * (1.0 - metal), kd[1] * (1.0 - metal), kd[2] * (1.0 - metal))
    return diff, f0, (c0, c1, c2), alpha


@nb.njit(**JIT)
def ggx_d(nh, alpha):
    a2 = alpha * alpha
    x = nh * nh * (a2 - 1.0) + 1.0
    return a2 / (math.pi * x * x)


@nb.njit(**JIT)
def smith_g(nl, nv, alpha):
    k = 0.5 * alpha
    return (nl / (nl * (1.0 - k) + k)) * (nv / (nv * (1.0 - k) + k))


@nb.njit(**SHADING_INLINE_JIT)
def direct(S, sp, wi, E):
    """Reflected radiance towards sp.wo from one light sample arriving along wi with E_perp = E at shading
    point sp (a `records.ShadingPoint`; its shading normal on the viewer's side)."""
    return direct_parts(S, sp, wi, E)[0]


@nb.njit(**SHADING_INLINE_JIT)
def direct_parts(S, sp, wi, E):
    """(`direct`, the part of it its diffuse term gives): Lambert, the preview surface's diffuse, Gooch tone
    shading; the rest is specular (GGX, clearcoat, the course's highlight): what a light's inputs:diffuse and
    inputs:specular weigh (`lights.lobe_gains`)."""
    mat, kd, ks, n, wo = sp.mat, sp.kd, sp.ks, sp.ns, sp.wo
    model = S.mat_i[mat, MI_MODEL]
    cos_i = dot(n, wi)
    zero = (0.0, 0.0, 0.0)
    if cos_i <= 0.0:
        return zero, zero
    mf = S.mat_f
    if F_MODELS & B_COOL_TO_WARM and (F_MODELS == B_COOL_TO_WARM or model == D.COOL_TO_WARM):
        # Gooch: blend by (1 + n.l)/2 between k_cool and k_warm derived from kd; the light's grey
        # level scales it so several lights add up.
        tw = 0.5 * (1.0 + cos_i)
        e = (E[0] + E[1] + E[2]) / 3.0
        cool = (GOOCH_ALPHA * kd[0], GOOCH_ALPHA * kd[1], GOOCH_BLUE + GOOCH_ALPHA * kd[2])
        warm = (GOOCH_YELLOW + GOOCH_BETA * kd[0], GOOCH_YELLOW + GOOCH_BETA * kd[1], GOOCH_BETA * kd[2])
        c = (e * (tw * warm[0] + (1 - tw) * cool[0]), e * (tw * warm[1] + (1 - tw) * cool[1]),
             e * (tw * warm[2] + (1 - tw) * cool[2]))
        return c, c
    if F_MODELS & B_PREVIEW_SURFACE and (F_MODELS == B_PREVIEW_SURFACE or model == D.PREVIEW_SURFACE):
        diff, f0, f90, alpha = preview_params(S, mat, kd, ks, sp.rmo)
        nv = dot(n, wo)
        if nv <= 0.0:
            return zero, zero
        h = normalize((wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]))
        nh = max(dot(n, h), 0.0)
        vh = max(dot(wo, h), 0.0)
        dg = ggx_d(nh, alpha) * smith_g(cos_i, nv, alpha) / (4.0 * cos_i * nv)
        F0 = _schlick(f0[0], f90[0], vh)
        F1 = _schlick(f0[1], f90[1], vh)
        F2 = _schlick(f0[2], f90[2], vh)
        r = (diff[0] / math.pi * (1.0 - F0) + dg * F0) * E[0] * cos_i
        g = (diff[1] / math.pi * (1.0 - F1) + dg * F1) * E[1] * cos_i
        b = (diff[2] / math.pi * (1.0 - F2) + dg * F2) * E[2] * cos_i
        d = (diff[0] / math.pi * (1.0 - F0) * E[0] * cos_i, diff[1] / math.pi * (1.0 - F1) * E[1] * cos_i,
             diff[2] / math.pi * (1.0 - F2) * E[2] * cos_i)
        cc = scalar(S, mat, sp.st, MF_CLEARCOAT, S_CLEARCOAT)
        if F_CLEARCOAT and cc > 0.0:
            ca = max(scalar(S, mat, sp.st, MF_CC_ROUGH, S_CC_ROUGH), 0.001) ** 2
            Fc = _schlick(0.04, 1.0, vh)
            spec = cc * Fc * ggx_d(nh, ca) * smith_g(cos_i, nv, ca) / (4.0 * cos_i * nv)
            r += spec * E[0] * cos_i
            g += spec * E[1] * cos_i
            b += spec * E[2] * cos_i
        return (r, g, b), d
    m = 0.0
    if model == D.GLAZE or model == D.BLINN_PHONG_MIRRORED:
        m = float(mf[mat, MF_MIRROR])
    if model == D.LAMBERTIAN or model == D.GLAZE or model == D.BLINN_PHONG or model == D.BLINN_PHONG_MIRRORED:
        w = (1.0 - m) * cos_i
        r = (kd[0] * E[0] * w, kd[1] * E[1] * w, kd[2] * E[2] * w)
        d = r
        if model == D.BLINN_PHONG or model == D.BLINN_PHONG_MIRRORED:
            h = normalize((wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]))
            nh = dot(n, h)
            if nh > 0.0:
                s = nh ** float(mf[mat, MF_EXP])
                r = (r[0] + ks[0] * E[0] * s, r[1] + ks[1] * E[1] * s, r[2] + ks[2] * E[2] * s)
        return r, d
    return zero, zero


@nb.njit(**JIT)
def fresnel_dielectric(cos_i, eta):
    """Unpolarised Fresnel reflectance for relative index eta = n_t / n_i (cos_i > 0); 1 on total
    internal reflection.  Also returns cos_t."""
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0, 0.0
    cos_t = math.sqrt(1.0 - sin2_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp), cos_t


@nb.njit(**JIT)
def refract(d, n, eta, cos_i, cos_t):
    """Refracted direction of unit d through a surface with unit normal n facing against d."""
    k = 1.0 / eta
    return normalize((k * d[0] + (k * cos_i - cos_t) * n[0],
                      k * d[1] + (k * cos_i - cos_t) * n[1],
                      k * d[2] + (k * cos_i - cos_t) * n[2]))


@nb.njit(**SHADING_INLINE_JIT)
def mirror_weight(S, mat, model, ks):
    """Colour weight of the specular continuation of the course models (0 = none)."""
    if model == D.MIRROR:
        if ks[0] > 0.0 or ks[1] > 0.0 or ks[2] > 0.0:
            return ks
        return (1.0, 1.0, 1.0)
    if model == D.GLAZE or model == D.BLINN_PHONG_MIRRORED:
        m = float(S.mat_f[mat, MF_MIRROR])
        return (m, m, m)
    return (0.0, 0.0, 0.0)


@nb.njit(**JIT)
def sample_ggx_h(n, alpha, u1, u2, onb_t, onb_b):
    """Half vector from the GGX normal distribution (pdf D(h) cos(theta_h))."""
    phi = 2.0 * math.pi * u1
    t2 = alpha * alpha * u2 / max(1.0 - u2, 1e-12)
    cos_t = 1.0 / math.sqrt(1.0 + t2)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    x = sin_t * math.cos(phi)
    y = sin_t * math.sin(phi)
    return (x * onb_t[0] + y * onb_b[0] + cos_t * n[0],
            x * onb_t[1] + y * onb_b[1] + cos_t * n[1],
            x * onb_t[2] + y * onb_b[2] + cos_t * n[2])

