"""Lights for the path integrator: samples with their solid-angle pdf, and the emission that
BSDF-sampled rays find, so that the two strategies are combined by multiple importance sampling.

`sample_ld(S, L, k, p, n, u1, u2)` -> (wi, dist, Le rgb, pdf, delta): a direction towards light k, the
distance for the shadow ray, the radiance arriving along it and the pdf of wi per unit solid angle.
Delta lights (point; distant of zero angle) return delta = True, pdf 1 and Le = the irradiance they
deliver normal to wi (I / d^2, or E): next-event estimation alone sees them.

Lights with extent: rect (uniform in the solid angle it subtends, the spherical rectangle of Urena et
al. 2013, pdf = 1 / S; by area when S is tiny or nearly 2 pi, or seen from farther than its diagonal, where a
rect with an image draws its points by the image's luminance, `rect_sampling.py`), disk and the side of a cylinder
(uniform by area: pdf = d^2 / (cos_l A)),
sphere (uniform in the cone it subtends, exact), distant with an angle (uniform in its cone: radiance
E / Omega), dome (importance sampling of its lat-long texture by luminance x sin(theta),
`dome_sampling.py`; cosine-weighted about n when untextured).  From a vertex whose narrow GGX lobe carries
most of its albedo, rect and disk lights are drawn towards the lobe instead (`sample_ld_lobe`,
`lobe_sampling.py`), and a BSDF ray from it that meets one is weighed by that strategy's pdf.
A rect light's image multiplies its emission wherever a light sample or a ray meets it (`_imaged_at`).
Emissive surfaces are sampled by `surface_lights.sample_surface` (which `path.light_sample` calls for
them: a moving one needs the ray's time and Embree's matrix at it).  Rects and disks emit from their
front (local -Z) only, spheres and cylinders outwards (a cylinder from its side, not its caps: points
facing away from the receiver are drawn and contribute nothing), emissive surfaces from both sides.
Light shapes occlude nothing (shadow rays do not meet them: ray masks), and a ray collects the emission of every light
shape it crosses before the surface it hits (`shape_emission`, `path.find_surface`).  Every ray
sees them, camera rays included (UsdLux gives lights no camera-visibility attribute; path renders
what the light emits towards the camera, as Mitsuba and Karma do by default); the cook integrator
does not see light shapes at all.

`L` is the `PathLights` record of `host/light_selection.py` (the light tree that picks a light,
`kernel/light_tree.py`, the pmf, the list of light shapes, the dome tables).
"""
import math

import numba as nb

from .. import description as D
from .features import (B_CYLINDER, B_DISTANT, B_DOME, B_PLANAR, B_POINT, B_SPHERE, F_DOME_TEXTURE, F_LIGHTS,
                       F_RECT_TEXTURE)
from .dome_sampling import dome_pdf, sample_dome_texture
from .light_tree import light_pmf
from .lights import cylinder_point, dome_radiance, gained, rect_radiance, shaped
from .jit import SHADING_INLINE_JIT as _JIT
from .lobe_sampling import (NO_PLANE, NO_WINDOW, cauchy_sample, lobe_area_pdf, lobe_pdf, lobe_window,
                            rect_coords, round_window)
from .rect_sampling import image_density, image_sampled, sample_image_point
from .tables import LF_AREA, LF_COS_MAX, LF_H, LF_LENGTH, LF_M, LF_RAD, LF_RADIUS, LF_W
from .tile_lights import vertex_pmf
from .trace import MASK_ALL, MASK_FACING, MASK_LIGHT_SHAPES, MASK_SURFACES
from .vecmath import cross, dot, normalize, onb, sub, to_world, toward, turn
INF = math.inf
FLOAT32_EPS = 2.0 ** -23
T_ULPS = 16.0
# A rect light whose solid angle seen from the shading point lies in [SPHERICAL_MIN, SPHERICAL_MAX] sr is
# sampled uniformly in that solid angle (`spherical_rect`); outside it uniformly by area: a far light's
# solid angle loses precision where both strategies are equally good, and one nearly filling the
# hemisphere has its pdf near zero at grazing points (the bounds of pbrt-v4's rectangle sampling).
SPHERICAL_MIN = 3e-4
SPHERICAL_MAX = 6.22
# ... and only from points nearer its centre than NEAR_FIELD x its diagonal: farther away the pdf by area
# varies little over the light (relative variance of the unoccluded irradiance estimate <= 0.07 at one
# diagonal, measured), and the spherical rectangle's two atan2, sine, cosine and eight square roots
# (~150 ns a sample, measured) cost more than they save.
NEAR_FIELD = 1.0
ZERO = (0.0, 0.0, 0.0)
NONE = ((0.0, 0.0, 1.0), 0.0, ZERO, 0.0, False)
NO_RECT = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)    # a `spherical_rect` of solid angle 0: not sampled by it


