"""Write sign.png, the image of the gallery's lit sign (scenes/lights.usda's RectLight "Sign"): the letters RTC in
a 5 x 7 block font, warm neon on a dark panel.  The letters read left to right from the side the light shines on
(UsdLux puts the image's top-left corner at the light's local (+X, +Y)), so the sign shows the convention.  An
8-bit sRGB PNG, 126 x 66 (21 x 11 cells of 6 pixels).

    python scenes/images/make_sign.py
"""
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

GLYPHS = {'R': ['11110', '10001', '10001', '11110', '10100', '10010', '10001'],
          'T': ['11111', '00100', '00100', '00100', '00100', '00100', '00100'],
          'C': ['01111', '10000', '10000', '10000', '10000', '10000', '01111']}
CELL = 6
cells = np.zeros((11, 21), bool)
for i, letter in enumerate('RTC'):
    cells[2:9, 2 + 6 * i:7 + 6 * i] = np.array([[c == '1' for c in row] for row in GLYPHS[letter]])
img = np.where(cells[..., None], np.array([1.0, 0.45, 0.12]), np.array([0.02, 0.02, 0.025]))
img = np.repeat(np.repeat(img, CELL, 0), CELL, 1).astype(np.float32)
srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * img ** (1 / 2.4) - 0.055).astype(np.float32)
h, w = img.shape[:2]
buf = oiio.ImageBuf(oiio.ImageSpec(w, h, 3, 'uint8'))
buf.set_pixels(oiio.ROI(0, w, 0, h), np.ascontiguousarray(srgb))
out = Path(__file__).with_name('sign.png')
if not buf.write(str(out)):
    raise SystemExit(buf.geterror())
