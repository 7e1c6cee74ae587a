"""Light sampling for direct illumination (UsdLux semantics; see renderer/description.py `Light`).

`sample_light` draws one point (or direction) on light k for a shading point and returns the
direction to it, the distance for the shadow ray and the estimate of the light's contribution to
the irradiance *per unit cosine*: `E_perp`, such that the Monte Carlo estimate of the reflected
radiance is `f(wi, wo) * E_perp * cos(theta_i)` for physically based BRDFs and
`kd * E_perp * cos + ks * E_perp * (n.h)^p` for the course models (which treat every light sample
as a point light: Cook et al. 1984; Shirley, FCG).

Area lights are sampled uniformly by area (rectangle, disk, the side of a cylinder) or by solid
angle of the visible cap (sphere: exact, no wasted samples behind the horizon of the light), which
gives soft shadows whose noise falls with the stratification of the 2D light sample.  A cylinder
light (along its local X) emits outwards from its side: a sample point facing away from the shading
point contributes nothing.

A light with UsdLux.ShapingAPI (`shaped`) is a spotlight: its emission towards a direction at angle theta off its
-Z axis is multiplied by the cone's cut-off, 1 - smoothstep(theta; angle (1 - softness), angle), so 1 inside the
cone's soft edge, 0 past its angle, as Pixar's hdEmbree shapes it, and with a focus f by the off-axis cosine power
lerp(focusTint, 1, cos(theta)^f), and with an IES profile by the profile's intensity towards the direction
(`ies_profiles.ies_weight`).  Both integrators apply it to every light sample, and the path integrator to BSDF
rays that find the light's shape, so that the two estimators agree.

A light's UsdLux `inputs:diffuse` and `inputs:specular` (`lobe_gains`) multiply its effect on the diffuse and
on the specular lobes of the surfaces it lights: in each light sample, the BSDF's two parts (`bsdf.evaluate_parts`,
`materials.direct_parts`) are weighted by them; where a BSDF-sampled ray finds the light, its emission is
weighted by them in the shares the sampled direction's BSDF value had (`gained`).  Both are the same integrand,
so MIS still combines them.  A camera ray sees the light as it is.
"""
import math

import numba as nb

from .. import description as D
from .features import (B_CYLINDER, B_DISTANT, B_DOME, B_PLANAR, B_POINT, B_SPHERE, F_COURSE_LIGHTS, F_DOME_TEXTURE,
                       F_IES, F_LIGHT_GAINS, F_LIGHTS, F_LUX_LIGHTS, F_RECT_TEXTURE, F_SHAPING)
from .ies_profiles import ies_weight
from .jit import INLINE_JIT, SHADING_INLINE_JIT, SHADING_JIT
from .tables import (LF_AREA, LF_CONE, LF_COS_MAX, LF_COURSE, LF_COURSE_I, LF_FOCUS, LF_GAIN, LF_H, LF_IES, LF_LENGTH,
                     LF_M, LF_RAD, LF_RADIUS, LF_SHAPED, LF_TINT, LF_W)
from .textures import sample_latlong, sample_texture
from .vecmath import dot, normalize, onb, sub, to_world

INF = math.inf
CAMERA_SHARE = (-1.0, -1.0, -1.0)       # the diffuse share (`gained`) of a ray no BSDF drew: a camera ray
SPECULAR_SHARE = (0.0, 0.0, 0.0)        # of a ray a specular lobe drew (a mirror, a refraction)


@nb.njit(**INLINE_JIT)
def _col(li_f, k, j):
    return (li_f[k, LF_M + j], li_f[k, LF_M + 4 + j], li_f[k, LF_M + 8 + j])


@nb.njit(**SHADING_INLINE_JIT)
def light_is_area(S, k):
    """True if light k has extent (its sample point uses a 2D sample): not a point light, not a
    distant light of zero angle.  Delta lights draw no sample: nothing is computed they don't need."""
    t = S.li_type[k]
    return not (t == D.POINT or (t == D.DISTANT and S.li_f[k, LF_COS_MAX] >= 1.0))