@nb.njit(**_JIT)
def _col(lf, k, j):
    return (lf[k, LF_M + j], lf[k, LF_M + 4 + j], lf[k, LF_M + 8 + j])


@nb.njit(**_JIT)
def _plane(lf, k):
    """(centre, ex, ey, unit normal towards the emitting side's opposite = local +Z side)."""
    ex = _col(lf, k, 0)
    ey = _col(lf, k, 1)
    nrm = normalize(cross(ex, ey))
    if dot(nrm, _col(lf, k, 2)) < 0.0:
        nrm = (-nrm[0], -nrm[1], -nrm[2])
    return _col(lf, k, 3), ex, ey, nrm


@nb.njit(**_JIT)
def sphere_cone(r, d2):
    """1 - cos of the half-angle of the cone that a sphere of radius r subtends at squared distance d2 > r^2:
    (r^2 / d2) / (1 + cos), which keeps its precision where 1 - sqrt(1 - r^2 / d2) cancels (r / d = 1e-7:
    1.4 % off; 1e-8: 0, and its pdf a division by zero)."""
    s2 = r * r / d2
    return s2 / (1.0 + math.sqrt(max(0.0, 1.0 - s2)))


@nb.njit(**_JIT)
def _cone(w, one_minus, u1, u2):
    """A direction uniformly in the cone about w of solid angle 2 pi one_minus (one_minus = 1 - cos of its
    half-angle, passed as such: computed as 1 - cos it loses its digits for narrow cones)."""
    x = u1 * one_minus                           # 1 - cos_t
    cos_t = 1.0 - x
    sin_t = math.sqrt(max(0.0, x * (2.0 - x)))   # (not 1 - cos_t^2: it cancels in a narrow cone)
    cp, sp = turn(u2)
    tt, bb = onb(w)
    return to_world((sin_t * cp, sin_t * sp, cos_t), tt, bb, w)


