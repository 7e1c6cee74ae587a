"""rtc.renderer.kernel.tables: the one declaration of the table columns, read by the kernels and
written by the builder."""
import numpy as np

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.kernel import tables as T
from tests.renderer.handmade import ortho_down, quad, rect_light, scene


def test_offsets_are_the_packed_declaration():
    """Offsets are the running sums of the declared widths (the layout of rtc 7f10cee, whose
    hand-numbered columns these replace)."""
    assert [T.MF_KD, T.MF_KS, T.MF_EXP, T.MF_MIRROR, T.MF_ROUGH, T.MF_IOR, T.MF_ATTEN, T.MF_EMIT, T.MF_METAL,
            T.MF_OPACITY, T.MF_SPECWF, T.MF_CLEARCOAT, T.MF_CC_ROUGH, T.MF_OPACITY_CUT, T.MF_GAIN] == \
        [0, 3, 6, 7, 8, 9, 10, 13, 16, 17, 18, 19, 20, 21, 22]
    assert T.MAT_F_COLS == 24 and T.MAT_I_COLS == 16
    assert (T.MI_MODEL, T.MI_DIFFUSE_TEX, T.MI_SPECULAR_TEX, T.MI_EMISSION_TEX, T.MI_VERTEX_COLOR, T.MI_SCALAR_TEX,
            T.MI_SCALAR_CH, T.MI_NORMAL_TEX) == (0, 1, 2, 3, 4, 5, 10, 15)
    assert [T.LF_M, T.LF_RAD, T.LF_RADIUS, T.LF_W, T.LF_H, T.LF_COS_MAX, T.LF_AREA, T.LF_COURSE, T.LF_COURSE_I,
            T.LF_LENGTH, T.LF_SHAPED, T.LF_CONE, T.LF_FOCUS, T.LF_TINT, T.LF_IES, T.LF_GAIN] == \
        [0, 12, 15, 16, 17, 18, 19, 20, 21, 24, 25, 26, 28, 29, 32, 35]
    assert T.LI_F_COLS == 37
    assert [T.C_M, T.C_M1, T.C_ORTHO, T.C_HALF_W, T.C_HALF_H, T.C_OFF_X, T.C_OFF_Y, T.C_LENS, T.C_FOCUS, T.C_NEAR,
            T.C_FAR, T.C_MOVING] == [0, 12, *range(24, 34)]
    assert T.CAM_COLS == 34
    assert (T.TI_OFFSET, T.TI_WRAP_T, T.TI_UDIM, T.TI_UDIM_ROWS, T.TI_BYTES, T.TEX_I_COLS) == (0, 5, 6, 7, 8, 9)
    assert (T.TF_SCALE, T.TF_BIAS, T.TF_XF, T.TEX_F_COLS) == (0, 4, 8, 14)
    for t in T.TABLES:
        ends = [t.offset[name] + w for name, w in t.fields]
        assert ends[-1] == t.width and [0, *ends[:-1]] == [t.offset[name] for name, _ in t.fields]


def test_write_places_every_field():
    t = T.Table('X', [('A', 1), ('B', 3), ('C', 2)])
    row = np.zeros(t.width)
    t.write(row, B=(1.0, 2.0, 3.0), A=7.0, C=(8.0, 9.0))
    assert row.tolist() == [7.0, 1.0, 2.0, 3.0, 8.0, 9.0]
    assert t.constants() == {'X_A': 0, 'X_B': 1, 'X_C': 4}


def test_builder_writes_through_the_declaration():
    """A material and a rect light land in the columns the kernels read."""
    mat = D.Material(path='/m', model=D.BLINN_PHONG, diffuse=(0.1, 0.2, 0.3), specular=(0.4, 0.5, 0.6),
                     exponent=12.0, ior=1.5, emission=(0.0, 0.0, 2.0))
    light = rect_light((0.0, 4.0, 0.0), 2.0, 3.0, (1.0, 2.0, 3.0))
    desc = scene([D.Container(key='/', meshes=[quad()])], [mat], [light], ortho_down(y=5.0))
    b = build(desc)
    try:
        mf, li = b.data.mat_f[0], b.data.li_f[0]
        np.testing.assert_array_equal(mf[T.MF_KD:T.MF_KD + 3], np.float32([0.1, 0.2, 0.3]))
        np.testing.assert_array_equal(mf[T.MF_KS:T.MF_KS + 3], np.float32([0.4, 0.5, 0.6]))
        assert mf[T.MF_EXP] == 12.0 and mf[T.MF_IOR] == 1.5 and mf[T.MF_EMIT + 2] == 2.0
        assert b.data.mat_i[0, T.MI_MODEL] == D.BLINN_PHONG and b.data.mat_i[0, T.MI_DIFFUSE_TEX] == -1
        assert li[T.LF_RAD:T.LF_RAD + 3].tolist() == [1.0, 2.0, 3.0]
        assert li[T.LF_AREA] == 6.0 and li[T.LF_W] == 2.0 and li[T.LF_H] == 3.0
        # light-to-world rows, camera-relative (the camera sits at y = 5): local +Z = world +Y
        assert li[T.LF_M:T.LF_M + 12].tolist() == [1, 0, 0, 0, 0, 0, 1, -1, 0, -1, 0, 0]
    finally:
        b.close()