@nb.njit(**SHADING_INLINE_JIT)
def lobe_gains(S, k):
    """(diffuse, specular) multipliers of light k's effect on the surfaces it lights (UsdLux inputs:diffuse,
    inputs:specular); (1, 1) where the scene has none other (`Features.light_gains`)."""
    if not F_LIGHT_GAINS:
        return 1.0, 1.0
    return S.li_f[k, LF_GAIN], S.li_f[k, LF_GAIN + 1]


@nb.njit(**SHADING_INLINE_JIT)
def gained_by(gains, share, Le):
    """Radiance Le of a light with lobe gains `gains` = (diffuse, specular) found by a BSDF-sampled ray whose BSDF
    value was in the diffuse share `share` (rgb; the rest specular; share[0] < 0: no BSDF, a camera ray)."""
    gd, gs = gains
    if (gd == 1.0 and gs == 1.0) or share[0] < 0.0:
        return Le
    return (Le[0] * (gs + (gd - gs) * share[0]), Le[1] * (gs + (gd - gs) * share[1]),
            Le[2] * (gs + (gd - gs) * share[2]))


@nb.njit(**SHADING_INLINE_JIT)
def gained(S, k, share, Le):
    """`gained_by` light k's `lobe_gains`."""
    return gained_by(lobe_gains(S, k), share, Le)


@nb.njit(**SHADING_INLINE_JIT)
def split_by(gains, fc, fd):
    """A light sample's BSDF value fc (rgb) whose diffuse part is fd, weighted by lobe gains `gains`."""
    gd, gs = gains
    return (gd * fd[0] + gs * (fc[0] - fd[0]), gd * fd[1] + gs * (fc[1] - fd[1]), gd * fd[2] + gs * (fc[2] - fd[2]))


@nb.njit(**SHADING_INLINE_JIT)
def shaped(S, k, wi, Le):
    """Radiance Le of light k along the direction -wi (wi: from the lit point towards the light) as its
    UsdLux.ShapingAPI shapes it (module docstring); Le itself for an unshaped light."""
    lf = S.li_f
    if not (F_SHAPING and lf[k, LF_SHAPED] != 0.0):
        return Le
    z = normalize(_col(lf, k, 2))                    # (the light emits along -Z: cos theta = wi . Z)
    c = max(-1.0, min(1.0, dot(wi, z)))
    theta = math.acos(c)
    hi, lo = lf[k, LF_CONE], lf[k, LF_CONE + 1]
    f = 1.0
    if theta >= hi:
        f = 0.0
    elif theta > lo:
        x = (theta - lo) / (hi - lo)
        f = 1.0 - x * x * (3.0 - 2.0 * x)
    if F_IES and lf[k, LF_IES] >= 0.0 and f > 0.0:
        f *= ies_weight(S.li_ies, lf, k, dot(wi, normalize(_col(lf, k, 0))), dot(wi, normalize(_col(lf, k, 1))), c)
    focus = lf[k, LF_FOCUS]
    if focus > 0.0:
        g = max(c, 0.0) ** focus
        return (Le[0] * f * (lf[k, LF_TINT] + (1.0 - lf[k, LF_TINT]) * g),
                Le[1] * f * (lf[k, LF_TINT + 1] + (1.0 - lf[k, LF_TINT + 1]) * g),
                Le[2] * f * (lf[k, LF_TINT + 2] + (1.0 - lf[k, LF_TINT + 2]) * g))
    return Le[0] * f, Le[1] * f, Le[2] * f