@nb.njit(**_JIT)
def sample_ld(S, L, k, p, n, u1, u2):
    """-> (wi, dist, Le rgb, pdf, delta) for light k seen from p (n: shading normal, for the dome)."""
    t = S.li_type[k]
    lf = S.li_f
    Lr = (lf[k, LF_RAD], lf[k, LF_RAD + 1], lf[k, LF_RAD + 2])
    pos = _col(lf, k, 3)
    if F_LIGHTS & B_POINT and (F_LIGHTS == B_POINT or t == D.POINT):
        v = sub(pos, p)
        d2 = dot(v, v)
        if d2 <= 0.0:
            return NONE
        d = math.sqrt(d2)
        return (v[0] / d, v[1] / d, v[2] / d), d, (Lr[0] / d2, Lr[1] / d2, Lr[2] / d2), 1.0, True
    if F_LIGHTS & B_PLANAR and (t == D.RECT or t == D.DISK):
        c, ex, ey, nrm = _plane(lf, k)
        if t == D.RECT:
            sr = near_rect(p, c, ex, ey, nrm, lf[k, LF_W], lf[k, LF_H])
            if sr[0] > 0.0:
                return _spherical_rect_ld(p, sr, (ex, ey, nrm), (lf[k, LF_W], lf[k, LF_H]), (u1, u2), Lr)
            if image_sampled(L, k):                  # (far: by its image)
                return _image_ld(L, k, p, (c, ex, ey, nrm), (lf[k, LF_W], lf[k, LF_H], lf[k, LF_AREA]), (u1, u2), Lr)
            a = (u1 - 0.5) * lf[k, LF_W]
            b = (u2 - 0.5) * lf[k, LF_H]
        else:
            r = lf[k, LF_RADIUS] * math.sqrt(u1)
            cp, sp = turn(u2)
            a = r * cp
            b = r * sp
        q = (c[0] + a * ex[0] + b * ey[0], c[1] + a * ex[1] + b * ey[1], c[2] + a * ex[2] + b * ey[2])
        return area_ld(p, q, (-nrm[0], -nrm[1], -nrm[2]), lf[k, LF_AREA], Lr)
    if F_LIGHTS & B_CYLINDER and (F_LIGHTS == B_CYLINDER or t == D.CYLINDER):
        return _cylinder_ld(lf, k, p, u1, u2, Lr)
    if F_LIGHTS & B_SPHERE and (F_LIGHTS == B_SPHERE or t == D.SPHERE):
        r = lf[k, LF_RADIUS]
        v = sub(pos, p)
        d2 = dot(v, v)
        if d2 <= r * r:
            return NONE
        d = math.sqrt(d2)
        w = (v[0] / d, v[1] / d, v[2] / d)
        one_minus = sphere_cone(r, d2)
        if not one_minus > 0.0:                  # (r / d below ~1e-154: its square underflows)
            return NONE
        wi = _cone(w, one_minus, u1, u2)
        bq = d * dot(wi, w)
        dist = bq - math.sqrt(max(0.0, r * r - (d2 - bq * bq)))
        return wi, dist, Lr, 1.0 / (2.0 * math.pi * one_minus), False
    if F_LIGHTS & B_DISTANT and (F_LIGHTS == B_DISTANT or t == D.DISTANT):
        w = normalize(_col(lf, k, 2))
        cos_max = lf[k, LF_COS_MAX]
        if cos_max >= 1.0:
            return w, INF, Lr, 1.0, True
        omega = 2.0 * math.pi * (1.0 - cos_max)
        return _cone(w, 1.0 - cos_max, u1, u2), INF, (Lr[0] / omega, Lr[1] / omega, Lr[2] / omega), 1.0 / omega, False
    if F_LIGHTS & B_DOME and (F_LIGHTS == B_DOME or t == D.DOME):
        if F_DOME_TEXTURE and L.image_i[k, 0] >= 0:
            wi, pdf = sample_dome_texture(S, L, k, u1, u2)
        else:
            r = math.sqrt(u1)
            cp, sp = turn(u2)
            z = math.sqrt(max(0.0, 1.0 - u1))
            tt, bb = onb(n)
            wi = to_world((r * cp, r * sp, z), tt, bb, n)
            pdf = z / math.pi
        if not pdf > 0.0:
            return NONE
        return wi, INF, dome_radiance(S, k, wi), pdf, False
    return NONE


@nb.njit(**_JIT)
def _lobe_light(S, k):
    """True if light k's samples can follow a glossy lobe (`lobe_sampling`): a rect or disk light."""
    return F_LIGHTS & B_PLANAR and (S.li_type[k] == D.RECT or S.li_type[k] == D.DISK)


@nb.njit(**_JIT)
def light_window(S, k, p, lobe):
    """(window, plane, radius or inf) of the lobe strategy of light k seen from p (`lobe_sampling`): its point
    q = c + a ex + b ey of plane (c, ex, ey, nrm), inside the disk of that radius; NO_WINDOW where it is not
    used."""
    lf = S.li_f
    if not (lobe[4] > 0.0 and _lobe_light(S, k)):
        return NO_WINDOW, NO_PLANE, INF
    plane = _plane(lf, k)
    if S.li_type[k] == D.RECT:
        return lobe_window(p, lobe, plane, lf[k, LF_W], lf[k, LF_H]), plane, INF
    return round_window(p, lobe, plane, lf[k, LF_RADIUS]), plane, lf[k, LF_RADIUS]


