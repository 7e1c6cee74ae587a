"""A textured rect light's points drawn by its image: the piecewise-constant distribution over the image
that `host/light_images.py` tabulates (texels weighted by luminance; one marginal CDF over rows, one
conditional CDF per row), its inverse (`sample_image_point`) and its density per unit area of the rect
(`image_density`).

`light_sampling.sample_ld` draws a textured rect's point this way where it would draw it uniformly by area:
seen from farther than the rect's diagonal (`light_sampling.NEAR_FIELD`), where the solid angle a unit of the
rect's area subtends varies little over it, so that the density follows the emission, image and all.  Nearer,
the point stays uniform in the rect's solid angle (the image a factor of its emission), and from a glossy
vertex it follows the lobe (`lobe_sampling`): each vertex takes one strategy, not a mixture, so that the
light sample keeps the stratification of its two numbers (`lobe_sampling.LOBE_SHARE_MIN`).

The image lies on the rect as `lights.rect_radiance` reads it: its column fraction s = 1/2 - a / w and its row
fraction from the top r = 1/2 - b / h at the rect's point c + a ex + b ey (the top-left corner at local
(+X, +Y)).
"""
import numba as nb

from .dome_sampling import invert
from .features import F_RECT_TEXTURE
from .jit import SHADING_INLINE_JIT as _JIT


@nb.njit(**_JIT)
def sample_image_point(L, k, size, u1, u2):
    """(a, b, density per unit of the unit square) of the point of rect light k (size = (w, h)) that the
    sample (u1, u2) draws from its image's distribution; density 0: none (an empty row or column)."""
    moff, coff, w, h = L.image_i[k, 0], L.image_i[k, 1], L.image_i[k, 2], L.image_i[k, 3]
    y, fy, pm = invert(L.image_cdf, moff, h, u2)
    if not pm > 0.0:
        return 0.0, 0.0, 0.0
    x, fx, pc = invert(L.image_cdf, coff + y * (w + 1), w, u1)
    if not pc > 0.0:
        return 0.0, 0.0, 0.0
    s = (x + fx) / w
    r = (y + fy) / h
    return (0.5 - s) * size[0], (0.5 - r) * size[1], pm * pc * w * h


@nb.njit(**_JIT)
def image_density(L, k, size, a, b):
    """The density per unit of the unit square with which `sample_image_point` draws the point (a, b) of rect
    light k (size = (w, h)); divided by the rect's area, its density per unit area."""
    moff, coff, w, h = L.image_i[k, 0], L.image_i[k, 1], L.image_i[k, 2], L.image_i[k, 3]
    x = min(max(int((0.5 - a / size[0]) * w), 0), w - 1)
    y = min(max(int((0.5 - b / size[1]) * h), 0), h - 1)
    row = coff + y * (w + 1)
    pm = L.image_cdf[moff + y + 1] - L.image_cdf[moff + y]
    pc = L.image_cdf[row + x + 1] - L.image_cdf[row + x]
    return pm * pc * w * h


@nb.njit(**_JIT)
def image_sampled(L, k):
    """Whether light k (a rect) has an image whose distribution `sample_image_point` draws from."""
    return F_RECT_TEXTURE and L.image_i[k, 0] >= 0
