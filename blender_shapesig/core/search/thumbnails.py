"""Pose thumbnails: a clip as a strip of a few key poses (``POSES``) of the canonical body, drawn by the numpy
rasterizer (``core.raster``) from the local search's key points (``local.body_positions`` by forward kinematics in
the comparison space, stored per clip as its entry's ``sequence``: relative to the pelvis, the facing removed, in
leg lengths), seen from the body's right side, each pose standing on the ground line at ``SCALE`` pixels per leg
length, so clips of any rig and size look alike. Key poses (``key_times``): one per equal slot of the clip (or of a
matched window), the slot's pose furthest from the mean pose. A timeline under the figures marks the key times and
the window. ``thumbnail`` makes a picture once and keeps it in the signature cache's own folder beside the item's
entries (same key; ``SignatureCache`` deletes it with them). See docs/search.md, "Pictures".
"""

import os
from typing import Optional, Sequence, Tuple

import numpy as np

from ..errors import ShapeSigError
from ..raster import Canvas, png_bytes
from .local import features as local
from .local.rank import item_local_entries
from .local.store import hashed_name

__all__ = ["POSES", "SCALE", "HEIGHT", "SLOT", "THUMB_VERSION", "key_times", "poses_of", "draw_strip",
           "entry_strip", "figure_mask", "thumbnail_file", "thumbnail", "local_entry_of", "warped_times", "picture_bytes",
           "frame_window"]

POSES = 4            # key poses per strip (3 to 5 read well at icon sizes)
SCALE = 36.0         # pixels per leg length (hip joint to ankle)
HEIGHT = 96          # pixels; the ground line at GROUND pixels from the top, the timeline below it
SLOT = 48            # pixels of width per pose
GROUND = 86
WIDTH = 0.13         # limb thickness, leg lengths (the torso 1.4 times it)
HEAD = 0.2           # neck to the head's centre, leg lengths
THUMB_VERSION = 1    # bump when the drawing changes (part of every picture's file name)

_BACKGROUND = (0.93, 0.93, 0.92, 1.0)
_NEAR, _FAR, _BODY = (0.13, 0.18, 0.28), (0.55, 0.60, 0.68), (0.20, 0.24, 0.32)
_ACCENT = (0.90, 0.42, 0.10)
_IDX = {p: i for i, p in enumerate(local.POINTS)}


def poses_of(entry) -> np.ndarray:
    """(samples, points, 3) the key points of a local entry's ``sequence`` (``local.POINTS``; pelvis at 0)."""
    seq = np.asarray(entry.sequence, np.float64)
    n = len(local.POINTS)
    if seq.ndim != 2 or seq.shape[1] < 3 * n or len(seq) == 0:
        raise ShapeSigError("the clip's key points are missing from its index entry")
    return seq[:, :3 * n].reshape(len(seq), n, 3)


def _peak_offset(y, i):
    """The sub-sample offset (-0.5..0.5) of the maximum of the parabola through y[i-1], y[i], y[i+1]."""
    if i <= 0 or i >= len(y) - 1:
        return 0.0
    den = y[i - 1] - 2.0 * y[i] + y[i + 1]
    return float(np.clip(0.5 * (y[i - 1] - y[i + 1]) / den, -0.5, 0.5)) if den < 0 else 0.0


def key_times(P: np.ndarray, count: int = POSES, window: Optional[Tuple[float, float]] = None) -> np.ndarray:
    """(count,) fractions 0..1 of the clip: in each of ``count`` equal slots of ``window`` (fractions; None: the
    whole clip), the sample whose pose is furthest from the span's mean pose (the slot's extreme: a stride's
    widest, a jump's crouch or top)."""
    T = len(P)
    u0, u1 = window if window is not None else (0.0, 1.0)
    u0, u1 = float(np.clip(min(u0, u1), 0, 1)), float(np.clip(max(u0, u1), 0, 1))
    if T < 2:
        return np.full(count, u0)
    lo, hi = int(np.floor(u0 * (T - 1))), int(np.ceil(u1 * (T - 1)))
    span = P[lo:hi + 1].reshape(hi - lo + 1, -1)
    far = np.linalg.norm(span - span.mean(axis=0), axis=1)
    out = []
    for k in range(count):
        a = lo + int(round(k * (hi - lo + 1) / count))
        b = max(lo + int(round((k + 1) * (hi - lo + 1) / count)), a + 1)
        i = a + int(np.argmax(far[a - lo:b - lo]))
        out.append((i + _peak_offset(far, i - lo)) / (T - 1))
    return np.array(out)