@nb.njit(**_JIT)
def sample_ld_lobe(S, L, k, vtx, u):
    """`sample_ld` of light k seen from path vertex vtx for the sample u = (u1, u2); a rect or disk light
    seen from a vertex whose light samples follow its GGX lobe (vtx.lobe: `lobe_sampling.glossy_lobe`)
    is drawn towards that lobe (`lobe_sampling`; none where the point falls
    outside a disk), with the pdf that `lobe_sampling.lobe_pdf` gives a BSDF ray that meets the light."""
    if not _lobe_light(S, k):
        return sample_ld(S, L, k, vtx.p, vtx.ns, u[0], u[1])
    win, plane, lim = light_window(S, k, vtx.p, vtx.lobe)
    if not win[0]:
        return _imaged(S, k, vtx.p, sample_ld(S, L, k, vtx.p, vtx.ns, u[0], u[1]))
    c, ex, ey, nrm = plane
    a = cauchy_sample(win[1], u[0])
    b = cauchy_sample(win[2], u[1])
    if a * a + b * b > lim * lim:
        return NONE
    q = (c[0] + a * ex[0] + b * ey[0], c[1] + a * ex[1] + b * ey[1], c[2] + a * ex[2] + b * ey[2])
    wi, dist, d2 = toward(vtx.p, q)
    cos_l = dot(wi, nrm)
    if not (d2 > 0.0 and cos_l > 0.0):
        return NONE
    lf = S.li_f
    Lr = (lf[k, LF_RAD], lf[k, LF_RAD + 1], lf[k, LF_RAD + 2])
    if F_RECT_TEXTURE and S.li_type[k] == D.RECT:
        Lr = rect_radiance(S, k, a, b, Lr)
    return wi, dist, Lr, lobe_area_pdf(win, a, b) * d2 / cos_l, False


@nb.njit(**_JIT)
def _image_ld(L, k, p, plane, size, u, Lr):
    """`sample_ld` of textured rect light k (plane (c, ex, ey, nrm), size (w, h, area)) seen from p: its point
    drawn by its image (`rect_sampling`), pdf d^2 / cos_l times its density per unit area."""
    a, b, dens = sample_image_point(L, k, size, u[0], u[1])
    if not dens > 0.0:
        return NONE
    c, ex, ey, nrm = plane
    q = (c[0] + a * ex[0] + b * ey[0], c[1] + a * ex[1] + b * ey[1], c[2] + a * ex[2] + b * ey[2])
    return area_ld(p, q, (-nrm[0], -nrm[1], -nrm[2]), size[2] / dens, Lr)


@nb.njit(**_JIT)
def _imaged_at(S, k, q, Le):
    """Emission Le of light k at its point q, times the light's image there (a textured rect:
    `lights.rect_radiance`); Le itself for every other light."""
    if not (F_RECT_TEXTURE and S.li_type[k] == D.RECT and S.li_tex[k] >= 0):
        return Le
    c, ex, ey, nrm = _plane(S.li_f, k)
    a, b = rect_coords(q, c, ex, ey, nrm)
    return rect_radiance(S, k, a, b, Le)


@nb.njit(**_JIT)
def _imaged(S, k, p, sample):
    """A light sample (wi, dist, Le, pdf, delta) of light k seen from p, its emission times the light's image
    where it meets the light (`_imaged_at`)."""
    wi, dist, Le, pdf, delta = sample
    if not (F_RECT_TEXTURE and pdf > 0.0):
        return sample
    return wi, dist, _imaged_at(S, k, (p[0] + dist * wi[0], p[1] + dist * wi[1], p[2] + dist * wi[2]), Le), pdf, delta


@nb.njit(**_JIT)
def _cylinder_ld(lf, k, p, u1, u2, Lr):
    """`sample_ld` of cylinder light k: a point uniformly by area on its side."""
    q, nq = cylinder_point(lf, k, u1, u2)
    return area_ld(p, q, nq, lf[k, LF_AREA], Lr)