@nb.njit(**SHADING_INLINE_JIT)
def sample_light(S, k, p, n, u1, u2):
    """-> (wi, dist, E_perp rgb).  E_perp = (0,0,0) when the sample cannot contribute (behind the
    light, inside a sphere light, ...).  n is the shading normal facing the viewer; only the dome
    uses it (cosine-weighted hemisphere sampling)."""
    t = S.li_type[k]
    lf = S.li_f
    L = (lf[k, LF_RAD], lf[k, LF_RAD + 1], lf[k, LF_RAD + 2])
    if F_LIGHTS & B_POINT and (F_LIGHTS == B_POINT or t == D.POINT):
        return _sample_point(lf, k, p, L)
    if F_LIGHTS & B_PLANAR and (t == D.RECT or t == D.DISK):
        return _sample_area(S, k, t, p, u1, u2, L)
    if F_LIGHTS & B_SPHERE and (F_LIGHTS == B_SPHERE or t == D.SPHERE):
        return _sample_sphere(lf, k, p, u1, u2, L)
    if F_LIGHTS & B_CYLINDER and (F_LIGHTS == B_CYLINDER or t == D.CYLINDER):
        return _sample_cylinder(lf, k, p, u1, u2, L)
    if F_LIGHTS & B_DISTANT and (F_LIGHTS == B_DISTANT or t == D.DISTANT):
        return _sample_distant(lf, k, u1, u2, L)
    if F_LIGHTS & B_DOME and (F_LIGHTS == B_DOME or t == D.DOME):
        return _sample_dome(S, k, n, u1, u2)
    return (0.0, 0.0, 1.0), 0.0, (0.0, 0.0, 0.0)


@nb.njit(**INLINE_JIT)
def _sample_point(lf, k, p, L):
    """A point light of intensity L: inverse-square falloff."""
    v = sub(_col(lf, k, 3), p)
    d2 = dot(v, v)
    if d2 <= 0.0:
        return (0.0, 0.0, 1.0), 0.0, (0.0, 0.0, 0.0)
    d = math.sqrt(d2)
    r = 1.0 / d
    inv = r * r
    return (v[0] * r, v[1] * r, v[2] * r), d, (L[0] * inv, L[1] * inv, L[2] * inv)


@nb.njit(**SHADING_INLINE_JIT)
def rect_radiance(S, k, a, b, Le):
    """Radiance Le of rect light k at its point c + a ex + b ey, times its image there if it has one: UsdLux
    puts the image's top-left corner at local (+X, +Y) and its bottom-right at (-X, -Y) (so that it reads as
    drawn seen from the side the light shines on), i.e. texture coordinates (1/2 - a / w, 1/2 + b / h)."""
    tex = S.li_tex[k]
    if not (F_RECT_TEXTURE and tex >= 0):
        return Le
    lf = S.li_f
    c = sample_texture(S, tex, 0.5 - a / lf[k, LF_W], 0.5 + b / lf[k, LF_H])
    return Le[0] * c[0], Le[1] * c[1], Le[2] * c[2]


@nb.njit(**SHADING_INLINE_JIT)
def _sample_area(S, k, t, p, u1, u2, L):
    """A point uniformly on a rect (t == D.RECT) or disk light of radiance L, as seen from p."""
    lf = S.li_f
    pos = _col(lf, k, 3)
    ex = _col(lf, k, 0)
    ey = _col(lf, k, 1)
    if t == D.RECT:
        a = (u1 - 0.5) * lf[k, LF_W]
        b = (u2 - 0.5) * lf[k, LF_H]
        L = rect_radiance(S, k, a, b, L)
    else:
        r = lf[k, LF_RADIUS] * math.sqrt(u1)
        phi = 2.0 * math.pi * u2
        a = r * math.cos(phi)
        b = r * math.sin(phi)
    q = (pos[0] + a * ex[0] + b * ey[0], pos[1] + a * ex[1] + b * ey[1], pos[2] + a * ex[2] + b * ey[2])
    return _area_point(p, q, normalize(_col(lf, k, 2)), lf[k, LF_AREA], L)   # emits along local -Z