def pose_at(P: np.ndarray, u: float) -> np.ndarray:
    """(points, 3) the pose at fraction ``u`` of the clip, linearly interpolated between samples."""
    s = float(np.clip(u, 0.0, 1.0)) * (len(P) - 1)
    i = min(int(np.floor(s)), max(len(P) - 2, 0))
    w = s - i if len(P) > 1 else 0.0
    return P[i] * (1.0 - w) + P[min(i + 1, len(P) - 1)] * w


def warped_times(times, warp) -> np.ndarray:
    """The times of a second clip matched to ``times`` of the first through a warp ((nodes, 2) of (t0, t1))."""
    w = np.asarray(warp, np.float64)
    return np.interp(np.asarray(times, np.float64), w[:, 0], w[:, 1])


def _side_view(p):
    """(points, 2) screen offsets in leg lengths of one pose: x forward, y up (the viewer on the body's right)."""
    return np.column_stack([-p[:, 1], p[:, 2]])


def _draw_pose(canvas, pose, cx, color_scale=1.0, accent=False):
    """One figure, its lowest ankle on the ground line, its pelvis at x = ``cx`` pixels."""
    q = _side_view(pose)
    pelvis = np.zeros(2)
    ground = min(q[_IDX["ankle.L"], 1], q[_IDX["ankle.R"], 1]) - 0.04

    def px(v):
        return np.array([cx + SCALE * v[0], GROUND - SCALE * (v[1] - ground)])

    def pt(name):
        return px(q[_IDX[name]])

    alpha = color_scale
    near = _ACCENT if accent else _NEAR
    neck = 0.5 * (pt("shoulder.L") + pt("shoulder.R"))
    # the head along the torso: rigs place the skull's base differently (0.2 leg lengths apart for one take)
    up = neck - px(pelvis)
    head = neck + up * (HEAD / max(np.linalg.norm(up) / SCALE, 1e-9))
    width = WIDTH * SCALE
    # the far (left) limbs first, then the torso and head, then the near (right) limbs
    for side, color in (("L", _FAR), ("R", None)):
        if color is None:
            canvas.polyline([px(pelvis), neck], width * 1.4, _BODY + (alpha,))
            canvas.disc(head, 0.12 * SCALE, _BODY + (alpha,))
            color = near
        canvas.polyline([px(pelvis), pt(f"knee.{side}"), pt(f"ankle.{side}")], width, color + (alpha,))
        canvas.polyline([neck, pt(f"elbow.{side}"), pt(f"wrist.{side}")], width * 0.85, color + (alpha,))


def draw_strip(P: np.ndarray, times: Sequence[float], window: Optional[Tuple[float, float]] = None,
               marks: Optional[Sequence[float]] = None) -> np.ndarray:
    """(HEIGHT, SLOT * len(times), 4) uint8: the poses of ``P`` (samples, points, 3) at ``times`` (fractions) side
    by side, and the clip's timeline below them with the key times (or ``marks``) and the ``window`` in the
    accent colour (the poses then drawn in it too)."""
    n = len(times)
    canvas = Canvas(SLOT * n, HEIGHT, _BACKGROUND)
    canvas.rect(0, GROUND, canvas.width, GROUND + 1, (0.70, 0.70, 0.68))
    for k, u in enumerate(times):
        _draw_pose(canvas, pose_at(P, u), SLOT * (k + 0.5), accent=window is not None)
    x0, x1, y0 = 3.0, canvas.width - 3.0, HEIGHT - 6.0
    canvas.rect(x0, y0, x1, y0 + 3, (0.78, 0.78, 0.76))
    if window is not None:
        canvas.rect(x0 + (x1 - x0) * min(window), y0, x0 + (x1 - x0) * max(window), y0 + 3, _ACCENT)
    for u in (times if marks is None else marks):
        x = x0 + (x1 - x0) * float(np.clip(u, 0, 1))
        canvas.rect(x - 0.75, y0 - 2, x + 0.75, y0 + 3, _BODY)
    return canvas.pixels


