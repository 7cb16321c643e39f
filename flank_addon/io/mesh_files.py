"""Triangle-mesh file I/O: STL (binary write; ascii + binary read), PLY, OBJ.

All readers return ``(verts (N,3) float64, faces (M,3) int64)``; polygons
are fan-triangulated.  Malformed input raises :class:`MeshFormatError`
naming the file and the line / element at fault.
"""
import os
import struct

import numpy as np

from ..geometry.rows import unique_float32_triples, unique_rows
from .files import atomic_write

__all__ = ["MeshFormatError", "write_stl", "write_ply", "write_obj", "write_mesh", "read_mesh", "stl_bytes",
           "ply_bytes", "obj_bytes",
           "read_stl", "read_ply", "read_obj", "WRITERS", "READERS"]


class MeshFormatError(ValueError):
    """Malformed or unsupported mesh file."""


def _check(verts, faces):
    v = np.asarray(verts, dtype=float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"verts must be (N, 3), got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must be (M, 3) triangles, got shape {f.shape}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"face index out of range 0..{len(v) - 1}")
    return v, f.astype(np.int64)


def _fan(poly):
    """Fan triangles of one polygon (list of indices)."""
    return [(poly[0], poly[k], poly[k + 1]) for k in range(1, len(poly) - 1)]


# --------------------------------------------------------------------------- STL

def write_stl(path, verts, faces, header=b"flank_addon binary STL"):
    """Binary STL, written whole or not at all."""
    atomic_write(path, stl_bytes(verts, faces, header))


def stl_bytes(verts, faces, header=b"flank_addon binary STL"):
    v, f = _check(verts, faces)
    tri = v[f].astype(np.float32)  # (M, 3, 3)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]).astype(np.float64)
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, ln, out=np.zeros_like(nrm), where=ln > 0).astype(np.float32)
    rec = np.zeros(len(f), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"] = nrm
    rec["v"] = tri
    return header[:80].ljust(80, b"\0") + struct.pack("<I", len(f)) + rec.tobytes()


def _merge(tri_verts):
    """Exact merge of identical vertex rows -> (verts, faces)."""
    flat = tri_verts.reshape(-1, 3)
    if flat.dtype == np.float32:          # a binary STL's own numbers: the faster sort of their bits
        uniq, inv = unique_float32_triples(flat)
    else:
        uniq, inv = unique_rows(flat)
    return uniq.astype(np.float64, copy=False), inv.reshape(-1, 3).astype(np.int64)


def read_stl(path):
    with open(path, "rb") as fh:
        data = fh.read()
    if len(data) >= 84:
        (count,) = struct.unpack_from("<I", data, 80)
        if 84 + 50 * count == len(data):
            rec = np.frombuffer(data, dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")],
                                count=count, offset=84)
            tri = rec["v"]
            if not np.all(np.isfinite(tri)):
                bad = int(np.flatnonzero(~np.isfinite(tri).all(axis=(1, 2)))[0])
                raise MeshFormatError(f"{path}: binary STL facet {bad} has non-finite coordinates")
            return _merge(tri)
    head = data[:5].lower()
    if head != b"solid":
        if len(data) < 84:
            raise MeshFormatError(f"{path}: too short for a binary STL ({len(data)} bytes) and not ascii")
        (count,) = struct.unpack_from("<I", data, 80)
        raise MeshFormatError(f"{path}: binary STL size mismatch: header says {count} facets "
                              f"({84 + 50 * count} bytes), file has {len(data)} bytes")
    return _read_stl_ascii(path, data)


def _read_stl_ascii(path, data):
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError as e:
        raise MeshFormatError(f"{path}: ascii STL contains non-ascii bytes at offset {e.start}") from None
    tris = []
    cur = []
    in_loop = False
    for ln, line in enumerate(text.splitlines(), 1):
        tok = line.split()
        if not tok:
            continue
        key = tok[0].lower()
        if key == "vertex":
            if not in_loop:
                raise MeshFormatError(f"{path}: line {ln}: 'vertex' outside 'outer loop'")
            if len(tok) != 4:
                raise MeshFormatError(f"{path}: line {ln}: vertex needs 3 coordinates, got {len(tok) - 1}")
            try:
                cur.append([float(t) for t in tok[1:]])
            except ValueError:
                raise MeshFormatError(f"{path}: line {ln}: bad vertex coordinates {line.strip()!r}") from None
        elif key == "outer":
            in_loop = True
            cur = []
        elif key == "endloop":
            if len(cur) < 3:
                raise MeshFormatError(f"{path}: line {ln}: facet loop with {len(cur)} vertices (need >= 3)")
            tris.extend([cur[a], cur[b], cur[c]] for a, b, c in _fan(list(range(len(cur)))))
            in_loop = False
        elif key in ("solid", "facet", "endfacet", "endsolid"):
            continue
        else:
            raise MeshFormatError(f"{path}: line {ln}: unexpected keyword {tok[0]!r} in ascii STL")
    if in_loop:
        raise MeshFormatError(f"{path}: file ends inside a facet loop")
    if not tris:
        raise MeshFormatError(f"{path}: ascii STL contains no facets")
    tri = np.asarray(tris, dtype=np.float64)
    if not np.all(np.isfinite(tri)):
        raise MeshFormatError(f"{path}: ascii STL has non-finite coordinates")
    return _merge(tri)


# --------------------------------------------------------------------------- PLY

def write_ply(path, verts, faces, binary=True):
    """PLY (binary little endian or ASCII), written whole or not at all."""
    atomic_write(path, ply_bytes(verts, faces, binary))


def ply_bytes(verts, faces, binary=True):
    v, f = _check(verts, faces)
    fmt = "binary_little_endian" if binary else "ascii"
    header = (f"ply\nformat {fmt} 1.0\ncomment flank_addon\nelement vertex {len(v)}\n"
              "property double x\nproperty double y\nproperty double z\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    if binary:
        rec = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3
        rec["i"] = f
        return header.encode("ascii") + v.astype("<f8").tobytes() + rec.tobytes()
    lines = [" ".join(repr(float(c)) for c in row) for row in v]
    lines += ["3 %d %d %d" % tuple(row) for row in f]
    return (header + "\n".join(lines) + "\n").encode("ascii")


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "<i2", "int16": "<i2",
              "ushort": "<u2", "uint16": "<u2", "int": "<i4", "int32": "<i4", "uint": "<u4",
              "uint32": "<u4", "float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8"}


def _ply_header(path, fh):
    first = fh.readline()
    if first.strip() != b"ply":
        raise MeshFormatError(f"{path}: not a PLY file (first line {first[:20]!r})")
    fmt = None
    elements = []  # [name, count, [(prop, type) or (prop, ('list', ctype, itype))]]
    ln = 1
    while True:
        raw = fh.readline()
        ln += 1
        if not raw:
            raise MeshFormatError(f"{path}: PLY header has no 'end_header'")
        tok = raw.decode("ascii", "replace").split()
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        if tok[0] == "end_header":
            break
        if tok[0] == "format":
            if len(tok) < 2 or tok[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise MeshFormatError(f"{path}: line {ln}: unknown PLY format {' '.join(tok[1:])!r}")
            fmt = tok[1]
        elif tok[0] == "element":
            try:
                elements.append([tok[1], int(tok[2]), []])
            except (IndexError, ValueError):
                raise MeshFormatError(f"{path}: line {ln}: bad element line {' '.join(tok)!r}") from None
        elif tok[0] == "property":
            if not elements:
                raise MeshFormatError(f"{path}: line {ln}: property before any element")
            if len(tok) >= 5 and tok[1] == "list":
                if tok[2] not in _PLY_TYPES or tok[3] not in _PLY_TYPES:
                    raise MeshFormatError(f"{path}: line {ln}: unknown list types {tok[2]!r}/{tok[3]!r}")
                elements[-1][2].append((tok[4], ("list", tok[2], tok[3])))
            elif len(tok) >= 3 and tok[1] in _PLY_TYPES:
                elements[-1][2].append((tok[2], tok[1]))
            else:
                raise MeshFormatError(f"{path}: line {ln}: bad property line {' '.join(tok)!r}")
        else:
            raise MeshFormatError(f"{path}: line {ln}: unexpected header keyword {tok[0]!r}")
    if fmt is None:
        raise MeshFormatError(f"{path}: PLY header has no 'format' line")
    if fmt == "binary_big_endian":
        raise MeshFormatError(f"{path}: PLY binary_big_endian is not supported")
    return fmt, elements, ln


def read_ply(path):
    with open(path, "rb") as fh:
        fmt, elements, hdr_lines = _ply_header(path, fh)
        body = fh.read()
    names = [e[0] for e in elements]
    if "vertex" not in names:
        raise MeshFormatError(f"{path}: PLY has no 'vertex' element")
    vel = elements[names.index("vertex")]
    vprops = [p for p, _ in vel[2]]
    for c in "xyz":
        if c not in vprops:
            raise MeshFormatError(f"{path}: PLY vertex element lacks property {c!r}")
    if fmt == "ascii":
        data = _ply_ascii(path, body, elements, hdr_lines)
    else:
        data = _ply_binary(path, body, elements)
    v = np.stack([data["vertex"][c] for c in "xyz"], axis=1).astype(np.float64)
    polys = data.get("face", [])
    tris = []
    for k, poly in enumerate(polys):
        if len(poly) < 3:
            raise MeshFormatError(f"{path}: PLY face {k} has {len(poly)} vertices (need >= 3)")
        if min(poly) < 0 or max(poly) >= len(v):
            raise MeshFormatError(f"{path}: PLY face {k} index out of range 0..{len(v) - 1}: {list(poly)}")
        tris.extend(_fan(list(poly)))
    f = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    return v, f


def _face_key(props):
    for name, t in props:
        if isinstance(t, tuple) and name in ("vertex_indices", "vertex_index"):
            return name
    return None


def _ply_ascii(path, body, elements, hdr_lines):
    lines = body.decode("ascii", "replace").splitlines()
    pos = 0
    out = {}
    for name, count, props in elements:
        key = _face_key(props) if name == "face" else None
        cols = {p: [] for p, _ in props}
        for k in range(count):
            while pos < len(lines) and not lines[pos].strip():
                pos += 1
            if pos >= len(lines):
                raise MeshFormatError(f"{path}: PLY ends early: element {name} {k} of {count} missing")
            tok = lines[pos].split()
            ln = hdr_lines + pos + 1
            pos += 1
            i = 0
            try:
                for p, t in props:
                    if isinstance(t, tuple):
                        n = int(tok[i])
                        cols[p].append([int(x) for x in tok[i + 1:i + 1 + n]])
                        if len(cols[p][-1]) != n:
                            raise IndexError
                        i += 1 + n
                    else:
                        cols[p].append(float(tok[i]))
                        i += 1
            except (IndexError, ValueError):
                raise MeshFormatError(f"{path}: line {ln}: bad {name} {k}: {lines[pos - 1].strip()!r}") from None
        if name == "vertex":
            out["vertex"] = {p: np.asarray(cols[p], dtype=float) for p in "xyz"}
        elif name == "face":
            if key is None:
                raise MeshFormatError(f"{path}: PLY face element has no vertex_indices list")
            out["face"] = cols[key]
    return out


def _ply_binary(path, body, elements):
    off = 0
    out = {}
    for name, count, props in elements:
        has_list = any(isinstance(t, tuple) for _, t in props)
        if not has_list:
            dt = np.dtype([(p, _PLY_TYPES[t]) for p, t in props])
            need = dt.itemsize * count
            if off + need > len(body):
                raise MeshFormatError(f"{path}: binary PLY ends early in element {name!r} "
                                      f"({len(body) - off} of {need} bytes)")
            arr = np.frombuffer(body, dtype=dt, count=count, offset=off)
            off += need
            if name == "vertex":
                out["vertex"] = {p: arr[p].astype(float) for p in "xyz"}
            continue
        key = _face_key(props) if name == "face" else None
        # fast path: a face element made only of a list of triangles
        if name == "face" and len(props) == 1 and key and count:
            _, ct, it = props[0][1]
            cdt, idt = np.dtype(_PLY_TYPES[ct]), np.dtype(_PLY_TYPES[it])
            rec = np.dtype([("n", cdt), ("i", idt, 3)])
            if off + rec.itemsize * count <= len(body):
                arr = np.frombuffer(body, dtype=rec, count=count, offset=off)
                if np.all(arr["n"] == 3):
                    out["face"] = arr["i"].astype(np.int64).tolist()
                    off += rec.itemsize * count
                    continue
        lists = []
        for k in range(count):
            for p, t in props:
                try:
                    if isinstance(t, tuple):
                        cdt, idt = np.dtype(_PLY_TYPES[t[1]]), np.dtype(_PLY_TYPES[t[2]])
                        n = int(np.frombuffer(body, cdt, 1, off)[0])
                        off += cdt.itemsize
                        vals = np.frombuffer(body, idt, n, off)
                        off += idt.itemsize * n
                        if p == key:
                            lists.append(vals.astype(np.int64).tolist())
                    else:
                        off += np.dtype(_PLY_TYPES[t]).itemsize
                        if off > len(body):
                            raise ValueError
                except ValueError:
                    raise MeshFormatError(f"{path}: binary PLY ends early in {name} {k} of {count}") from None
        if name == "face":
            if key is None:
                raise MeshFormatError(f"{path}: PLY face element has no vertex_indices list")
            out["face"] = lists
    return out


# --------------------------------------------------------------------------- OBJ

def write_obj(path, verts, faces):
    """OBJ, written whole or not at all."""
    atomic_write(path, obj_bytes(verts, faces))


def obj_bytes(verts, faces):
    v, f = _check(verts, faces)
    return ("# flank_addon OBJ\n" + "".join("v %.17g %.17g %.17g\n" % tuple(r) for r in v)
            + "".join("f %d %d %d\n" % tuple(r) for r in (f + 1))).encode("ascii")


def read_obj(path):
    verts = []
    tris = []
    with open(path, "r", errors="replace") as fh:
        for ln, line in enumerate(fh, 1):
            tok = line.split()
            if not tok or tok[0].startswith("#"):
                continue
            if tok[0] == "v":
                if len(tok) < 4:
                    raise MeshFormatError(f"{path}: line {ln}: 'v' needs 3 coordinates: {line.strip()!r}")
                try:
                    verts.append([float(t) for t in tok[1:4]])
                except ValueError:
                    raise MeshFormatError(f"{path}: line {ln}: bad vertex {line.strip()!r}") from None
            elif tok[0] == "f":
                if len(tok) < 4:
                    raise MeshFormatError(f"{path}: line {ln}: face needs >= 3 vertices: {line.strip()!r}")
                idx = []
                for t in tok[1:]:
                    try:
                        i = int(t.split("/")[0])
                    except ValueError:
                        raise MeshFormatError(f"{path}: line {ln}: bad face index {t!r}") from None
                    if i == 0:
                        raise MeshFormatError(f"{path}: line {ln}: face index 0 (OBJ indices start at 1)")
                    j = i - 1 if i > 0 else len(verts) + i
                    if not 0 <= j < len(verts):
                        raise MeshFormatError(f"{path}: line {ln}: face index {i} refers to a vertex not "
                                              f"defined yet ({len(verts)} so far)")
                    idx.append(j)
                tris.extend(_fan(idx))
            # vt, vn, g, o, s, usemtl, mtllib, l ... are ignored
    if not verts:
        raise MeshFormatError(f"{path}: OBJ has no vertices")
    v = np.asarray(verts, dtype=np.float64)
    f = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    return v, f


# --------------------------------------------------------------------------- dispatch

WRITERS = {".stl": write_stl, ".ply": write_ply, ".obj": write_obj}
READERS = {".stl": read_stl, ".ply": read_ply, ".obj": read_obj}


def _ext(path, table):
    ext = os.path.splitext(str(path))[1].lower()
    if ext not in table:
        raise MeshFormatError(f"{path}: unsupported mesh extension {ext!r}; use one of {sorted(table)}")
    return table[ext]


def write_mesh(path, verts, faces):
    """Write by extension: .stl (binary), .ply (binary little endian), .obj."""
    _ext(path, WRITERS)(path, verts, faces)


def read_mesh(path):
    """Read .stl (ascii/binary), .ply (ascii/binary_little_endian) or .obj -> (verts, faces)."""
    reader = _ext(path, READERS)
    if not os.path.exists(path):
        raise FileNotFoundError(2, "no such mesh file", str(path))
    return reader(path)
