"""8-bit textures keep their bytes (`description.BytePixels`, `SceneData.tex_bytes`): a quarter of the memory of
their float32 values, read through the table of what each byte decodes to (`images.byte_lut`), so that every value
the kernels read, and every image, is what the float32 path gives, bit for bit.  Checked against the float32 path
computed independently (OpenImageIO's float conversion, then the sRGB decode), on generated images of 1-4 channels
in each colour space and on the corpus's 8-bit images, and by rendering the gallery's textured stages both ways."""
import os
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from rtc.renderer.description import BytePixels, float_textures
from rtc.renderer.host.build import build
from rtc.renderer.host.render import Renderer
from rtc.renderer.images import read_pixels, srgb_decode
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.texture_files import read_texture
from rtc.renderer.usd.stage import read_stage

REPO = Path(__file__).resolve().parents[2]
CORPUS = Path(os.environ.get('RTC_SHARED', REPO.parent / 'shared')) / 'corpus'   # (as tests/interop)


def _png(path, pixels, srgb_tag=None):
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], 'uint8')
    if srgb_tag is not None:
        spec.attribute('oiio:ColorSpace', srgb_tag)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), spec)
    out.write_image(pixels)
    out.close()
    return str(path)


def _float_path(path, colour_space):
    """The float32 values the texture reader gave before it kept bytes: the file as floats, its colour channels
    sRGB-decoded where `colour_space` (or, for 'auto', an 8-bit file without a linear tag) says so."""
    px, spec = read_pixels(path)
    tagged = str(spec.getattribute('oiio:ColorSpace') or '').lower()
    if colour_space == 'sRGB' or (colour_space == 'auto' and (tagged.startswith('srgb') or not tagged)):
        n = min(3, spec.nchannels if spec.nchannels != 2 else 1)
        px[..., :n] = srgb_decode(px[..., :n])
    return px


@pytest.mark.parametrize('channels', [1, 2, 3, 4])
@pytest.mark.parametrize('colour_space', ['auto', 'raw', 'sRGB'])
def test_an_8_bit_image_keeps_its_bytes_and_reads_as_the_float_path(tmp_path, channels, colour_space):
    """Every byte value in every channel: the bytes kept, read as the float32 path reads them, bit for bit."""
    px = np.stack([np.roll(np.arange(256), 37 * c) for c in range(channels)], -1).reshape(16, 16, channels)
    px = px.astype(np.uint8)
    path = _png(tmp_path / 'tex.png', px)
    got = read_texture(path, colour_space)
    assert isinstance(got, BytePixels) and got.data.dtype == np.uint8 and got.data.shape == px.shape
    assert got.srgb == (0 if colour_space == 'raw' else min(3, channels if channels != 2 else 1))
    want = _float_path(path, colour_space)
    assert got.linear().dtype == np.float32 and np.array_equal(got.linear(), want)


def test_a_float_image_keeps_its_floats(tmp_path):
    path = str(tmp_path / 'hdr.exr')
    px = np.random.default_rng(1).uniform(0, 4, (8, 8, 3)).astype(np.float32)
    out = oiio.ImageOutput.create(path)
    out.open(path, oiio.ImageSpec(8, 8, 3, 'float'))
    out.write_image(px)
    out.close()
    got = read_texture(path, 'auto')
    assert isinstance(got, np.ndarray) and got.dtype == np.float32 and np.array_equal(got, px)


def test_the_corpus_8_bit_images_read_as_the_float_path():
    files = sorted(p for p in CORPUS.rglob('*') if p.suffix.lower() in ('.png', '.jpg', '.jpeg'))[:40]
    if not files:
        pytest.skip(f'corpus not found at {CORPUS} (shared/ beside the repository, or set RTC_SHARED)')
    checked = 0
    for f in files:
        for colour_space in ('auto', 'raw'):
            got = read_texture(str(f), colour_space)
            if isinstance(got, BytePixels):
                assert np.array_equal(got.linear(), _float_path(str(f), colour_space)), (f, colour_space)
                checked += 1
    assert checked >= 20


@pytest.mark.parametrize('scene, integrator', [('emitters.usda', 'path'), ('lights.usda', 'path'),
                                               ('lights.usda', 'cook')])
def test_textured_stages_render_from_bytes_as_from_floats(scene, integrator):
    """The gallery's textured stages (an image on a screen, a UDIM floor, a normal map, a RectLight's image): the
    same images from bytes as from floats, bit for bit, with a quarter of the texels' memory."""
    desc = read_stage(str(REPO / 'scenes' / scene))
    assert any(isinstance(t.pixels, BytePixels) or any(isinstance(p, BytePixels) for p in t.tiles)
               for t in desc.textures)
    images, sizes = [], []
    for d in (desc, float_textures(desc)):
        built = build(d)
        sizes.append((built.data.tex_data.nbytes, built.data.tex_bytes.nbytes))
        built.close()
        with Renderer(d, threads=1) as r:
            images.append(r.render(RenderOptions(width=48, height=36, spp=4, integrator=integrator, max_depth=3,
                                                 threads=1)).image)
    assert np.array_equal(images[0], images[1])
    (floats_b, bytes_b), (floats_f, bytes_f) = sizes
    assert bytes_f <= 1 and 4 * bytes_b + floats_b <= floats_f + 4     # every 8-bit texel: 1 byte, not 4