@nb.njit(**_JIT)
def near_rect(p, c, ex, ey, nrm, w, h):
    """`spherical_rect` of a rect light seen from p when `sample_ld` samples it in solid angle: p
    nearer its centre than its diagonal (NEAR_FIELD) and the solid angle within [SPHERICAL_MIN,
    SPHERICAL_MAX]; else S = 0 (sampled by area)."""
    v = sub(c, p)
    if dot(v, v) >= NEAR_FIELD * NEAR_FIELD * (w * w + h * h):
        return NO_RECT
    sr = spherical_rect(p, c, ex, ey, nrm, w, h)
    return sr if SPHERICAL_MIN <= sr[0] <= SPHERICAL_MAX else NO_RECT


@nb.njit(**_JIT)
def spherical_rect(p, c, ex, ey, nrm, w, h):
    """The spherical rectangle that the rect light centred at c (unit axes ex, ey, nrm = ex x ey, sides w
    and h, emitting towards -nrm) subtends from p, in the local frame of Urena, Fajardo and King, "An
    Area-Preserving Parametrization for Spherical Rectangles" (EGSR 2013): (S, x0, y0, z0, b0, b1, k0)
    with S its solid angle, (x0, y0, z0) the corner c - w/2 ex - h/2 ey seen from p along (ex, ey, -nrm)
    (z0 < 0), b0, b1 the z components of two edge-plane normals and k0 = 2 pi - g2 - g3.  S = 0 when
    p is not on the emitting side."""
    s = (c[0] - 0.5 * (w * ex[0] + h * ey[0]), c[1] - 0.5 * (w * ex[1] + h * ey[1]),
         c[2] - 0.5 * (w * ex[2] + h * ey[2]))
    dv = sub(s, p)
    z0 = dot(dv, nrm)
    if not z0 > 0.0:
        return NO_RECT
    z0 = -z0                                  # the frame's z axis is -nrm: p sees the corner below it
    x0 = dot(dv, ex)
    y0 = dot(dv, ey)
    x1 = x0 + w
    y1 = y0 + h
    zz = z0 * z0
    # z components of the unit normals of the planes through p and each edge (the others cancel
    # in the dot products between neighbours); the rectangle's interior angles g0..g3 have cosines
    # -n0z n1z, ...; only the sums g0 + g1 and g2 + g3 are needed: one atan2 each
    n0z = -y0 / math.sqrt(zz + y0 * y0)
    n1z = x1 / math.sqrt(zz + x1 * x1)
    n2z = y1 / math.sqrt(zz + y1 * y1)
    n3z = -x0 / math.sqrt(zz + x0 * x0)
    g01 = _angle_sum(-n0z * n1z, -n1z * n2z)
    g23 = _angle_sum(-n2z * n3z, -n3z * n0z)
    k0 = 2.0 * math.pi - g23
    return g01 - k0, x0, y0, z0, n0z, n2z, k0


@nb.njit(**_JIT)
def _angle_sum(ca, cb):
    """acos(ca) + acos(cb), in [0, 2 pi), by one atan2 of the sum's sine and cosine."""
    ca = min(1.0, max(-1.0, ca))
    cb = min(1.0, max(-1.0, cb))
    sa = math.sqrt(1.0 - ca * ca)
    sb = math.sqrt(1.0 - cb * cb)
    g = math.atan2(sa * cb + ca * sb, ca * cb - sa * sb)     # the sum modulo 2 pi, in (-pi, pi]
    if ca + cb < 0.0:                                         # the sum exceeds pi
        return g + 2.0 * math.pi if g < 0.5 * math.pi else g
    if g < -0.5 * math.pi:                                    # pi, with the sine's sign lost
        return g + 2.0 * math.pi
    return max(g, 0.0)


