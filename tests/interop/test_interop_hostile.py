"""Hostile and broken input (issue #6): every failure is a clean error (exit 2, one message that
names the file, no traceback) and writes nothing; absurd sizes are refused before allocating;
an existing output survives a failed run unchanged.

The command line is run in-process with click's CliRunner (``catch_exceptions=False``: a
traceback would fail the test), except where a crash of usd-core itself must be contained."""
from __future__ import annotations

import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Sdf

from rtc.cli import main

from tests.interop.interop_helpers import REPO, RTC, USD_CORPUS

XXE = '''<?xml version="1.0"?>
<!DOCTYPE scene [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<scene bgColor="&secret;"/>
'''
XXE_NETWORK = '''<?xml version="1.0"?>
<!DOCTYPE scene SYSTEM "http://127.0.0.1:9/scene.dtd">
<scene/>
'''
BOMB = '<?xml version="1.0"?>\n<!DOCTYPE scene [\n <!ENTITY a "' + 'a' * 64 + '">\n' + ''.join(
    f' <!ENTITY {c} "{("&" + p + ";") * 20}">\n' for p, c in zip('abcdef', 'bcdefg')) + \
    ']>\n<scene><sceneParameters><envMapPrefix>&g;</envMapPrefix></sceneParameters></scene>\n'


def rtc(*args, **kw):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False, **kw)


def clean_error(result, name: str):
    """Exit 2, a message naming the file, no traceback."""
    assert result.exit_code == 2, (result.exit_code, result.output)
    assert name in result.output and 'Traceback' not in result.output, result.output


def only(directory: Path, *names: str):
    assert sorted(p.name for p in directory.iterdir()) == sorted(names)


# ----------------------------------------------------------------------------- XML entities
@pytest.mark.parametrize('text', [XXE, XXE_NETWORK, BOMB], ids=['xxe-file', 'xxe-network', 'entity-bomb'])
@pytest.mark.parametrize('command', ['compile', 'render'])
def test_entities_are_refused(text, command, tmp_path):
    scene = tmp_path / 'scene.xml'
    scene.write_text(text)
    out = tmp_path / ('out.usda' if command == 'compile' else 'out.png')
    result = rtc(command, scene, '-o', out)
    clean_error(result, 'scene.xml')
    assert 'DOCTYPE' in result.output and 'root:' not in result.output     # /etc/passwd not read
    only(tmp_path, 'scene.xml')


# ----------------------------------------------------------------------------- corrupt USD
def _crate(tmp_path) -> bytes:
    layer = Sdf.Layer.FindOrOpen(str(USD_CORPUS / 'openusd/pxr/usdImaging/usdImagingGL/testenv/'
                                                  'testUsdImagingGLPointInstancer/pi_varying.usda'))
    layer.Export(str(tmp_path / 'good.usdc'))
    return (tmp_path / 'good.usdc').read_bytes()


def _corruptions(data: bytes) -> dict[str, bytes]:
    mid = len(data) // 2
    return {'empty.usdc': b'', 'header-only.usdc': data[:88], 'half.usdc': data[:mid],
            'no-toc.usdc': data[:-64], 'zeroed-middle.usdc': data[:mid] + bytes(256) + data[mid + 256:],
            'garbage.usdc': b'PXR-USDC' + bytes(range(256)) * 8}


def test_corrupt_usd_files_through_the_cli(usd_corpus, tmp_path):
    data = _crate(tmp_path)
    text = (USD_CORPUS / 'openusd/pxr/usdImaging/usdImagingGL/testenv/testUsdImagingGLInstancing/'
                         'instance2.usda').read_text()
    bad = {**_corruptions(data), 'truncated.usda': text[:len(text) // 3], 'binary.usda': '\x00\x01garbage',
           'truncated.usdz': (USD_CORPUS / 'usd-wg/test_assets/USDZ/AnimatedCube/AnimatedCube.usdz').read_bytes()[:2000]}
    work = tmp_path / 'work'
    work.mkdir()
    for name, content in bad.items():
        path = work / name
        path.write_bytes(content.encode() if isinstance(content, str) else content)
        clean_error(rtc('render', path, '-o', work / 'out.png', '--width', 8, '--spp', 1), name)
        clean_error(rtc('info', path), name)
        path.unlink()
    only(work)


def test_random_crate_corruption_never_crashes(usd_corpus, tmp_path):
    """usd-core reads the crate in C++: run 30 corruptions in a child process so a crash would
    show as a failed test rather than a dead test run; each must be a SceneError or a stage."""
    data = _crate(tmp_path)
    rng = np.random.default_rng(6)
    for i in range(30):
        b = bytearray(data)
        cut = int(rng.integers(len(b)))
        if i % 3 == 0:
            b = b[:cut]
        elif i % 3 == 1:
            for j in rng.integers(len(b), size=8):
                b[j] = int(rng.integers(256))
        else:
            b[cut:cut + 64] = bytes(len(b[cut:cut + 64]))
        (tmp_path / f'c{i}.usdc').write_bytes(bytes(b))
    code = ('import sys, glob\nfrom rtc.renderer.usd.stage import read_stage\nfrom rtc.renderer.errors import SceneError\n'
            'from rtc.renderer.options import RenderOptions\n'
            'for p in sorted(glob.glob(sys.argv[1] + "/c*.usdc")):\n'
            '    try:\n        read_stage(p, options=RenderOptions(width=8, height=6, spp=1))\n'
            '    except SceneError as e:\n        assert p.rsplit("/", 1)[1] in str(e), e\n')
    r = subprocess.run([sys.executable, '-c', code, str(tmp_path)], capture_output=True, text=True,
                       timeout=300, cwd=REPO)
    assert r.returncode == 0, r.stderr[-2000:]


# ----------------------------------------------------------------------------- corrupt OBJ / images
def _png_header(width, height) -> bytes:
    def chunk(kind, payload):
        return struct.pack('>I', len(payload)) + kind + payload + struct.pack('>I', zlib.crc32(kind + payload))
    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, 2, 0, 0, 0))
            + chunk(b'IDAT', zlib.compress(bytes(1000))) + chunk(b'IEND', b''))


