import struct

import numpy as np
import pytest

from flank_addon.io import mesh_files as mesh_io
from flank_addon.io.mesh_files import MeshFormatError, read_mesh, write_mesh


def _tetra():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 0.5 + 0.125
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return v, f


def _same_mesh(v1, f1, v2, f2, atol=0.0):
    """Equal as sets of triangles (vertex order inside a triangle cyclic)."""
    def key(v, f):
        tris = v[f]
        out = []
        for t in tris:
            k = int(np.lexsort(t.T[::-1])[0])
            out.append(tuple(np.roll(t, -k, axis=0).ravel().round(9)))
        return sorted(out)
    a, b = key(v1, f1), key(v2, f2)
    assert len(a) == len(b)
    assert np.allclose(np.array(a), np.array(b), atol=atol)


@pytest.mark.parametrize("ext", [".stl", ".ply", ".obj"])
def test_round_trip(tmp_path, ext):
    v, f = _tetra()
    p = tmp_path / f"m{ext}"
    write_mesh(p, v, f)
    v2, f2 = read_mesh(p)
    assert v2.shape == (4, 3) and f2.shape == (4, 3)
    _same_mesh(v, f, v2, f2)


def test_ply_ascii_round_trip_and_rotor_mesh(tmp_path):
    from flank_addon.geometry.rotors import builtin_rotor
    v, f = builtin_rotor("srm_a", "female").mesh(n_profile=120, n_axial=6)
    p = tmp_path / "r.ply"
    mesh_io.write_ply(p, v, f, binary=False)
    v2, f2 = read_mesh(p)
    assert np.array_equal(v2, v) and np.array_equal(f2, f)
    mesh_io.write_ply(p, v, f)
    v3, f3 = read_mesh(p)
    assert np.array_equal(v3, v) and np.array_equal(f3, f)
    s = tmp_path / "r.stl"
    write_mesh(s, v, f)
    v4, f4 = read_mesh(s)
    assert len(v4) == len(v) and len(f4) == len(f)  # duplicates merged exactly
    assert np.allclose(v4[f4], v[f].astype(np.float32), atol=0)


def test_ascii_stl_and_polygons(tmp_path):
    p = tmp_path / "a.stl"
    p.write_text("solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n"
                 "   vertex 1 1 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid x\n")
    v, f = read_mesh(p)
    assert len(v) == 4 and len(f) == 2


def test_obj_forms(tmp_path):
    p = tmp_path / "a.obj"
    p.write_text("# c\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
                 "f 1/1/1 2/1/1 3//1 4\nf -4 -2 -1\n")
    v, f = read_mesh(p)
    assert v.shape == (4, 3)
    assert f.tolist() == [[0, 1, 2], [0, 2, 3], [0, 2, 3]]


def test_ply_polygon_binary(tmp_path):
    p = tmp_path / "q.ply"
    hdr = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")
    body = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "<f4").tobytes()
    body += struct.pack("<B4i", 4, 0, 1, 2, 3)
    p.write_bytes(hdr.encode() + body)
    v, f = read_mesh(p)
    assert f.tolist() == [[0, 1, 2], [0, 2, 3]]