@nb.njit(**_JIT)
def spherical_rect_point(sr, w, h, u1, u2):
    """The point (x, y) of the rectangle (in the frame of `spherical_rect`: x in [x0, x0 + w], y in
    [y0, y0 + h], at height z0) whose direction from p is the sample (u1, u2) drawn uniformly in the
    solid angle S (Urena et al. 2013, section 4)."""
    S, x0, y0, z0, b0, b1, k0 = sr
    au = u1 * S + k0
    sa = math.sin(au)
    xu = 0.0
    if abs(sa) > 1e-300:
        fu = (math.cos(au) * b0 - b1) / sa
        cu = min(1.0 - 1e-15, 1.0 / math.sqrt(fu * fu + b0 * b0))
        if fu < 0.0:
            cu = -cu
        xu = -(cu * z0) / math.sqrt(1.0 - cu * cu)
    xu = min(max(xu, x0), x0 + w)
    dd2 = xu * xu + z0 * z0
    dd = math.sqrt(dd2)
    y1 = y0 + h
    h0 = y0 / math.sqrt(dd2 + y0 * y0)
    h1 = y1 / math.sqrt(dd2 + y1 * y1)
    hv = h0 + u2 * (h1 - h0)
    hv2 = hv * hv
    yv = hv * dd / math.sqrt(1.0 - hv2) if hv2 < 1.0 - 1e-15 else y1
    return xu, min(max(yv, y0), y1)


@nb.njit(**_JIT)
def _spherical_rect_ld(p, sr, frame, size, u, Lr):
    """`sample_ld` of a rect light (its frame (ex, ey, nrm), its size (w, h)) seen from p by its spherical
    rectangle sr, for the sample u = (u1, u2): pdf 1 / S."""
    ex, ey, nrm = frame
    x, y = spherical_rect_point(sr, size[0], size[1], u[0], u[1])
    z = sr[3]
    v = (x * ex[0] + y * ey[0] - z * nrm[0], x * ex[1] + y * ey[1] - z * nrm[1], x * ex[2] + y * ey[2] - z * nrm[2])
    d2 = dot(v, v)
    if not d2 > 0.0:
        return NONE
    d = math.sqrt(d2)
    return (v[0] / d, v[1] / d, v[2] / d), d, Lr, 1.0 / sr[0], False


@nb.njit(**_JIT)
def area_ld(p, q, nq, area, Lr):
    """`sample_ld` of the point q, drawn uniformly by area on a light of that area whose emitting side
    faces along nq, seen from p: NONE unless q's emitting side faces p (pdf d^2 / (cos_l A))."""
    wi, d, d2 = toward(p, q)
    if d2 <= 0.0:
        return NONE
    cos_l = -dot(nq, wi)
    if cos_l <= 0.0:
        return NONE
    return wi, d, Lr, d2 / (cos_l * area), False


# ----------------------------------------------------------------------------- what BSDF rays find
@nb.njit(**_JIT)
def _power(a, b):
    a2 = a * a
    return a2 / (a2 + b * b)


@nb.njit(**_JIT)
def hit_shape(S, L, k, o, d, tmax, p0):
    """(t, pdf) where the ray o + t d, t in (0, tmax), meets the emitting side of light shape k,
    t = -1 if it does not; pdf: the solid-angle pdf of `sample_ld` for that point seen from p0 (the
    path vertex the ray left, which o follows on the same line when the ray passed through
    transparent surfaces)."""
    lf = S.li_f
    t = S.li_type[k]
    if F_LIGHTS & B_CYLINDER and t == D.CYLINDER:
        return _hit_cylinder(lf, k, o, d, tmax, p0)
    if t == D.SPHERE:
        r = lf[k, LF_RADIUS]
        c = _col(lf, k, 3)
        oc = sub(o, c)
        b = dot(oc, d)
        cc = dot(oc, oc) - r * r
        disc = b * b - cc
        if cc <= 0.0 or disc <= 0.0:
            return -1.0, 0.0
        th = -b - math.sqrt(disc)
        if not (0.0 < th < tmax):
            return -1.0, 0.0
        v = sub(c, p0)
        one_minus = sphere_cone(r, dot(v, v))
        if not one_minus > 0.0:
            return -1.0, 0.0
        return th, 1.0 / (2.0 * math.pi * one_minus)
    c, ex, ey, nrm = _plane(lf, k)
    den = dot(d, nrm)
    if den <= 0.0:                       # travelling away from the emitting side
        return -1.0, 0.0
    th = dot(sub(c, o), nrm) / den
    if not (0.0 < th < tmax):
        return -1.0, 0.0
    q = (o[0] + th * d[0], o[1] + th * d[1], o[2] + th * d[2])
    rv = sub(q, c)
    cy = cross(ey, nrm)
    cx = cross(nrm, ex)
    a = dot(rv, cy) / dot(ex, cy)
    b = dot(rv, cx) / dot(ey, cx)
    if t == D.RECT:
        if abs(a) > 0.5 * lf[k, LF_W] or abs(b) > 0.5 * lf[k, LF_H]:
            return -1.0, 0.0
    elif a * a + b * b > lf[k, LF_RADIUS] * lf[k, LF_RADIUS]:
        return -1.0, 0.0
    area = lf[k, LF_AREA]
    if t == D.RECT:
        S = near_rect(p0, c, ex, ey, nrm, lf[k, LF_W], lf[k, LF_H])[0]
        if S > 0.0:
            return th, 1.0 / S
        if image_sampled(L, k):
            area /= image_density(L, k, (lf[k, LF_W], lf[k, LF_H]), a, b)
    v = sub(q, p0)
    d2 = dot(v, v)
    return th, d2 / (den * area)


