"""A PNG reader for the tests (the package only writes PNG files): ``read_png`` decodes an 8-bit RGB(A)
non-interlaced PNG with zlib and struct, every row filter of the format undone."""

import struct
import zlib

import numpy as np

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _unfilter(raw, h, w, bpp=4):
    """Undo the PNG row filters (0-4) of ``raw`` (h rows of 1 + w * bpp bytes)."""
    stride = w * bpp
    rows = np.frombuffer(raw, np.uint8).reshape(h, stride + 1)
    out = np.zeros((h, stride), np.uint8)
    prev = np.zeros(stride, np.int32)
    for y in range(h):
        kind, line = rows[y, 0], rows[y, 1:].astype(np.int32)
        if kind == 0:
            cur = line
        elif kind == 2:
            cur = (line + prev) & 0xFF
        else:
            cur = np.zeros(stride, np.int32)
            for x in range(stride):
                left = cur[x - bpp] if x >= bpp else 0
                up, ul = prev[x], (prev[x - bpp] if x >= bpp else 0)
                if kind == 1:
                    p = left
                elif kind == 3:
                    p = (left + up) // 2
                elif kind == 4:
                    pa, pb, pc = abs(up - ul), abs(left - ul), abs(left + up - 2 * ul)
                    p = left if pa <= pb and pa <= pc else (up if pb <= pc else ul)
                else:
                    raise ValueError(f"unknown PNG row filter {kind}")
                cur[x] = (line[x] + p) & 0xFF
        out[y] = cur
        prev = cur
    return out


def read_png(path) -> np.ndarray:
    """(height, width, 4) uint8 of an 8-bit RGBA (or RGB) non-interlaced PNG (what ``core.raster.write_png``
    writes); other kinds are refused in one line."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(_SIGNATURE):
        raise ValueError(f"{path}: not a PNG file")
    pos, head, idat = 8, None, []
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
        pos += 12 + n
    if head is None or head[2] != 8 or head[3] not in (2, 6) or head[6] != 0:
        raise ValueError(f"{path}: only 8-bit RGB(A) non-interlaced PNG files are read here")
    w, h, bpp = head[0], head[1], 4 if head[3] == 6 else 3
    img = _unfilter(zlib.decompress(b"".join(idat)), h, w, bpp).reshape(h, w, bpp)
    if bpp == 3:
        img = np.concatenate([img, np.full((h, w, 1), 255, np.uint8)], axis=2)
    return img
