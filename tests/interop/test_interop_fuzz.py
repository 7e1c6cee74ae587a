"""Fuzzing the compiler (issue #6): mutated course scenes give a clean error or a valid USD.

Sources: the course's own scenes (shared/corpus/course) and the product's (scenes/).  Two kinds of
mutation: text (delete, duplicate or insert bytes, replace a number by an absurd one, truncate)
and structure (with lxml: delete, duplicate, move or rename an element, set an attribute or a
text to an odd value).  Each mutant is compiled in-process through `rtc compile`'s click command
(`catch_exceptions=False`: any exception fails the test with the mutant that caused it); the
outcome must be exit 0 with a USD that usd-core opens (default prim /World), or exit 2 with a
message naming the scene file and no output.

Default run: 100 + 100 cases; `-m slow`: 5,000 + 5,000.  Deterministic (derandomized).
"""
from __future__ import annotations

import copy
import os
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree
from pxr import Usd

from rtc.compiler.cli import compile_cmd

from tests.interop.interop_helpers import COURSE_CORPUS, REPO

SOURCES = sorted(COURSE_CORPUS.rglob('*.xml')) + sorted((REPO / 'scenes').glob('*.xml'))
ODD_NUMBERS = ['nan', 'inf', '-inf', '1e308', '-1e308', '1e-320', '0', '-0', '1e999', '99999999999999999999999',
               '', ' ', '1 2', '1,2,3', 'x', '0x10', '１', '-', '.', 'e5']
TAGS = ['scene', 'camera', 'light', 'shape', 'shader', 'instance', 'texture', 'transform', 'translate',
        'rotate', 'scale', 'center', 'radius', 'minPt', 'maxPt', 'v0', 'v1', 'v2', 'file', 'diffuse', 'specular',
        'phongExp', 'mirrorCoef', 'position', 'intensity', 'viewDir', 'lookatPoint', 'focalLength',
        'imagePlaneWidth', 'sceneParameters', 'bgColor', 'envMapPrefix', 'normal', 'width', 'length', 'bogus']
ATTRS = ['name', 'type', 'ref', 'id', 'axis', 'tex', 'bgColor', 'envmapPrefix', 'foo']
VALUES = ODD_NUMBERS + ['sphere', 'box', 'triangle', 'mesh', 'instance', 'cylinder', 'point', 'area',
                        'perspective', 'orthographic', 'Lambertian', 'BlinnPhong', 'Dielectric', 'Mirror', 'X',
                        'nonexistent', '../../../../etc/passwd', 'objFiles/none.obj', 'a' * 300]
HEAVY = ('boxSphereTest', 'dielectric_dragon', 'happyBuddha', 'bunnies')      # 0.2-0.5 s each to compile
LIGHT_SOURCES = [p for p in SOURCES if not p.stem.startswith(HEAVY)]


@pytest.fixture(scope='module')
def workspace(tmp_path_factory) -> dict[Path, Path]:
    """Source directory -> a scratch directory whose entries are symlinks to the source's, so that
    a mutant written there finds its meshes and images by the same relative paths."""
    if not SOURCES:
        pytest.skip('no course scenes')
    root = tmp_path_factory.mktemp('fuzz')
    spaces = {}
    for i, d in enumerate(sorted({p.parent for p in SOURCES})):
        w = root / f'd{i}'
        w.mkdir()
        for entry in d.iterdir():
            os.symlink(entry, w / entry.name)
        spaces[d] = w
    return spaces


def check_outcome(workspace, source: Path, mutant: bytes):
    scene = workspace[source.parent] / '_mutant.xml'
    out = workspace[source.parent] / '_mutant.usda'
    scene.write_bytes(mutant)
    result = CliRunner().invoke(compile_cmd, [str(scene), '-o', str(out)], catch_exceptions=False)
    try:
        if result.exit_code == 0:
            stage = Usd.Stage.Open(str(out))
            assert stage is not None and stage.GetDefaultPrim().GetPath() == '/World', result.output
        else:
            assert result.exit_code == 2, (result.exit_code, result.output)
            assert str(scene) in result.output and 'Traceback' not in result.output, result.output
            assert not out.exists()
    finally:
        out.unlink(missing_ok=True)
        assets = out.parent / '_mutant_assets'
        if assets.exists():
            import shutil
            shutil.rmtree(assets)