@nb.njit(**_JIT)
def _hit_cylinder(lf, k, o, d, tmax, p0):
    """`hit_shape` of cylinder light k: the ray entering its side from outside (the caps do not emit;
    a ray from inside the infinite cylinder cannot enter the side)."""
    ax = normalize(_col(lf, k, 0))
    c = _col(lf, k, 3)
    r = lf[k, LF_RADIUS]
    oc = sub(o, c)
    oa = dot(oc, ax)
    da = dot(d, ax)
    op = (oc[0] - oa * ax[0], oc[1] - oa * ax[1], oc[2] - oa * ax[2])
    dp = (d[0] - da * ax[0], d[1] - da * ax[1], d[2] - da * ax[2])
    a2 = dot(dp, dp)
    b = dot(op, dp)
    cc = dot(op, op) - r * r
    disc = b * b - a2 * cc
    if cc <= 0.0 or b >= 0.0 or disc <= 0.0:
        return -1.0, 0.0
    th = cc / (-b + math.sqrt(disc))                 # the nearer root, without cancellation
    if not (0.0 < th < tmax) or abs(oa + th * da) > 0.5 * lf[k, LF_LENGTH]:
        return -1.0, 0.0
    lat = (op[0] + th * dp[0], op[1] + th * dp[1], op[2] + th * dp[2])
    cos_l = -dot(lat, d) / r
    if cos_l <= 0.0:
        return -1.0, 0.0
    q = (o[0] + th * d[0], o[1] + th * d[1], o[2] + th * d[2])
    v = sub(q, p0)
    return th, dot(v, v) / (cos_l * lf[k, LF_AREA])


@nb.njit(**_JIT)
def hit_tolerance(o, te):
    """How far Embree's distance te to a light shape, along a ray from o, may be from the exact one
    (`hit_shape`) for the two to be the same crossing: 1e-4 te (the polygons of round shapes), 1e-6,
    and T_ULPS float32 steps of the ray's coordinates (|o| + te): Embree intersects float32 triangles
    with a float32 ray, so where the light is nearer the ray's origin than its coordinates are large
    (a rect 5e-4 above a floor 5 units from the camera) its t is off by more than 1e-4 te + 1e-6, and
    a tighter test rejected the crossing and lost its light (2.6 % of the floor's there: `tests/
    stability/test_near_lights.py`).  The far side of a sphere light is 2 r cos away: farther unless the
    ray grazes it."""
    m = max(abs(o[0]), abs(o[1]), abs(o[2])) + te
    return 1e-4 * te + 1e-6 + T_ULPS * FLOAT32_EPS * m