@nb.njit(**INLINE_JIT)
def _area_point(p, q, nl, area, L):
    """(wi, dist, E_perp) of the point q drawn uniformly by area on a light of that area and radiance L
    (nl: the opposite of its emitting side's normal at q), seen from p."""
    v = sub(q, p)
    d2 = dot(v, v)
    if d2 <= 0.0:
        return (0.0, 0.0, 1.0), 0.0, (0.0, 0.0, 0.0)
    d = math.sqrt(d2)
    r = 1.0 / d
    wi = (v[0] * r, v[1] * r, v[2] * r)
    cos_l = dot(nl, wi)                        # = dot(-n, -wi)
    if cos_l <= 0.0:                           # the light's back, or the side facing away from p
        return wi, d, (0.0, 0.0, 0.0)
    g = cos_l * area * (r * r)
    return wi, d, (L[0] * g, L[1] * g, L[2] * g)


@nb.njit(**INLINE_JIT)
def cylinder_point(lf, k, u1, u2):
    """(point, outward unit normal) uniformly by area on the side of cylinder light k (u1 along its
    axis, local X; u2 around it)."""
    ax = normalize(_col(lf, k, 0))
    ey = normalize(_col(lf, k, 1))
    ez = normalize(_col(lf, k, 2))
    c = _col(lf, k, 3)
    a = (u1 - 0.5) * lf[k, LF_LENGTH]
    phi = 2.0 * math.pi * u2
    cp = math.cos(phi)
    sp = math.sin(phi)
    n = (cp * ey[0] + sp * ez[0], cp * ey[1] + sp * ez[1], cp * ey[2] + sp * ez[2])
    r = lf[k, LF_RADIUS]
    return (c[0] + a * ax[0] + r * n[0], c[1] + a * ax[1] + r * n[1], c[2] + a * ax[2] + r * n[2]), n


@nb.njit(**INLINE_JIT)
def _sample_cylinder(lf, k, p, u1, u2, L):
    """A point uniformly by area on the side of a cylinder light of radiance L, as seen from p."""
    q, nq = cylinder_point(lf, k, u1, u2)
    return _area_point(p, q, (-nq[0], -nq[1], -nq[2]), lf[k, LF_AREA], L)


@nb.njit(**INLINE_JIT)
def _sample_sphere(lf, k, p, u1, u2, L):
    """A direction uniformly in the cone a sphere light subtends at p."""
    r = lf[k, LF_RADIUS]
    v = sub(_col(lf, k, 3), p)
    d2 = dot(v, v)
    if d2 <= r * r:
        return (0.0, 0.0, 1.0), 0.0, (0.0, 0.0, 0.0)
    d = math.sqrt(d2)
    rd = 1.0 / d
    w = (v[0] * rd, v[1] * rd, v[2] * rd)
    cos_max = math.sqrt(max(0.0, 1.0 - r * r / d2))
    cos_t = 1.0 - u1 * (1.0 - cos_max)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * math.pi * u2
    tt, bb = onb(w)
    wi = to_world((sin_t * math.cos(phi), sin_t * math.sin(phi), cos_t), tt, bb, w)
    # distance to the sphere surface along wi
    bq = d * cos_t
    dist = bq - math.sqrt(max(0.0, r * r - (d2 - bq * bq)))
    omega = 2.0 * math.pi * (1.0 - cos_max)
    return wi, dist, (L[0] * omega, L[1] * omega, L[2] * omega)


@nb.njit(**INLINE_JIT)
def _sample_distant(lf, k, u1, u2, L):
    """A distant light: its direction, or one uniformly in its cone of angular diameter `angle`."""
    w = normalize(_col(lf, k, 2))            # direction towards the light: local +Z
    cos_max = lf[k, LF_COS_MAX]
    if cos_max < 1.0:
        cos_t = 1.0 - u1 * (1.0 - cos_max)
        sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
        phi = 2.0 * math.pi * u2
        tt, bb = onb(w)
        w = to_world((sin_t * math.cos(phi), sin_t * math.sin(phi), cos_t), tt, bb, w)
    return w, INF, L


