"""Write downlight.ies, the gallery's IES profile (scenes/lights.usda's sconce): an LM-63-2002 file of photometric
type C, rotationally symmetric (one horizontal angle), whose candela peak in a ring at 35 degrees off the nadir and
fall to 0 from 55 to 62 degrees: the scallop a downlight paints on a wall beside it.

    python scenes/ies/make_downlight.py
"""
from pathlib import Path

import numpy as np

vertical = np.arange(0.0, 90.01, 2.5)
ring = 0.3 + 0.7 * np.exp(-((vertical - 35.0) / 15.0) ** 2)
cut = np.clip((62.0 - vertical) / 7.0, 0.0, 1.0)
candela = 1000.0 * ring * cut * cut * (3.0 - 2.0 * cut)

lines = ['IESNA:LM-63-2002', '[TEST] rtc gallery', '[MANUFAC] rtc (synthetic)', '[LUMCAT] DOWNLIGHT-35',
         '[LUMINAIRE] downlight with a 35-degree ring and a 60-degree cut-off', 'TILT=NONE',
         f'1 -1 1 {len(vertical)} 1 1 2 0 0 0', '1.0 1.0 20']
for i in range(0, len(vertical), 10):
    lines.append(' '.join(f'{v:g}' for v in vertical[i:i + 10]))
lines.append('0')
for i in range(0, len(candela), 10):
    lines.append(' '.join(f'{c:.1f}' for c in candela[i:i + 10]))
Path(__file__).with_name('downlight.ies').write_text('\n'.join(lines) + '\n')