@nb.njit(**_JIT)
def shape_mask(L, d):
    """The ray mask of a camera or BSDF ray along d in the path integrator's top level: surfaces, the
    light shapes of group MASK_LIGHT_SHAPES, and each group of one-sided planar lights facing one way
    (`host/light_selection.facing_groups`) whose emitting side d can meet (d . axis above the group's
    bound): a ray cannot see a rect's or disk's emission from behind (`hit_shape` gives it nothing), so it
    does not traverse those shapes and is not continued past them.  Every ray when the scene has no such
    group."""
    fc = L.facing
    if fc.shape[0] == 0:
        return MASK_ALL
    m = MASK_SURFACES | MASK_LIGHT_SHAPES
    for g in range(fc.shape[0]):
        if d[0] * fc[g, 0] + d[1] * fc[g, 1] + d[2] * fc[g, 2] > fc[g, 3]:
            m |= MASK_FACING << g
    return m


@nb.njit(**_JIT)
def shape_emission(S, L, k, ray, te, prev, tl):
    """MIS-weighted radiance of light shape k, which Embree found at distance te along ray = (o, d) (in
    the path integrator's top level: `host/build.path_top`); zero unless the exact test
    `hit_shape` agrees (the emitting side, inside the disk, this crossing of a sphere: its far side is
    a second hit of the same point; a cylinder's side, not the capsule's round caps).  prev = (p0, n0,
    bsdf pdf, mis mode, lobe, share): the vertex the ray left, its normal, the pdf with which its BSDF drew d,
    0 = weight by the power heuristic, 1 = weight 1 (camera ray, delta lobe, or BSDF sampling alone),
    2 = weight 0 (next-event estimation alone), its `lobe_sampling.glossy_lobe` (`sample_ld_lobe`) and the
    diffuse share of its BSDF value along d (`lights.gained`; -1: a camera ray) and whether its light samples were
    chosen by the tile's choice `tl` (`tile_lights.vertex_pmf`)."""
    o, d = ray
    p0, pb, mode, lobe = prev[0], prev[2], prev[3], prev[4]
    if mode == 2:
        return ZERO
    t, pl = hit_shape(S, L, k, o, d, INF, p0)
    if t < 0.0 or abs(t - te) > hit_tolerance(o, te):
        return ZERO
    q = (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])
    if mode == 0 and lobe[4] > 0.0:
        win, plane, lim = light_window(S, k, p0, lobe)
        if win[0]:
            pl = lobe_pdf(win, plane, lim, p0, q)
    w = 1.0 if mode == 1 else _power(pb, vertex_pmf(L, tl, prev, k) * pl)
    Le = (w * S.li_f[k, LF_RAD], w * S.li_f[k, LF_RAD + 1], w * S.li_f[k, LF_RAD + 2])
    return gained(S, k, prev[5], shaped(S, k, d, _imaged_at(S, k, q, Le)))


@nb.njit(**_JIT)
def escaped_emission(S, L, d, prev):
    """MIS-weighted radiance along a ray that leaves the scene: domes and distant lights with an
    angle (prev as in `shape_emission`); the background colour (weight 1: no light samples it) when
    the scene has no dome."""
    p0, n0, pb, mode = prev[0], prev[1], prev[2], prev[3]
    r = 0.0
    g = 0.0
    b = 0.0
    if L.has_dome == 0:
        r = S.background[0]
        g = S.background[1]
        b = S.background[2]
    if mode == 2:
        return r, g, b
    lf = S.li_f
    for j in range(L.infinite.shape[0]):
        k = L.infinite[j]
        if F_LIGHTS & B_DOME and (F_LIGHTS == B_DOME or S.li_type[k] == D.DOME):
            Le = dome_radiance(S, k, d)
            pl = dome_pdf(S, L, k, d, n0)
        else:
            cos_max = lf[k, LF_COS_MAX]
            if dot(d, normalize(_col(lf, k, 2))) < cos_max:
                continue
            omega = 2.0 * math.pi * (1.0 - cos_max)
            Le = (lf[k, LF_RAD] / omega, lf[k, LF_RAD + 1] / omega, lf[k, LF_RAD + 2] / omega)
            pl = 1.0 / omega
        w = 1.0 if mode == 1 else _power(pb, light_pmf(L, p0, n0, k) * pl)
        Le = gained(S, k, prev[5], Le)
        r += w * Le[0]
        g += w * Le[1]
        b += w * Le[2]
    return r, g, b
