"""The path integrator's shadow-ray queue (`kernel/path._defer_shadow`): where no surface is see-through
and Embree traces packets with its own kernels (`embree.Device.native_packets`: 16-wide on AVX-512, 8-wide
on AVX2), every shadow ray waits with its light sample's contribution and is traced in a packet of 16.  A
queued shadow ray only decides whether a contribution counts, so the image must be the one the same scene
gives with shadow rays traced one by one: checked by rendering a scene with the queue (forced on, whatever
the CPU, with packets traced 16 and 8 at a time), once with a see-through quad that no ray meets (which turns
the queue off: `shadow_transmittance`), and once with the queue off as on a CPU whose packets are emulated."""
import numpy as np

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer.handmade import look_at, quad, rect_light, scene


def _scene(see_through: bool):
    meshes = [quad(12.0, material=0, path='/floor'),
              quad(1.5, y=1.2, material=1, path='/blocker', center=(0.4, -0.3)),     # a shadow on the floor
              quad(2.0, y=0.6, material=2, path='/shelf', center=(-2.0, 1.0))]        # glossy, lit and shadowing
    materials = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6)),
                 D.Material('/blocker', diffuse=(0.3, 0.5, 0.2)),
                 D.Material('/shelf', diffuse=(0.1, 0.1, 0.1), metallic=1.0, roughness=0.25, specular=(0.9, 0.7, 0.4))]
    if see_through:               # far under the floor and out of view: no camera, shadow or BSDF ray meets it
        meshes.append(quad(0.1, y=-50.0, material=3, path='/veil'))
        materials.append(D.Material('/veil', diffuse=(0.5, 0.5, 0.5), opacity=0.5))
    lights = [rect_light((0.0, 3.0, 0.0), 1.0, 1.0, (8.0, 8.0, 8.0))]
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 4.0, 7.0), (0.0, 0.0, 0.0)))
    return scene([D.Container('/', meshes=meshes)], materials, lights, cam, width=48, height=36)


def _render(see_through: bool, shadow_packets: bool = True, width: int = 16):
    r = Renderer(_scene(see_through))
    r.shadow_packets = shadow_packets
    r.packet_width = width
    try:
        res = r.render(RenderOptions(width=48, height=36, spp=16, integrator='path', max_depth=4, sampler='sobol',
                                     filter='box'))
        return np.asarray(res.image, np.float64), res.stats
    finally:
        r.close()


def test_queued_shadow_rays_give_the_image_of_shadow_rays_traced_alone():
    queued, qs = _render(False)
    alone, s = _render(True)
    assert qs.rays_shadow > 10000 and qs.rays_shadow_packet == qs.rays_shadow      # every shadow ray in a packet
    assert s.rays_shadow_packet == 0                                               # the veil: every one alone
    assert qs.rays_camera == s.rays_camera and qs.rays_secondary == s.rays_secondary
    assert abs(qs.rays_shadow - s.rays_shadow) <= 2       # the same light samples (and a mirror-edge ray or two)
    assert queued.mean() > 0.05 and (queued == 0).mean() < 0.2
    # the same estimate, summed in another order: equal to float rounding, the shadow included
    close = np.isclose(queued, alone, rtol=1e-5, atol=1e-6)
    assert close.mean() > 0.999
    assert abs(queued.mean() / alone.mean() - 1.0) < 1e-5


def test_shadow_rays_alone_where_packets_are_emulated_give_the_same_image():
    alone, s = _render(False, shadow_packets=False)
    for width in (16, 8):
        queued, qs = _render(False, width=width)
        assert s.rays_shadow_packet == 0 and abs(qs.rays_shadow - s.rays_shadow) <= 2
        assert qs.rays_shadow_packet == qs.rays_shadow > 1000
        assert qs.rays_camera == s.rays_camera and qs.rays_secondary == s.rays_secondary
        close = np.isclose(queued, alone, rtol=1e-5, atol=1e-6)
        assert close.mean() > 0.999
        assert abs(queued.mean() / alone.mean() - 1.0) < 1e-5


def test_packets_of_8_and_16_give_the_same_image():
    """The same packets traced as one 16-ray query or two 8-ray ones: the same hits, so the same image
    to the last bit (camera packets and the queue's shadow packets alike)."""
    a, sa = _render(False, width=16)
    b, sb = _render(False, width=8)
    assert sa.rays_shadow_packet == sb.rays_shadow_packet > 1000
    assert np.array_equal(a, b)


def test_the_default_follows_embrees_packet_width():
    from rtc.renderer.host.embree import Device
    with Device() as dev:
        native = dev.native_packets
        width = dev.packet_width
        assert native == (dev.native_ray16 or dev.native_ray8)
        assert width == (16 if dev.native_ray16 or not dev.native_ray8 else 8)
    r = Renderer(_scene(False))
    try:
        assert r.shadow_packets == native and r.packet_width == width
        s = r.render(RenderOptions(width=16, height=12, spp=4, integrator='path', max_depth=2)).stats
        assert (s.rays_shadow_packet == s.rays_shadow) if native else (s.rays_shadow_packet == 0)
        assert s.rays_shadow > 0
    finally:
        r.close()
