"""OBJ loader: polygons of any size as fans, negative indices, vt/vn, file order kept, errors."""
from __future__ import annotations

import numpy as np
import pytest

from rtc.compiler.obj import ObjError, load_obj

from tests.compiler.compiler_helpers import CORPUS


def _obj(tmp_path, text):
    path = tmp_path / "m.obj"
    path.write_text(text)
    return path


def test_polygons_are_fans_in_file_order(tmp_path):
    mesh = load_obj(_obj(tmp_path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n"
                                   "f 1 2 3 4 5\nf 3 2 1\n"))
    np.testing.assert_array_equal(mesh.triangles, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [2, 1, 0]])
    assert mesh.polygons == 2 and mesh.points.shape == (5, 3)


def test_negative_indices_are_relative_to_the_vertices_so_far(tmp_path):
    mesh = load_obj(_obj(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 2\n"))
    np.testing.assert_array_equal(mesh.triangles, [[0, 1, 2], [0, 3, 1]])


def test_uvs_and_normals_are_indexed_per_corner(tmp_path):
    mesh = load_obj(_obj(tmp_path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                   "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\n"
                                   "f 1/1/1 2/2/1 3/3/2 4/4/2\n"))
    np.testing.assert_array_equal(mesh.uv_indices, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(mesh.normal_indices, [[0, 0, 1], [0, 1, 1]])
    np.testing.assert_allclose(mesh.uvs[mesh.uv_indices[1]], [[0, 0], [1, 1], [0, 1]])
    mesh = load_obj(_obj(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"))
    assert mesh.uvs is None and mesh.normal_indices.tolist() == [[0, 0, 0]]


@pytest.mark.parametrize("text, message, line", [
    ("v 0 0 0\nv 1 0 0\nf 1 2 7\n", "face refers to vertex 7, but the file defines 2 such entries", 3),
    ("v 0 0 0\nv 1 0\nf 1 2 1\n", "'v' needs 3 numbers", 2),
    ("v 0 0 0\nv 1 0 0\nf 1 2\n", "a face needs at least 3 corners", 3),
    ("v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n", "'v' needs 3 numbers", 2),
    ("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", "'v' has a NaN or infinite value", 2),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1e39\nf 1//1 2//1 3//1\n",
     "'vn' has a value beyond the 32-bit float range (magnitude at most 3.402823e+38) in which USD and the "
     "renderer hold it", 4),
    ("v 0 0 0\n", "no faces ('f' lines) in the file", None),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", "a face corner is not of the form v, v/vt, v/vt/vn or v//vn", 4),
])
def test_malformed_files_name_the_line(tmp_path, text, message, line):
    with pytest.raises(ObjError) as err:
        load_obj(_obj(tmp_path, text))
    assert (err.value.message, err.value.line) == (message, line)


def test_course_ngon_mesh_is_triangulated():
    path = CORPUS / "course" / "scenes_B" / "objFiles" / "al.obj"
    if not path.is_file():
        pytest.skip(f"course corpus not found at {CORPUS / 'course'} (set RTC_SHARED)")
    mesh = load_obj(path)
    counts = [len(l.split()) - 1 for l in path.read_text().splitlines() if l.startswith("f ")]
    assert mesh.polygons == len(counts) == 3440
    assert len(mesh.triangles) == sum(c - 2 for c in counts) == 7124
    assert mesh.points.shape == (3618, 3)          # no merging or reordering of vertices
