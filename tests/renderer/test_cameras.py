"""The packet camera (`cameras.camera_rays`, vectorised loops over the lanes) gives bit for bit the
rays of the scalar `generate_ray`, for every camera model, and the rays are the model's rays."""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.kernel.cameras import C_LENS, camera_table, camera_rays, generate_ray


def _camera(projection='perspective', lens_radius=0.0, focus=5.0, motion=False):
    m = np.eye(4)
    m[:3, :3] = np.array([[0.8, 0.0, 0.6], [0.0, 1.0, 0.0], [-0.6, 0.0, 0.8]])       # turned about y
    m[:3, 3] = (1.0, 2.0, 3.0)
    cam = D.Camera(path='/cam', matrix=m, projection=projection, focal_length=0.5, horizontal_aperture=0.5,
                   vertical_aperture=0.375, lens_radius=lens_radius, focus_distance=focus)
    if motion:
        m1 = m.copy()
        m1[:3, 3] += (0.5, -0.25, 0.125)
        cam.motion = np.array([m, m1])
    return cam


CASES = {'pinhole': {}, 'thin lens': {'lens_radius': 0.2}, 'orthographic': {'projection': 'orthographic'},
         'moving thin lens': {'lens_radius': 0.1, 'motion': True}}


@pytest.mark.parametrize('case', CASES)
def test_packet_rays_equal_scalar_rays(case):
    cam = _camera(**CASES[case])
    table = camera_table(cam, 64, 48, np.array([1.0, 2.0, 3.0]))
    rng = np.random.default_rng(2)
    o, d = np.zeros((3, 16)), np.zeros((3, 16))
    for trial in range(200):
        fx, fy, lu, lv, tm = (rng.random(16) for _ in range(5))
        if trial == 0:             # the lens centre (0/0 in the disk map), its axes and diagonals
            lu[:6] = (0.5, 0.5, 0.75, 0.25, 0.75, 0.9)
            lv[:6] = (0.5, 0.8, 0.5, 0.25, 0.75, 0.1)
        n = 16 if trial % 3 else int(rng.integers(1, 16))
        o[:] = d[:] = np.nan
        camera_rays(table, n, fx, fy, (lu, lv), tm, o, d)
        for j in range(n):
            wo, wd = generate_ray(table, fx[j], fy[j], lu[j], lv[j], tm[j])
            assert tuple(o[:, j]) == wo and tuple(d[:, j]) == wd
        assert np.isnan(o[:, n:]).all() and np.isnan(d[:, n:]).all()


def test_thin_lens_rays_meet_at_the_focal_plane():
    """Every lens sample's ray through one film point passes the pinhole ray's point on the plane of
    focus, and starts on the lens disk."""
    cam = _camera(lens_radius=0.2, focus=5.0)
    table = camera_table(cam, 64, 48, np.zeros(3))
    assert table[C_LENS] == 0.2
    fx, fy = np.full(16, 0.3), np.full(16, 0.7)
    rng = np.random.default_rng(4)
    o, d = np.zeros((3, 16)), np.zeros((3, 16))
    camera_rays(table, 16, fx, fy, (rng.random(16), rng.random(16)), np.zeros(16), o, d)
    pin_o, pin_d = generate_ray(camera_table(_camera(), 64, 48, np.zeros(3)), 0.3, 0.7, 0.5, 0.5, 0.0)
    R = cam.matrix[:3, :3]
    view = -R[:, 2]
    focus_point = np.array(pin_o) + np.array(pin_d) * 5.0 / float(np.dot(pin_d, view))
    for j in range(16):
        assert np.linalg.norm(d[:, j]) == pytest.approx(1.0, abs=1e-15)
        local = R.T @ (o[:, j] - cam.matrix[:3, 3])
        assert math.hypot(local[0], local[1]) <= 0.2 + 1e-12 and abs(local[2]) < 1e-12
        t = float(np.dot(focus_point - o[:, j], view)) / float(np.dot(d[:, j], view))
        assert np.allclose(o[:, j] + t * d[:, j], focus_point, atol=1e-12)
