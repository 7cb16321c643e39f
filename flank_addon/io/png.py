"""PNG files without a PNG library: 8-bit RGBA written with the 'Up' row filter, read back, and uncompressed
UTF-8 ``iTXt`` text chunks (the report pictures carry their numbers in one).  Files are written atomically.
"""
import os
import struct
import zlib

import numpy as np

from .files import atomic_write, output_path_error


def _chunk(tag, data):
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def write_png(path, rgba, text=None):
    """Write (H, W, 4) uint8, top row first, as an 8-bit RGBA PNG (:func:`png_bytes`), atomically."""
    atomic_write(path, png_bytes(rgba, text))


def png_bytes(rgba, text=None):
    """The PNG file of (H, W, 4) uint8, top row first: 8-bit RGBA, every row with the 'Up' filter (the byte
    difference to the row above).  ``text``: dict keyword -> str, stored as uncompressed UTF-8 iTXt chunks."""
    a = np.ascontiguousarray(rgba, dtype=np.uint8)
    h, w = a.shape[:2]
    rows = a.reshape(h, w * 4)
    up = rows - np.concatenate([np.zeros((1, w * 4), np.uint8), rows[:-1]])        # mod 256
    raw = np.concatenate([np.full((h, 1), 2, np.uint8), up], axis=1).tobytes()
    png = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
    for key, value in (text or {}).items():
        png += _chunk(b"iTXt", key.encode("latin-1") + b"\x00\x00\x00\x00\x00" + value.encode("utf-8"))
    return png + _chunk(b"IDAT", zlib.compress(raw, 6)) + _chunk(b"IEND", b"")


def _chunks(path):
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos = 8
    while pos + 8 <= len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        yield tag, data[pos + 8:pos + 8 + n]
        pos += 12 + n


def read_png(path):
    """(H, W, 4) uint8 of an 8-bit RGBA or RGB PNG whose rows use the filters None or Up (as :func:`write_png`;
    not every PNG: Sub, Average and Paeth rows are refused)."""
    idat, w = b"", None
    for tag, body in _chunks(path):
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            if depth != 8 or ctype not in (2, 6):
                raise ValueError(f"{path}: only 8-bit RGB/RGBA PNGs are read here")
            ch = 4 if ctype == 6 else 3
        elif tag == b"IDAT":
            idat += body
    if w is None:
        raise ValueError(f"{path}: no IHDR chunk")
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * ch)
    if not np.isin(raw[:, 0], (0, 2)).all():
        raise ValueError(f"{path}: rows with the Sub, Average or Paeth filter (not written by write_png)")
    px = raw[:, 1:].copy()
    for y in np.flatnonzero(raw[:, 0] == 2):
        if y > 0:
            px[y] += px[y - 1]                                          # Up: add the decoded row above (mod 256)
    px = px.reshape(h, w, ch)
    if ch == 3:
        px = np.concatenate([px, np.full((h, w, 1), 255, np.uint8)], axis=-1)
    return px


def read_png_text(path):
    """keyword -> text of the PNG's uncompressed iTXt chunks (the report's metadata: ``flank-report``)."""
    out = {}
    for tag, body in _chunks(path):
        if tag == b"iTXt":
            key, rest = body.split(b"\x00", 1)
            if rest[:1] == b"\x00":                                  # not compressed
                rest = rest[2:]                                      # compression flag + method
                _lang, rest = rest.split(b"\x00", 1)
                _tkey, text = rest.split(b"\x00", 1)
                out[key.decode("latin-1")] = text.decode("utf-8")
    return out


def check_output(path):
    """Raise ValueError unless a PNG can be written at ``path`` (its folder exists and is writable)."""
    path = os.path.abspath(path)
    folder = os.path.dirname(path)
    msg = output_path_error(path)
    if msg:
        raise ValueError(msg)
    probe = "{}.probe{}".format(path, os.getpid())
    try:
        open(probe, "wb").close()
        os.remove(probe)
    except OSError as ex:
        raise ValueError(f"cannot write into the folder {folder!r}: {ex.strerror or ex}") from None
    return path