@pytest.fixture
def scenes(tmp_path) -> Path:
    shutil.copytree(REPO / 'scenes', tmp_path / 'scenes')
    return tmp_path / 'scenes'


@pytest.mark.parametrize('scene, victim, content, message', [
    ('gallery.xml', 'objFiles/icosahedron.obj', b'v 1 2\nf 1 2 3\n', "icosahedron.obj:1: 'v' needs 3 numbers"),
    ('bunnies.xml', 'objFiles/bunny.obj', None, 'bunny.obj'),                          # truncated mid-file
    ('envmap.xml', 'images/sky_posX.png', b'\x89PNG\r\n\x1a\n', 'sky_posX.png'),
], ids=['obj-syntax', 'obj-truncated', 'envmap-face'])
def test_corrupt_assets_of_a_course_scene(scenes, scene, victim, content, message):
    path = scenes / victim
    data = path.read_bytes()
    path.write_bytes(content if content is not None else data[:len(data) // 50])
    out = scenes / 'out.png'
    for command in (['render', scenes / scene, '-o', out, '--width', 8, '--spp', 1],
                    ['compile', scenes / scene, '-o', scenes / 'out.usda']):
        clean_error(rtc(*command), message)
    assert not out.exists() and not (scenes / 'out.usda').exists()


@pytest.mark.parametrize('content', [None, _png_header(20000, 20000)], ids=['truncated', 'huge-header'])
def test_corrupt_texture_of_a_course_scene_warns_and_falls_back(scenes, content):
    """Like the course's parsers (issue 14): a course scene with an undecodable texture compiles and
    renders with the shader's colour, after a warning naming the file and line; --strict exits 1."""
    path = scenes / 'images/textureMapCalibration.png'
    path.write_bytes(content if content is not None else path.read_bytes()[:len(path.read_bytes()) // 50])
    result = rtc('compile', scenes / 'shaders.xml', '-o', scenes / 'out.usda')
    assert result.exit_code == 0 and "textureMapCalibration.png" in result.output
    assert "the shader's colour is used instead" in result.output
    assert rtc('compile', scenes / 'shaders.xml', '-o', scenes / 'strict.usda', '--strict').exit_code == 1
    assert not (scenes / 'strict.usda').exists()


def test_corrupt_texture_in_usd_warns_and_renders(scenes, tmp_path):
    """In a USD file an unreadable texture is what usdImaging treats it as: a warning naming the
    file, then the shader's fallback (corpus files rely on this), not a failed render."""
    usd = tmp_path / 'shaders.usda'
    assert rtc('compile', scenes / 'shaders.xml', '-o', usd).exit_code == 0
    (scenes / 'images/textureMapCalibration.png').write_bytes(_png_header(20000, 20000))
    result = rtc('render', usd, '-o', tmp_path / 'out.png', '--width', 8, '--spp', 1)
    assert result.exit_code == 0, result.output
    assert 'cannot read texture' in result.output and 'textureMapCalibration.png' in result.output


# ----------------------------------------------------------------------------- absurd sizes
@pytest.mark.parametrize('args, message', [
    (['--width', 10 ** 6, '--height', 10 ** 6], 'image width 1000000 is out of range'),
    (['--spp', 10 ** 9], 'samples per pixel 1000000000 is out of range'),
    (['--threads', 100000], 'threads 100000 is out of range'),
    (['--max-depth', 10 ** 6], 'max depth 1000000 is out of range'),
    (['--checkpoint', '-1'], '--checkpoint must be a positive number'),
])
def test_absurd_render_options_are_refused_before_reading_the_scene(args, message, tmp_path):
    scene = tmp_path / 'scene.usda'
    scene.write_text('#usda 1.0\ndef Sphere "S"\n{\n}\n')
    result = rtc('render', scene, '-o', tmp_path / 'out.png', *args)
    assert result.exit_code == 2 and message in result.output and 'warning' not in result.output, result.output
    only(tmp_path, 'scene.usda')


def test_absurd_sizes_in_the_file_are_refused(tmp_path):
    """The stage's own render settings ask for 10^12 pixels and 10^9 spp."""
    scene = tmp_path / 'scene.usda'
    scene.write_text('#usda 1.0\n(\n    renderSettingsPrimPath = "/Render/Settings"\n)\n'
                     'def Sphere "S"\n{\n}\ndef Scope "Render"\n{\n    def RenderSettings "Settings"\n    {\n'
                     '        uniform int2 resolution = (1000000, 1000000)\n'
                     '        custom int rtc:samplesPerPixel = 1000000000\n    }\n}\n')
    result = rtc('render', scene, '-o', tmp_path / 'out.png')
    clean_error(result, 'image size 1000000x1000000 is out of range')
    result = rtc('render', scene, '-o', tmp_path / 'out.png', '--width', 8, '--height', 8)
    clean_error(result, 'samples per pixel 1000000000 is out of range')
    only(tmp_path, 'scene.usda')


def _nested_instancing(n: int, levels: int) -> str:
    """Prototype L0 = a sphere; L1..L(levels-1) = n instances of the level below; /World = n
    instances of the top level: n^levels placements from a file of n * levels small prims."""
    out = ['#usda 1.0', 'over "Protos"', '{', '    def Xform "L0"', '    {', '        def Sphere "s"',
           '        {', '        }', '    }']

    def instances(target: str, pad: str, axis: int):
        for i in range(n):
            offset = tuple(i if a == axis else 0 for a in range(3))
            out.extend([f'{pad}def "i{i}" (', f'{pad}    instanceable = true',
                        f'{pad}    prepend references = <{target}>', f'{pad})', f'{pad}{{',
                        f'{pad}    double3 xformOp:translate = {offset}',
                        f'{pad}    uniform token[] xformOpOrder = ["xformOp:translate"]', f'{pad}}}'])
    for level in range(1, levels):
        out.extend([f'    def Xform "L{level}"', '    {'])
        instances(f'/Protos/L{level - 1}', ' ' * 8, level % 3)
        out.append('    }')
    out.extend(['}', 'def Xform "World"', '{'])
    instances(f'/Protos/L{levels - 1}', ' ' * 4, levels % 3)
    out.append('}')
    return '\n'.join(out) + '\n'


def test_billion_instances_are_refused_before_allocating(tmp_path):
    """Three levels of 1000 native instances = 10^9 placements after flattening (a 0.7 MB file):
    refused with a message, without allocating gigabytes."""
    import resource
    scene = tmp_path / 'bomb.usda'
    scene.write_text(_nested_instancing(1000, 3))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    result = rtc('render', scene, '-o', tmp_path / 'out.png', '--width', 8, '--spp', 1)
    clean_error(result, 'bomb.usda')
    assert 'more than 10,000,000 placements' in result.output
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 2_000_000      # KB: < 2 GB growth
    small = tmp_path / 'small.usda'
    small.write_text(_nested_instancing(30, 2))             # 900 placements: fine
    assert 'placements: 900,' in rtc('info', small).output


# ----------------------------------------------------------------------------- existing outputs survive
def test_existing_output_survives_a_failed_render(tmp_path):
    out = tmp_path / 'out.png'
    out.write_bytes(b'previous image')
    bad = tmp_path / 'bad.usda'
    bad.write_text('#usda 1.0\ndef "A" {\n')
    clean_error(rtc('render', bad, '-o', out, '--width', 8, '--spp', 1), 'bad.usda')
    assert out.read_bytes() == b'previous image'
    only(tmp_path, 'out.png', 'bad.usda')


def test_existing_output_survives_a_failed_write(tmp_path, monkeypatch):
    """The image writer dies half-way through (disk full, killed): the target keeps its old
    bytes and no temporary file is left behind."""
    from rtc.renderer.host import film
    out = tmp_path / 'out.exr'
    out.write_bytes(b'previous image')

    class Dying:
        def __init__(self, real):
            self.real = real

        def __getattr__(self, name):
            return getattr(self.real, name)

        def write_image(self, pixels):
            self.real.write_image(pixels[: len(pixels) // 2])       # a partial file on disk
            raise OSError('No space left on device')

    real_create = film.oiio.ImageOutput.create
    monkeypatch.setattr(film.oiio.ImageOutput, 'create', staticmethod(lambda p: Dying(real_create(p))))
    with pytest.raises(film.FilmError, match='No space left'):
        film.write_image(out, np.ones((4, 4, 3), np.float32))
    assert out.read_bytes() == b'previous image'
    only(tmp_path, 'out.exr')


def test_existing_usd_survives_a_failed_compile(tmp_path):
    out = tmp_path / 'out.usda'
    out.write_text('#usda 1.0\n')
    scene = tmp_path / 'scene.xml'
    scene.write_text('<scene><shape type="sphere"><radius>oops</radius></shape>')
    clean_error(rtc('compile', scene, '-o', out), 'scene.xml')
    assert out.read_text() == '#usda 1.0\n'
    only(tmp_path, 'out.usda', 'scene.xml')