@pytest.mark.parametrize("name,content,msg", [
    ("bad.obj", "v 0 0 0\nv 1 0\n", r"bad\.obj: line 2"),
    ("bad2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", r"line 4: face index 7"),
    ("bad3.obj", "v 0 0 0\nv 1 0 0\nf 1 2 x\n", r"line 3: bad face index 'x'"),
    ("bad.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                "property float z\nend_header\n0 0 0\n1 q 0\n", r"line 9: bad vertex 1"),
    ("bad2.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                 "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", r"face 0 index out of range"),
    ("bad3.ply", "plx\n", r"not a PLY file"),
    ("bad.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0\nendloop\nendfacet\n", r"line 4: vertex needs 3"),
    ("bad2.stl", b"\0" * 80 + struct.pack("<I", 5) + b"\0" * 50, r"header says 5 facets"),
    ("bad.xyz", "", r"unsupported mesh extension"),
])
def test_bad_input_raises_with_message(tmp_path, name, content, msg):
    p = tmp_path / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content)
    with pytest.raises(MeshFormatError, match=msg):
        read_mesh(p)
    assert issubclass(MeshFormatError, ValueError)


def test_binary_ply_truncated(tmp_path):
    v, f = _tetra()
    p = tmp_path / "t.ply"
    mesh_io.write_ply(p, v, f)
    p.write_bytes(p.read_bytes()[:-30])
    with pytest.raises(MeshFormatError, match="ends early"):
        read_mesh(p)


@pytest.mark.parametrize("kind", ["pool", "mesh", "columns"])
def test_float32_merge_equals_the_general_unique_rows(kind):
    """A binary STL's vertices are merged by an integer sort of their float32 bits; the rows, their order and
    the inverse must be those of the general lexicographic unique (signs, zeros of both signs, denormals,
    huge and tiny values, rows equal in x and y only).  "pool": rows equal in x and y come with z out of
    order, so the sort must look at z too; "mesh": every vertex repeated, none shares x and y with
    another, so the sort by x and y alone is the answer; "columns": rows share x and y but come in z order,
    so it is still the answer."""
    from unittest import mock

    from flank_addon.geometry.rows import unique_float32_triples, unique_rows

    rng = np.random.default_rng(5)
    if kind == "pool":
        pool = np.array([0.0, -0.0, 1.0, -1.0, 1e-40, -1e-40, 3.4e38, -3.4e38, 1e-3, -1e-3, 2.5, -2.5], np.float32)
        a = np.concatenate([rng.choice(pool, (3000, 3)),
                            rng.normal(scale=50.0, size=(2000, 3)).astype(np.float32)])
        a = np.concatenate([a, a[rng.integers(0, len(a), 2000)]])[rng.permutation(7000)]
    elif kind == "mesh":
        v = rng.normal(scale=50.0, size=(1500, 3)).astype(np.float32)
        v[::10] *= -0.0
        a = v[rng.integers(0, len(v), 9000)]
    else:
        xy = rng.normal(size=(300, 2)).astype(np.float32)
        z = (np.arange(4000) // 3 * 0.5 - 300).astype(np.float32)        # never falls along the rows
        a = np.c_[xy[rng.integers(0, 300, 4000)], z]      # rows sharing x and y, and repeated ones (z in threes)
    u_ref, inv_ref = unique_rows(a.astype(np.float64))
    with mock.patch.object(np, "lexsort", wraps=np.lexsort) as lexsort:
        u, inv = unique_float32_triples(a)
    assert lexsort.call_count == (1 if kind == "pool" else 0)
    assert u.dtype == np.float64
    assert np.array_equal(u, u_ref) and np.array_equal(np.signbit(u), np.signbit(u_ref))
    assert np.array_equal(inv, inv_ref)
    assert np.array_equal(u[inv], a.astype(np.float64))


@pytest.mark.parametrize("unused", [0, 1, 300])
def test_used_vertices_equal_numpy_unique(unused):
    """The vertices that faces use and the faces renumbered into them, by counting: numpy's sorted unique and
    its inverse exactly, with every vertex used, one unused, or many (a selection of faces)."""
    from flank_addon.geometry.rows import used_vertices

    rng = np.random.default_rng(unused)
    n = 1000
    keep = np.sort(rng.permutation(n)[:n - unused])
    cover = np.resize(keep, -(-len(keep) // 3) * 3).reshape(-1, 3)          # every kept vertex appears
    faces = np.concatenate([cover, keep[rng.integers(0, len(keep), (5000, 3))]])[rng.permutation(5000 + len(cover))]
    used, F = used_vertices(faces, n)
    ref, inv = np.unique(faces, return_inverse=True)
    assert np.array_equal(used, ref) and np.array_equal(used, keep)
    assert F.shape == faces.shape and np.array_equal(F.ravel(), inv.ravel())
    assert np.array_equal(used[F], faces)
    with pytest.raises(ValueError, match="outside 0..999"):
        used_vertices(np.array([[0, 1, 1000]]), n)
    u0, f0 = used_vertices(np.zeros((0, 3), int), 5)
    assert len(u0) == 0 and f0.shape == (0, 3)