def source_files():
    # light scenes most of the time; the heavy ones now and then
    return st.one_of(st.sampled_from(LIGHT_SOURCES), st.sampled_from(SOURCES)) if SOURCES else st.nothing()


@st.composite
def text_mutant(draw):
    source = draw(source_files())
    data = bytearray(source.read_bytes())
    for _ in range(draw(st.integers(1, 4))):
        n = len(data)
        op = draw(st.sampled_from(['delete', 'insert', 'duplicate', 'number', 'truncate', 'byte']))
        i = draw(st.integers(0, max(n - 1, 0)))
        j = min(n, i + draw(st.integers(1, 64)))
        if op == 'delete':
            del data[i:j]
        elif op == 'insert':
            data[i:i] = draw(st.sampled_from([b'<', b'>', b'/>', b'&', b'&amp;', b'<!--', b'"', b"'", b'\x00',
                                              b'\xff\xfe', b']]>', b'<shape>', b'</scene>', b'<?xml?>']))
        elif op == 'duplicate':
            data[j:j] = data[i:j]
        elif op == 'number':
            digits = [k for k in range(n) if 48 <= data[k] <= 57]
            if digits:
                k = draw(st.sampled_from(digits))
                e = k
                while e < n and chr(data[e]) in '0123456789.eE-+':
                    e += 1
                data[k:e] = draw(st.sampled_from(ODD_NUMBERS)).encode()
        elif op == 'truncate':
            del data[i:]
        else:
            if n:
                data[i] = draw(st.integers(0, 255))
    return source, bytes(data)


@st.composite
def structural_mutant(draw):
    source = draw(source_files())
    root = etree.fromstring(source.read_bytes(), etree.XMLParser(remove_comments=True))
    for _ in range(draw(st.integers(1, 3))):
        elements = list(root.iter())
        el = draw(st.sampled_from(elements))
        op = draw(st.sampled_from(['delete', 'duplicate', 'move', 'rename', 'attribute', 'text', 'drop-attrs']))
        parent = el.getparent()
        if op == 'delete' and parent is not None:
            parent.remove(el)
        elif op == 'duplicate' and parent is not None:
            parent.insert(parent.index(el) + 1, copy.deepcopy(el))
        elif op == 'move' and parent is not None:
            targets = [e for e in elements if e is not el and el not in e.iterancestors()]
            target = draw(st.sampled_from(targets))
            parent.remove(el)
            target.append(el)
        elif op == 'rename':
            el.tag = draw(st.sampled_from(TAGS))
        elif op == 'attribute':
            el.set(draw(st.sampled_from(ATTRS)), draw(st.sampled_from(VALUES)))
        elif op == 'text':
            el.text = draw(st.sampled_from(VALUES + [' '.join(draw(st.lists(st.sampled_from(ODD_NUMBERS),
                                                                            max_size=4)))]))
        elif op == 'drop-attrs':
            el.attrib.clear()
    return source, etree.tostring(root)


FAST = settings(max_examples=100, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])
SLOW = settings(FAST, max_examples=5000)


@FAST
@given(case=text_mutant())
def test_text_mutations(workspace, case):
    check_outcome(workspace, *case)


@FAST
@given(case=structural_mutant())
def test_structural_mutations(workspace, case):
    check_outcome(workspace, *case)


@pytest.mark.slow
@SLOW
@given(case=text_mutant())
def test_text_mutations_10k_half(workspace, case):
    check_outcome(workspace, *case)


@pytest.mark.slow
@SLOW
@given(case=structural_mutant())
def test_structural_mutations_10k_half(workspace, case):
    check_outcome(workspace, *case)
