"""Writes bricks_normal.png, the tangent-space normal map of `emitters.usda`'s brick wall: 4 courses of 2 bricks
(each course offset by half a brick), bevelled into mortar joints.  A height field h(s, t) (1 on a brick's face,
falling over the bevel to 0 in the joint) becomes the normal (-dh/ds, -dh/dt, 1) normalised, stored as
(n + 1) / 2 in 8-bit RGB, row 0 at t = 1 (the top), to be read raw with scale 2 and bias -1.

    python scenes/images/make_bricks_normal.py
"""
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

SIZE, COURSES, BRICKS, JOINT, BEVEL, RELIEF = 512, 4, 2, 0.012, 0.02, 0.03


def heights(n: int) -> np.ndarray:
    """h[t index, s index] over [0, 1)^2, t growing with the first index."""
    s, t = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n)
    course = np.floor(t * COURSES)
    u = (s * BRICKS + 0.5 * (course % 2)) % 1.0 / BRICKS        # position along the course, in texture units
    v = (t * COURSES) % 1.0 / COURSES
    edge = np.minimum(np.minimum(u, 1.0 / BRICKS - u), np.minimum(v, 1.0 / COURSES - v))
    return RELIEF * np.clip((edge - JOINT) / BEVEL, 0.0, 1.0)


def main() -> None:
    h = heights(SIZE)
    dh_dt, dh_ds = np.gradient(h, 1.0 / SIZE)
    n = np.stack([-dh_ds, -dh_dt, np.ones_like(h)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    pixels = np.round((n[::-1] + 1.0) / 2.0 * 255.0).astype(np.uint8)            # row 0: the top (t = 1)
    out = Path(__file__).with_name('bricks_normal.png')
    buf = oiio.ImageBuf(oiio.ImageSpec(SIZE, SIZE, 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(0, SIZE, 0, SIZE, 0, 1, 0, 3), np.ascontiguousarray(pixels))
    if not buf.write(str(out)):
        raise SystemExit(buf.geterror())


if __name__ == '__main__':
    main()
