"""The distribution ray tracer against closed-form answers (hand-built scenes, no USD)."""
import math

import numba
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.render import RenderOptions, Renderer, render
from rtc.renderer.kernel.shapes import surface
from rtc.renderer.kernel.trace import hit_of, intersect1, new_ray_buffer

from tests.renderer.handmade import look_at, ortho_down, point_light, quad, rect_light, scene, static_instances, translate

LAMBERT = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))
BLACK = D.Material('/black', model=D.LAMBERTIAN, diffuse=(0.0, 0.0, 0.0))


def pixel_centers(n, width):
    return -width / 2 + width * (np.arange(n) + 0.5) / n


def pixel_average(fn, n, width, sub=8):
    """Average of fn(x, z) over each pixel of an n x n orthographic view of [-w/2, w/2]^2 (rows: z)."""
    off = (np.arange(sub) + 0.5) / sub - 0.5
    px = width / n
    xs = (pixel_centers(n, width)[:, None] + off[None, :] * px).ravel()
    X, Z = np.meshgrid(xs, xs)
    return fn(X, Z).reshape(n, sub, n, sub).mean(axis=(1, 3))


def test_point_light_inverse_square_and_cosine():
    h, J, n, width = 1.5, 4.0, 24, 3.0
    desc = scene([D.Container('/', meshes=[quad(40.0)])], [LAMBERT], [point_light((0, h, 0), (J, J, J))],
                 ortho_down(width=width), width=n, height=n)
    img = render(desc, RenderOptions(spp=64, sampler='sobol', filter='box')).image[..., 0]
    ref = pixel_average(lambda x, z: 0.5 * J * h / (h * h + x * x + z * z) ** 1.5, n, width)
    assert np.max(np.abs(img / ref - 1)) < 1e-3


def polygon_irradiance(x, z, corners, L):
    """Lambert's formula: irradiance at (x, 0, z) (normal +Y) from a uniform polygon of radiance L."""
    E = np.zeros_like(x)
    r = [np.stack([c[0] - x, np.full_like(x, c[1]), c[2] - z], -1) for c in corners]
    for i in range(len(r)):
        a, b = r[i], r[(i + 1) % len(r)]
        cr = np.cross(a, b)
        ang = np.arccos(np.clip((a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1), -1, 1))
        E += ang * cr[..., 1] / np.linalg.norm(cr, axis=-1)
    return L * np.abs(E) / 2


def test_rect_light_matches_lambert_polygon_formula():
    h, a, b, Lr, n, width = 1.0, 1.2, 0.8, 2.0, 16, 4.0
    light = rect_light((0.0, h, 0.0), a, b, (Lr, Lr, Lr))
    desc = scene([D.Container('/', meshes=[quad(40.0)])], [LAMBERT], [light], ortho_down(width=width),
                 width=n, height=n)
    img = render(desc, RenderOptions(spp=4096, sampler='sobol', filter='box')).image[..., 0]
    # light local X (width a) = world X, local Y (height b) = world -Z
    corners = [(-a / 2, h, -b / 2), (a / 2, h, -b / 2), (a / 2, h, b / 2), (-a / 2, h, b / 2)]
    ref = pixel_average(lambda x, z: 0.5 * polygon_irradiance(x, z, corners, Lr), n, width, sub=6)
    assert np.max(np.abs(img / ref - 1)) < 5e-3


def ellipsoid_scene(n=48, width=4.0):
    """Unit sphere placed with the lecture's ellipsoid matrix, black, over a white background,
    seen by an orthographic camera looking down -Z."""
    m = np.array([[0.5, 0, 0, 0], [0, 1.5, 0, 1.5], [0, 0, 1, -4], [0, 0, 0, 1]], float)
    cont = D.Container('/proto', spheres=[D.Sphere('/proto/s', 1.0, np.eye(4), material=0)])
    cam = D.Camera('/cam', matrix=translate(0, 1.5, 10), projection='orthographic',
                   horizontal_aperture=width, vertical_aperture=width)
    return scene([cont], [BLACK], [], cam, instances=static_instances(matrices=[m]), width=n, height=n,
                 background=(1, 1, 1)), m


