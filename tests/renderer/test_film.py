"""Film accumulation, checkpoints, atomic OpenImageIO output, sRGB encoding, metrics."""
import os
import stat

import numpy as np
import OpenImageIO as oiio
import pytest

from rtc.renderer.host import film as fm
from rtc.renderer.host import metrics
from rtc.renderer.host.film import Film, FilmError, read_image, write_image

META = {'rtc:spp': 64, 'rtc:sampler': 'sobol', 'rtc:seconds': 3.25, 'rtc:rays': 19_700_000_000,
        'rtc:seed': 7, 'Software': 'rtc 0.1.0'}


def files(d):
    return sorted(os.listdir(d))


def attribs(path):
    inp = oiio.ImageInput.open(str(path))
    try:
        return {a.name: a.value for a in inp.spec().extra_attribs}, inp.spec()
    finally:
        inp.close()


def random_image(h=5, w=7, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.random((h, w, 3)) * 4 - 0.5).astype(np.float32)      # HDR, some negatives


# --------------------------------------------------------------------------- EXR
def test_exr_round_trip_exact_and_metadata(tmp_path):
    img = random_image()
    img[0, 0] = [1e-8, 65504.0, 1e6]
    p = tmp_path / 'out.exr'
    assert write_image(p, img, META) == 0
    assert files(tmp_path) == ['out.exr']
    back = read_image(p)
    assert back.dtype == np.float32 and back.shape == img.shape
    assert np.array_equal(back, img)
    a, spec = attribs(p)
    assert spec.format == oiio.TypeDesc('float')
    assert a['rtc:spp'] == 64 and a['rtc:sampler'] == 'sobol' and a['rtc:seed'] == 7
    assert a['rtc:seconds'] == pytest.approx(3.25)
    assert a['rtc:rays'] == pytest.approx(19.7e9)
    assert a['Software'] == 'rtc 0.1.0'


def test_exr_half(tmp_path):
    img = random_image()
    p = tmp_path / 'h.exr'
    write_image(p, img, exr_half=True)
    _, spec = attribs(p)
    assert spec.format == oiio.TypeDesc('half')
    assert np.array_equal(read_image(p), img.astype(np.float16).astype(np.float32))


def test_nonfinite_replaced_and_counted(tmp_path):
    img = random_image()
    img[1, 2, 0] = np.nan
    img[3, 4, 1] = np.inf
    img[0, 0, 2] = -np.inf
    p = tmp_path / 'nan.exr'
    with pytest.warns(RuntimeWarning, match='3 non-finite'):
        assert write_image(p, img) == 3
    back = read_image(p)
    assert np.all(np.isfinite(back)) and back[1, 2, 0] == 0 and back[3, 4, 1] == 0
    assert attribs(p)[0]['rtc:nonfinite'] == 3


# --------------------------------------------------------------------------- sRGB / 8-bit
def test_srgb_encoding_known_values(tmp_path):
    # linear values -> expected 8-bit codes (exact piecewise sRGB OETF, round to nearest)
    t = 0.0031308
    row = np.array([0.0, 0.5, 1.0, t, t * 0.5, 0.2158605, 2.0, -1.0, 0.18], dtype=np.float64)
    expected = np.array([0, 188, 255, 10, 5, 128, 255, 0, 118])
    img = np.repeat(row[None, :, None], 3, axis=2).astype(np.float32)
    p = tmp_path / 'codes.png'
    write_image(p, img, META)
    inp = oiio.ImageInput.open(str(p))
    codes = inp.read_image(oiio.UINT8)
    inp.close()
    assert np.array_equal(codes[0, :, 0], expected), codes[0, :, 0]
    # both branches meet at the threshold (continuity) and the linear segment is 12.92 x
    assert fm.srgb_encode(t) == pytest.approx(12.92 * t)
    assert fm.srgb_encode(t) == pytest.approx(1.055 * t ** (1 / 2.4) - 0.055, rel=1e-6)
    assert fm.srgb_encode(1e-4) == pytest.approx(12.92e-4)
    # string metadata survives in PNG
    a, spec = attribs(p)
    assert spec.format == oiio.TypeDesc('uint8')
    assert a['rtc:spp'] == '64' and a['rtc:sampler'] == 'sobol' and a['Software'] == 'rtc 0.1.0'


def test_srgb_decode_inverts_encode():
    x = np.linspace(0, 1, 1001)
    assert np.allclose(fm.srgb_decode(fm.srgb_encode(x)), x, atol=1e-12)
    codes = np.arange(256) / 255
    assert np.allclose(fm.srgb_encode(fm.srgb_decode(codes)), codes, atol=1e-12)


@pytest.mark.parametrize('ext,tol', [('.png', 0.5 / 255), ('.tif', 0.5 / 65535), ('.jpg', 12 / 255)])
def test_ldr_round_trip_in_encoded_space(tmp_path, ext, tol):
    rng = np.random.default_rng(3)
    img = rng.random((16, 16, 3)).astype(np.float32)
    img = np.repeat(np.repeat(img[::4, ::4], 4, 0), 4, 1)               # blocky: JPEG friendly
    p = tmp_path / ('img' + ext)
    write_image(p, img, META)
    assert files(tmp_path) == ['img' + ext]
    back = read_image(p)
    err = np.abs(fm.srgb_encode(back) - fm.srgb_encode(img)).max()
    assert err <= tol + 1e-7, err
    if ext != '.png':
        assert 'rtc:spp=64' in attribs(p)[0]['ImageDescription']


# --------------------------------------------------------------------------- atomicity
def test_unknown_extension(tmp_path):
    with pytest.raises(FilmError, match='unknown image extension'):
        write_image(tmp_path / 'x.foo', random_image())
    assert files(tmp_path) == []


