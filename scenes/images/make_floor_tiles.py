"""Write floor_1001.png and floor_1002.png, the two UDIM tiles of scenes/emitters.usda's floor (its texture file is
floor_<UDIM>.png): a warm checker of 8 x 16 squares and a cool one of 16 x 32, so that the seam between tiles 1001
(s in [0, 1)) and 1002 (s in [1, 2)) shows where the floor's texture coordinates cross s = 1.  8-bit sRGB PNGs,
128 x 256 (a tile spans 6 x 12 units of the floor: square texels).

    python scenes/images/make_floor_tiles.py
"""
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

W, H = 128, 256
TILES = {1001: (8, (0.55, 0.5, 0.44), (0.4, 0.37, 0.33)), 1002: (16, (0.42, 0.48, 0.55), (0.3, 0.34, 0.4))}
y, x = np.mgrid[0:H, 0:W]
for number, (n, a, b) in TILES.items():
    img = np.where((((x * n) // W + (y * 2 * n) // H) % 2 == 0)[..., None], np.array(a), np.array(b))
    srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * img ** (1 / 2.4) - 0.055).astype(np.float32)
    buf = oiio.ImageBuf(oiio.ImageSpec(W, H, 3, 'uint8'))
    buf.set_pixels(oiio.ROI(0, W, 0, H), np.ascontiguousarray(srgb))
    out = Path(__file__).with_name(f'floor_{number}.png')
    if not buf.write(str(out)):
        raise SystemExit(buf.geterror())