def test_instanced_ellipsoid_silhouette_is_analytic():
    desc, m = ellipsoid_scene()
    n, width = 48, 4.0
    img = render(desc, RenderOptions(spp=256, sampler='sobol', filter='box')).image[..., 0]
    coverage = 1.0 - img
    xs = pixel_centers(n, width)
    sub = (np.arange(16) + 0.5) / 16 - 0.5
    X = (xs[:, None] + sub[None] * width / n).ravel()
    Y = (-xs[:, None] + sub[None] * width / n).ravel()          # row 0 is the top
    GX, GY = np.meshgrid(X, Y)
    inside = (GX / 0.5) ** 2 + (GY / 1.5) ** 2 <= 1.0               # camera centred on y = 1.5
    ref = inside.reshape(n, 16, n, 16).mean(axis=(1, 3))
    assert np.max(np.abs(coverage - ref)) < 0.08
    area = coverage.sum() * (width / n) ** 2
    assert area == pytest.approx(math.pi * 0.5 * 1.5, rel=5e-3)


@numba.njit
def _hit_normals(S, scene_handle, origins, dirs, out_p, out_n):
    f, u = new_ray_buffer()
    m = np.empty((3, 4))
    m32 = np.empty(12, np.float32)
    for i in range(origins.shape[0]):
        o = (origins[i, 0], origins[i, 1], origins[i, 2])
        d = (dirs[i, 0], dirs[i, 1], dirs[i, 2])
        out_n[i, 0] = np.nan
        if intersect1(scene_handle, f, u, o, d, 0.0, np.inf, 0.0):
            p, ng, ns, st, g, mat = surface(S, scene_handle, hit_of(f, u), o, d, 0.0, m, m32)
            for k in range(3):
                out_p[i, k] = p[k]
                out_n[i, k] = ng[k]