def entry_strip(entry, count: int = POSES, window=None) -> np.ndarray:
    """``draw_strip`` of a local entry's key poses (``key_times``, inside ``window`` when given)."""
    P = poses_of(entry)
    return draw_strip(P, key_times(P, count, window), window)


def figure_mask(rgba: np.ndarray, grow: int = 0) -> np.ndarray:
    """(GROUND, width) bool: the pixels of the figures (above the ground line, differing from the background),
    grown by ``grow`` pixels (two rigs place a joint a pixel or two apart: the same take then still agrees)."""
    img = np.asarray(rgba, np.int32)[:GROUND]
    bg = np.round(np.array(_BACKGROUND[:3]) * 255).astype(np.int32)
    mask = np.abs(img[..., :3] - bg).max(axis=-1) > 40
    if grow:
        from scipy.ndimage import binary_dilation

        mask = binary_dilation(mask, iterations=int(grow))
    return mask


def _window_text(window):
    return "" if window is None else f"{min(window):.4f}-{max(window):.4f}"


def thumbnail_file(store, key: str, name: str, window=None, count: int = POSES) -> Optional[str]:
    """The picture's file in the cache's own folder (None when the cache has no folder): named by the item's key,
    the clip, the window, the pose count, the drawing and the local search's settings."""
    if store is None or store.path is None:
        return None
    text = f"{key}|THUMB|{name}|{_window_text(window)}|{count}|V{THUMB_VERSION}|{local.settings_key()}|F{store.FORMAT}"
    return os.path.join(store.path, hashed_name(text) + ".png")


def local_entry_of(item, store, name: Optional[str] = None):
    """The local entry of clip ``name`` (None: the item's only or first clip) of a library item, from the store,
    else computed (the item's clips read); ShapeSigError when the local features refuse it (e.g. no legs)."""
    got = item_local_entries(item, store)
    e = next((x for x in got if name is None or x.name == name), None)
    if e is None:
        raise ShapeSigError(f"{item.name!r} has no clip {name!r}")
    if e.refused:
        raise ShapeSigError(f"no picture of {e.name!r}: {e.refused}")
    return e


def thumbnail(item, store, name: Optional[str] = None, window=None, count: int = POSES) -> Tuple[str, bool]:
    """(path, made): the picture of clip ``name`` of ``item`` (a ``LibraryItem``), from the cache's folder when it
    is there, else drawn (``entry_strip``) and written there (atomically). ShapeSigError (one line) when the
    clip has no key points or the cache has no folder."""
    name = name if name is not None else item.name
    path = thumbnail_file(store, item.key, name, window, count)
    if path is None:
        raise ShapeSigError("pictures are kept in the index folder, and the index has none")
    if os.path.isfile(path):
        return path, False
    rgba = entry_strip(local_entry_of(item, store, name), count, window)
    try:
        store._atomic_write(path, png_bytes(rgba))
    except OSError as exc:
        raise ShapeSigError(f"cannot write the picture ({exc.strerror or exc}: {store.path})") from None
    return path, True


def picture_bytes(item, store, name: Optional[str] = None, window=None, count: int = POSES) -> bytes:
    """The PNG bytes of a clip's picture: through the cache's folder (``thumbnail``) when it has one, else drawn
    now (a memory-only store)."""
    if store is not None and store.path is not None:
        path, _made = thumbnail(item, store, name, window, count)
        from ..io.files import open_regular

        try:
            with open_regular(path, cap=False) as f:  # a regular file only (a FIFO put there would hang)
                return f.read()
        except ShapeSigError:
            pass  # drawn again below
        store._discard(path)
    name = name if name is not None else item.name
    return png_bytes(entry_strip(local_entry_of(item, store, name), count, window))


def frame_window(start, end, frames: int, trimmed=(), first: int = 1):
    """A window of frames ``start``..``end`` (the clip's own numbers) as fractions of a clip of ``frames`` frames
    whose first frame is the first kept by trimming (``trimmed``' first number), else ``first``; None without a
    window."""
    if start is None or end is None or frames < 2:
        return None
    base = trimmed[0] if trimmed else first
    return tuple(min(max((f - base) / (frames - 1), 0.0), 1.0) for f in (start, end))