@nb.njit(**SHADING_INLINE_JIT)
def _sample_dome(S, k, n, u1, u2):
    """A dome light: cosine-weighted hemisphere about n; the estimate of the irradiance integral is
    L(wi) * pi / cos."""
    r = math.sqrt(u1)
    phi = 2.0 * math.pi * u2
    z = math.sqrt(max(0.0, 1.0 - u1))
    tt, bb = onb(n)
    wi = to_world((r * math.cos(phi), r * math.sin(phi), z), tt, bb, n)
    if z <= 1e-8:
        return wi, INF, (0.0, 0.0, 0.0)
    Le = dome_radiance(S, k, wi)
    s = math.pi / z
    return wi, INF, (Le[0] * s, Le[1] * s, Le[2] * s)


@nb.njit(**SHADING_JIT, inline='always')
def sample_course_light(S, k, p, n, u1, u2):
    """`sample_light` for the cook integrator: a course light (LF_COURSE, from the rtc: attributes
    the compiler writes) is shaded as the course shades it, E_perp = its intensity I at every
    sample point with no distance fall-off, no cosine at an area light and both of its sides lit
    (xml-format.md section 4); any other light as `sample_light`."""
    lf = S.li_f
    if F_LUX_LIGHTS and (not F_COURSE_LIGHTS or lf[k, LF_COURSE] == 0.0):
        wi, dist, E = sample_light(S, k, p, n, u1, u2)
        return wi, dist, shaped(S, k, wi, E)
    q = _col(lf, k, 3)
    if S.li_type[k] == D.RECT:
        ex = _col(lf, k, 0)
        ey = _col(lf, k, 1)
        a = (u1 - 0.5) * lf[k, LF_W]
        b = (u2 - 0.5) * lf[k, LF_H]
        q = (q[0] + a * ex[0] + b * ey[0], q[1] + a * ex[1] + b * ey[1], q[2] + a * ex[2] + b * ey[2])
    v = sub(q, p)
    d2 = dot(v, v)
    if d2 <= 0.0:
        return (0.0, 0.0, 1.0), 0.0, (0.0, 0.0, 0.0)
    d = math.sqrt(d2)
    r = 1.0 / d
    return (v[0] * r, v[1] * r, v[2] * r), d, (lf[k, LF_COURSE_I], lf[k, LF_COURSE_I + 1], lf[k, LF_COURSE_I + 2])


@nb.njit(**SHADING_JIT)
def dome_radiance(S, k, wd):
    """Radiance of dome light k seen along world direction wd."""
    lf = S.li_f
    L = (lf[k, LF_RAD], lf[k, LF_RAD + 1], lf[k, LF_RAD + 2])
    tex = S.li_tex[k]
    if F_DOME_TEXTURE and tex >= 0:
        # world -> light-local direction: rows of the (orthonormal up to scale) rotation
        x = normalize(_col(lf, k, 0))
        y = normalize(_col(lf, k, 1))
        z = normalize(_col(lf, k, 2))
        c = sample_latlong(S, tex, (dot(wd, x), dot(wd, y), dot(wd, z)))
        return (L[0] * c[0], L[1] * c[1], L[2] * c[2])
    return L


@nb.njit(**SHADING_INLINE_JIT)
def escaped_radiance(S, wd, share):
    """Radiance of a ray that leaves the scene: the dome lights if any (weighted by their `lobe_gains` in the
    diffuse share `share` of the ray's BSDF value: `gained`), else the background colour."""
    r = 0.0
    g = 0.0
    b = 0.0
    found = False
    for k in range(S.li_type.shape[0]):
        if F_LIGHTS & B_DOME and S.li_type[k] == D.DOME:
            c = gained(S, k, share, dome_radiance(S, k, wd))
            r += c[0]
            g += c[1]
            b += c[2]
            found = True
    if found:
        return (r, g, b)
    return (S.background[0], S.background[1], S.background[2])