@pytest.mark.parametrize('mirror', [False, True])
def test_normals_of_scaled_and_mirrored_instances_are_analytic(mirror):
    """World normal of a unit sphere under rotation x non-uniform scale (x mirror) = L^-T n."""
    rng = np.random.default_rng(1)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    L = q @ np.diag([3.0, 0.3, 1.0]) @ (np.diag([-1.0, 1, 1]) if mirror else np.eye(3))
    m = np.eye(4)
    m[:3, :3] = L
    m[:3, 3] = (0.5, -0.2, 0.3)
    cont = D.Container('/p', spheres=[D.Sphere('/p/s', 1.0, np.eye(4), material=0)])
    cam = D.Camera('/cam', matrix=look_at((0, 0, 10), (0, 0, 0)))
    desc = scene([cont], [LAMBERT], [], cam, instances=static_instances(matrices=[m]))
    b = build(desc)
    try:
        n = 2000
        dirs = rng.normal(size=(n, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        target = m[:3, 3] - b.origin + 0.5 * rng.uniform(-1, 1, size=(n, 3))
        origins = target - 20.0 * dirs
        P = np.zeros((n, 3))
        N = np.zeros((n, 3))
        _hit_normals(b.data, b.handle, origins, dirs, P, N)
        hit = ~np.isnan(N[:, 0])
        assert hit.sum() > 200
        Linv = np.linalg.inv(L)
        p_obj = (P[hit] + b.origin - m[:3, 3]) @ Linv.T
        assert np.allclose(np.linalg.norm(p_obj, axis=1), 1.0, atol=1e-5)        # on the ellipsoid
        n_ref = p_obj @ Linv                                                    # (L^-T p_obj) as rows
        n_ref /= np.linalg.norm(n_ref, axis=1)[:, None]
        assert np.max(np.linalg.norm(N[hit] - n_ref, axis=1)) < 1e-5           # outward, analytic
    finally:
        b.close()


def box_mesh(material=0):
    p = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [(a, b, c) for f in faces for (a, b, c) in ((f[0], f[1], f[2]), (f[0], f[2], f[3]))]
    return D.Mesh('/box', points=p, triangles=np.array(tris, np.int32), material=material)


def test_instanced_and_flattened_scenes_render_identically():
    rng = np.random.default_rng(7)
    mats = []
    for k in range(4):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        m = np.eye(4)
        m[:3, :3] = q @ np.diag(rng.uniform(0.2, 0.8, 3))
        m[:3, 3] = (2.2 * k - 3.3, 0.8, 0)
        mats.append(m)
    floor = quad(20.0, y=-0.5, material=0, path='/floor')
    lights = [point_light((2, 6, 5), (40, 40, 40))]
    cam = look_at((0, 3, 9), (0, 0.5, 0))
    cam_ = D.Camera('/cam', matrix=cam, focal_length=5.0, horizontal_aperture=4.0, vertical_aperture=3.0)
    inst = D.Instances(container=np.array([0, 1, 1, 1, 1], np.int32),
                       matrices=np.stack([np.eye(4)] + mats)[:, None],
                       material_set=np.zeros(5, np.int32), material_sets=[()])
    blinn = D.Material('/b', model=D.BLINN_PHONG, diffuse=(0.7, 0.3, 0.2), specular=(0.4, 0.4, 0.4), exponent=40)
    a = scene([D.Container('/', meshes=[floor]), D.Container('/p', meshes=[box_mesh(1)])], [LAMBERT, blinn],
              lights, cam_, instances=inst, width=64, height=48)
    flat_meshes = [floor]
    for m in mats:
        b = box_mesh(1)
        b.points = b.points @ m[:3, :3].T + m[:3, 3]
        flat_meshes.append(b)
    f = scene([D.Container('/', meshes=flat_meshes)], [LAMBERT, blinn], lights, cam_, width=64, height=48)
    opts = RenderOptions(spp=8, sampler='sobol', seed=3)
    ia, fa = render(a, opts).image, render(f, opts).image
    diff = np.abs(ia - fa)
    assert np.mean(diff) < 2e-4
    assert np.quantile(diff, 0.995) < 1e-3


def test_mirror_reflects_to_the_analytic_position():
    """Orthographic view at 45 degrees onto a mirror floor; a lit red wall at z = -2, 1 unit tall,
    appears in the mirror exactly where reflected rays reach it."""
    mirror = D.Material('/mirror', model=D.MIRROR)
    red = D.Material('/red', model=D.LAMBERTIAN, diffuse=(1.0, 0.0, 0.0))
    wall = D.Mesh('/wall', points=np.array([[-5, 0, -2], [5, 0, -2], [5, 1, -2], [-5, 1, -2]], float),
                  triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=1)
    floor = quad(40.0, y=0.0, material=0, path='/floor')
    # camera looks along (0, -1, -1)/sqrt(2); screen up = (0, 1, -1)/sqrt(2)
    s = 1 / math.sqrt(2)
    cm = np.eye(4)
    cm[:3, 0] = (1, 0, 0)
    cm[:3, 1] = (0, s, -s)
    cm[:3, 2] = (0, s, s)
    cm[:3, 3] = (0, 5.0, 5.0)                    # ray through the film centre hits the floor at z = 0
    n, width = 64, 4.0
    cam = D.Camera('/cam', matrix=cm, projection='orthographic', horizontal_aperture=width, vertical_aperture=width)
    desc = scene([D.Container('/', meshes=[floor, wall])], [mirror, red], [point_light((0, 3, 3), (20, 20, 20))],
                 cam, width=n, height=n)
    img = render(desc, RenderOptions(spp=16, sampler='sobol', filter='box')).image
    col = img[:, n // 2, 0]
    # film row j (0 = top) is offset t = H/2 - H (j + 0.5)/n along screen-up; the ray hits the floor at
    # z = -sqrt(2) t, reflects towards (0, 1, -1) and meets the wall plane at height z + 2 when z > -2.
    t = width / 2 - width * (np.arange(n) + 0.5) / n
    z = -math.sqrt(2) * t
    height_on_wall = z + 2.0
    expect_red = (height_on_wall > 0.02) & (height_on_wall < 0.98) & (z > -2 + 0.02)
    expect_dark = (height_on_wall > 1.02) | (height_on_wall < -0.02)
    # the wall itself is seen directly above row where z < -2 (camera sees wall front): exclude
    direct = z < -2 + 1.0 + 0.05
    assert np.all(col[expect_red & ~direct] > 0.05)
    assert np.all(col[expect_dark & ~direct] < 1e-6)


def test_seed_gives_bit_identical_images_for_any_thread_count_and_pass_split():
    desc, _ = ellipsoid_scene(n=40)
    desc.lights.append(point_light((0, 5, 5), (30, 30, 30)))
    desc.materials[0] = LAMBERT
    base = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = render(desc, RenderOptions(spp=12, seed=11, sampler='cmj')).image
        numba.set_num_threads(base)
        with Renderer(desc) as r:
            many = r.render(RenderOptions(spp=12, seed=11, sampler='cmj', pass_seconds=1e-9)).image
    finally:
        numba.set_num_threads(base)
    assert np.array_equal(one, many)


def test_partial_packets_and_many_lights_stay_bit_identical():
    """Odd image sizes and sample counts leave packets partly filled at tile edges, and several
    lights (an area light among point lights) put more shadow rays in the queue than one packet
    holds: the image must not depend on how (pixel, sample) pairs were grouped into packets."""
    desc, _ = ellipsoid_scene(n=13, width=1.0)             # the ellipsoid fills about half the frame
    desc.lights.append(point_light((0, 5, 5), (30, 30, 30)))
    desc.lights.append(point_light((-4, 3, 2), (10, 12, 8)))
    desc.lights.append(rect_light((0, 4, 0), 2.0, 1.5, (3, 3, 3)))
    desc.materials[0] = LAMBERT
    opts = dict(width=13, height=7, spp=5, seed=3, sampler='sobol')
    base = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = render(desc, RenderOptions(**opts)).image
        numba.set_num_threads(base)
        with Renderer(desc) as r:
            passes = r.render(RenderOptions(**opts, pass_seconds=1e-9)).image
            assert r.render(RenderOptions(**opts)).stats.rays_shadow > 13 * 7 * 5    # several per sample
    finally:
        numba.set_num_threads(base)
    assert one.shape == (7, 13, 3) and np.all(np.isfinite(one)) and one.max() > 0
    assert np.array_equal(one, passes)


def test_lens_sincos_polynomial_matches_libm():
    """The thin-lens disk map's quarter-range sine/cosine polynomial is exact to double rounding,
    and the concentric map keeps every lens sample on the unit disk."""
    from rtc.renderer.kernel.cameras import _concentric_disk
    from rtc.renderer.kernel.vecmath import sincos_quarter
    xs = np.linspace(-math.pi / 4, math.pi / 4, 20001)
    for x in xs:
        s, c = sincos_quarter(x)
        assert abs(s - math.sin(x)) <= 2.3e-16 and abs(c - math.cos(x)) <= 2.3e-16
    rng = np.random.default_rng(3)
    for u, v in rng.random((5000, 2)):
        x, y = _concentric_disk(u, v)
        r = max(abs(2 * u - 1), abs(2 * v - 1))          # the concentric map's radius
        assert abs(math.hypot(x, y) - r) <= 1e-15


def test_turn_is_cos_and_sin_of_a_full_turn_to_double_rounding():
    """`vecmath.turn(u)` (the path samplers' azimuths, without libm) equals (cos 2 pi u, sin 2 pi u)
    computed in extended precision, on every quadrant and its edges."""
    from rtc.renderer.kernel.vecmath import turn
    rng = np.random.default_rng(5)
    us = np.concatenate([np.arange(0, 1, 1 / 512), rng.random(5000),
                         [np.nextafter(1.0, 0.0), np.nextafter(0.25, 0.0), np.nextafter(0.5, 1.0), 5e-324]])
    two_pi = 2 * np.longdouble('3.14159265358979323846264338327950288')
    for u in us:
        c, s = turn(float(u))
        a = np.longdouble(u) * two_pi
        assert abs(c - np.cos(a)) <= 2.5e-16 and abs(s - np.sin(a)) <= 2.5e-16, u
    assert turn(0.25) == (0.0, 1.0) and turn(0.5) == (-1.0, 0.0) and turn(0.75) == (0.0, -1.0)
