"""A small numpy rasterizer for pictures made without a GPU or a render engine (pose thumbnails, docs figures):
``Canvas`` holds an RGBA uint8 image and draws anti-aliased thick lines (capsules: ``line``, ``polyline``), discs
(``disc``) and rectangles (``rect``) composited "over" it, each pixel's coverage the clipped signed distance of its
centre to the shape's edge (a one-pixel ramp: a disc of radius r covers pi (r^2 + 1/12) pixels, a capsule of length L
and half-width r 2 r L + pi (r^2 + 1/12)); ``png_bytes`` / ``write_png`` encode 8-bit RGBA PNG files with zlib and
struct only (no Pillow; Blender's own Python and the command line's both have them).
"""

import struct
import zlib

import numpy as np

from .errors import ShapeSigError

__all__ = ["Canvas", "png_bytes", "write_png", "coverage_of"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _rgba(color):
    """(4,) float RGBA in 0..1 from 3 or 4 numbers in 0..1."""
    c = np.asarray(color, np.float64).ravel()
    if c.size == 3:
        c = np.append(c, 1.0)
    if c.size != 4:
        raise ShapeSigError(f"a colour is 3 or 4 numbers, got {c.size}")
    return np.clip(c, 0.0, 1.0)


def _segment_distance(px, py, a, b):
    """Distance of the points (px, py) (broadcast arrays) to the segment a-b."""
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    n2 = dx * dx + dy * dy
    if n2 < 1e-18:
        return np.hypot(px - ax, py - ay)
    t = np.clip(((px - ax) * dx + (py - ay) * dy) / n2, 0.0, 1.0)
    return np.hypot(px - (ax + t * dx), py - (ay + t * dy))


def coverage_of(distance, radius):
    """Pixel coverage (0..1) of a shape whose edge lies ``radius`` from its core, for pixel centres at
    ``distance``: a linear ramp one pixel wide centred on the edge."""
    return np.clip(radius + 0.5 - distance, 0.0, 1.0)


class Canvas:
    """An RGBA image of ``height`` x ``width`` pixels (``pixels``: (height, width, 4) uint8, row 0 at the top),
    filled with ``background``. Coordinates are in pixels, x to the right, y down, pixel (i, j) centred at
    (j + 0.5, i + 0.5)."""

    def __init__(self, width: int, height: int, background=(1.0, 1.0, 1.0, 0.0)):
        if width < 1 or height < 1:
            raise ShapeSigError(f"a picture needs at least one pixel, got {width} x {height}")
        self.width, self.height = int(width), int(height)
        self._img = np.empty((self.height, self.width, 4), np.float64)
        self._img[:] = _rgba(background)

    @property
    def pixels(self) -> np.ndarray:
        """(height, width, 4) uint8 RGBA, straight (not premultiplied) alpha."""
        return np.round(np.clip(self._img, 0.0, 1.0) * 255.0).astype(np.uint8)

    def _box(self, x0, y0, x1, y1):
        """Pixel index ranges (rows, cols) covering the box, clipped to the canvas, or None when outside."""
        c0, c1 = max(int(np.floor(x0)), 0), min(int(np.ceil(x1)) + 1, self.width)
        r0, r1 = max(int(np.floor(y0)), 0), min(int(np.ceil(y1)) + 1, self.height)
        if c0 >= c1 or r0 >= r1:
            return None
        return r0, r1, c0, c1

    def paint(self, r0, c0, alpha, color):
        """Composite ``color`` with per-pixel coverage ``alpha`` (rows from r0, cols from c0) over the image."""
        col = _rgba(color)
        a = alpha * col[3]
        h, w = alpha.shape
        dst = self._img[r0:r0 + h, c0:c0 + w]
        out_a = a + dst[..., 3] * (1.0 - a)
        safe = np.where(out_a > 0, out_a, 1.0)
        for k in range(3):
            dst[..., k] = (col[k] * a + dst[..., k] * dst[..., 3] * (1.0 - a)) / safe
        dst[..., 3] = out_a

    def line(self, a, b, width: float, color):
        """A capsule from ``a`` to ``b`` (x, y), ``width`` pixels thick, with round ends."""
        self.polyline(np.array([a, b], np.float64), width, color)

    def polyline(self, points, width: float, color):
        """Capsules joining consecutive points (one coverage for the whole chain: joints are not painted twice)."""
        pts = np.asarray(points, np.float64)
        if len(pts) == 1:
            self.disc(pts[0], 0.5 * width, color)
            return
        r = 0.5 * float(width)
        box = self._box(pts[:, 0].min() - r - 1, pts[:, 1].min() - r - 1, pts[:, 0].max() + r + 1,
                        pts[:, 1].max() + r + 1)
        if box is None:
            return
        r0, r1, c0, c1 = box
        py, px = np.mgrid[r0:r1, c0:c1] + 0.5
        d = np.full(px.shape, np.inf)
        for a, b in zip(pts[:-1], pts[1:]):
            d = np.minimum(d, _segment_distance(px, py, a, b))
        self.paint(r0, c0, coverage_of(d, r), color)

    def disc(self, centre, radius: float, color):
        """A filled disc."""
        r = float(radius)
        box = self._box(centre[0] - r - 1, centre[1] - r - 1, centre[0] + r + 1, centre[1] + r + 1)
        if box is None:
            return
        r0, r1, c0, c1 = box
        py, px = np.mgrid[r0:r1, c0:c1] + 0.5
        self.paint(r0, c0, coverage_of(np.hypot(px - centre[0], py - centre[1]), r), color)

    def rect(self, x0, y0, x1, y1, color):
        """A filled axis-aligned rectangle [x0, x1] x [y0, y1] (fractional edges cover pixels partly)."""
        box = self._box(x0, y0, x1, y1)
        if box is None:
            return
        r0, r1, c0, c1 = box
        cols = np.clip(np.minimum(np.arange(c0, c1) + 1, x1) - np.maximum(np.arange(c0, c1), x0), 0, 1)
        rows = np.clip(np.minimum(np.arange(r0, r1) + 1, y1) - np.maximum(np.arange(r0, r1), y0), 0, 1)
        self.paint(r0, c0, rows[:, None] * cols[None, :], color)


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(rgba) -> bytes:
    """An 8-bit RGBA PNG of ``rgba`` ((height, width, 4) uint8, row 0 at the top), filter 0 on every row."""
    img = np.ascontiguousarray(rgba, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] != 4:
        raise ShapeSigError(f"a PNG is written from (height, width, 4) pixels, got {img.shape}")
    h, w = img.shape[:2]
    raw = np.zeros((h, 1 + 4 * w), np.uint8)
    raw[:, 1:] = img.reshape(h, 4 * w)
    head = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)
    return _SIGNATURE + _chunk(b"IHDR", head) + _chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) \
        + _chunk(b"IEND", b"")


def write_png(path, rgba) -> str:
    """Write ``png_bytes(rgba)`` to ``path``; returns the path."""
    with open(path, "wb") as f:
        f.write(png_bytes(rgba))
    return str(path)