def test_missing_directory_leaves_nothing(tmp_path):
    target = tmp_path / 'nope' / 'out.png'
    with pytest.raises(FilmError, match='does not exist'):
        write_image(target, random_image())
    assert not target.exists() and files(tmp_path) == []


@pytest.mark.skipif(os.geteuid() == 0, reason='root ignores directory permissions')
def test_unwritable_directory(tmp_path):
    d = tmp_path / 'ro'
    d.mkdir()
    d.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.raises(FilmError):
            write_image(d / 'out.exr', random_image())
    finally:
        d.chmod(stat.S_IRWXU)
    assert files(d) == []


def test_failed_write_keeps_old_file_and_removes_temp(tmp_path, monkeypatch):
    p = tmp_path / 'keep.png'
    write_image(p, np.zeros((4, 4, 3), np.float32))
    before = p.read_bytes()
    assert oct(p.stat().st_mode & 0o777) != oct(0o600)          # not mkstemp's private mode

    class Broken:
        def __init__(self, real):
            self.real = real

        def open(self, *a):
            return self.real.open(*a)

        def write_image(self, pixels):
            self.real.write_scanline(0, 0, pixels[0])           # a partial file on disk...
            return False                                        # ...then the write fails

        def geterror(self):
            return 'simulated disk full'

        def close(self):
            return self.real.close()

    real_create = oiio.ImageOutput.create
    monkeypatch.setattr(fm.oiio.ImageOutput, 'create', staticmethod(lambda name: Broken(real_create(name))))
    with pytest.raises(FilmError, match='simulated disk full'):
        write_image(p, np.ones((4, 4, 3), np.float32))
    assert files(tmp_path) == ['keep.png']
    assert p.read_bytes() == before


def test_bad_shapes(tmp_path):
    with pytest.raises(FilmError, match='shape'):
        write_image(tmp_path / 'a.exr', np.zeros((4, 4, 5), np.float32))
    assert files(tmp_path) == []
    write_image(tmp_path / 'grey.exr', np.full((2, 3), 0.25, np.float32))
    assert np.all(read_image(tmp_path / 'grey.exr') == 0.25)


def test_read_missing():
    with pytest.raises(FilmError):
        read_image('/nonexistent/x.exr')


# --------------------------------------------------------------------------- Film
def test_film_progressive_passes_and_tiles():
    f = Film(4, 3, meta={'sampler': 'cmj'})
    assert f.shape == (3, 4) and f.spp == 0 and np.all(f.image() == 0)
    f.add_pass(np.full((3, 4, 3), 2.0), 4)            # 4 samples of radiance 0.5
    f.add_pass(np.full((3, 4, 3), 6.0), 4)            # 4 samples of radiance 1.5
    assert f.spp == 8 and np.allclose(f.image(), 1.0) and f.image().dtype == np.float32
    f.add_pass(np.full((2, 2, 3), 8.0), 8, y0=1, x0=2)  # a tile with 8 more samples of 1.0
    assert f.spp == 8 and f.count[2, 3] == 16 and f.total_samples == 8 * 12 + 8 * 4
    assert np.allclose(f.image()[2, 3], 1.0)
    with pytest.raises(ValueError):
        f.add_pass(np.zeros((2, 2, 3)), 1, y0=2, x0=3)
    # kernel-side accumulation into the same arrays
    fm.add_sample(f.sum, f.count, 0, 0, 3.0, 3.0, 3.0)
    assert f.count[0, 0] == 9 and np.allclose(f.image()[0, 0], (8 + 3) / 9)


def test_checkpoint_round_trip(tmp_path):
    f = Film(5, 2, meta={'sampler': 'sobol', 'seed': 3, 'next_index': 64})
    rng = np.random.default_rng(1)
    f.add_pass(rng.random((2, 5, 3)) * 64, rng.integers(1, 64, (2, 5)))
    p = tmp_path / 'ck.npz'
    f.to_checkpoint(p)
    assert files(tmp_path) == ['ck.npz']
    g = Film.from_checkpoint(p)
    assert g.meta == f.meta and np.array_equal(g.sum, f.sum) and np.array_equal(g.count, f.count)
    assert g.sum.dtype == np.float64 and g.count.dtype == np.int64
    # resume: adding the remaining passes gives the same as never stopping
    g.add_pass(np.ones((2, 5, 3)), 1)
    f.add_pass(np.ones((2, 5, 3)), 1)
    assert np.array_equal(g.image(), f.image())
    with pytest.raises(FilmError):
        Film.from_checkpoint(tmp_path / 'missing.npz')
    (tmp_path / 'junk.npz').write_bytes(b'not a zip')
    with pytest.raises(FilmError):
        Film.from_checkpoint(tmp_path / 'junk.npz')


# --------------------------------------------------------------------------- metrics
def test_metrics_match_openimageio():
    rng = np.random.default_rng(5)
    ref = rng.random((24, 32, 3)).astype(np.float32) * 2
    img = ref + rng.normal(0, 0.05, ref.shape).astype(np.float32)
    r = oiio.ImageBufAlgo.compare(oiio.ImageBuf(img), oiio.ImageBuf(ref), 1e9, 1e9)
    assert metrics.rmse(img, ref) == pytest.approx(r.rms_error, rel=1e-6)
    assert metrics.rmse(ref, ref) == 0.0
    d = img.astype(np.float64) - ref
    assert metrics.rel_mse(img, ref) == pytest.approx(np.mean(d * d / (ref.astype(np.float64) ** 2 + 0.01)))
    assert metrics.rel_mse(img, ref, eps=1.0) < metrics.rel_mse(img, ref)
    with pytest.raises(ValueError):
        metrics.rmse(img, ref[:-1])
