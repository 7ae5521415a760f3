"""Pictures of the result rows (Blender layer): after a Find Similar click, a ``ThumbJob`` makes each row's strip of
key poses (``core.search.thumbnails``: drawn once, kept in the index folder beside the clip's entries, reused by
later sessions) and loads it into the add-on's ``bpy.utils.previews`` collection, a few rows per tick of a
``bpy.app.timers`` timer, so the click itself is never slower; each row then has ``preview_path`` (the PNG) and
``preview_icon`` (its icon id: 0 while pending, and always 0 in background mode, where Blender makes no icons).
Headless scripts step the job themselves (``current_job().step()``). The Why Different box's pair of strips
aligned by the warp is ``why_pictures``. ``free_previews`` (unregister) frees the collection.
"""

import os
import time
from typing import Optional

import bpy
import bpy.utils.previews

from ..core.errors import ShapeSigError
from ..core.search import thumbnails as core_thumbs
from ..core.raster import png_bytes
from ..properties import results_of

__all__ = ["previews", "free_previews", "icon_of", "ThumbJob", "start_job", "current_job", "window_fraction",
           "why_pictures", "STEP_SECONDS"]

STEP_SECONDS = 0.02  # work per timer tick (the UI stays responsive)
_TICK = 0.05         # seconds between ticks
_STATE = {"previews": None, "job": None}


def previews():
    """The add-on's preview collection (made on first use)."""
    if _STATE["previews"] is None:
        _STATE["previews"] = bpy.utils.previews.new()
    return _STATE["previews"]


def free_previews():
    """Stop the running job and free the preview collection (unregister)."""
    _STATE["job"] = None
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    if _STATE["previews"] is not None:
        bpy.utils.previews.remove(_STATE["previews"])
        _STATE["previews"] = None


def icon_of(path: str) -> int:
    """The icon id of a picture file, loaded into the collection once (0 in background mode)."""
    if not path:
        return 0
    pcoll = previews()
    got = pcoll.get(path)
    if got is None:
        got = pcoll.load(path, path, "IMAGE")
    return int(got.icon_id)


def window_fraction(row):
    """A moment row's matched window as fractions (u0, u1) of its clip, or None for a whole clip. The clip's
    first frame: the first compared (trimmed clips), else the action's first frame, else 1 (a file's)."""
    if not row.frame_last or row.frames < 2:
        return None
    action = bpy.data.actions.get(row.source) if row.is_action else None
    first = row.kept_first if row.read_last else (int(round(action.frame_range[0])) if action is not None else 1)
    span = float(row.frames - 1)
    return tuple(min(max((f - first) / span, 0.0), 1.0) for f in (row.frame_first, row.frame_last))


class ThumbJob:
    """The pictures of one click: ``tasks`` [(row index or None for the query, clip name, LibraryItem, window)],
    made in order by ``step``; ``failed`` {clip name: one-line reason} (no legs, no index folder)."""

    def __init__(self, cache, tasks, query_name=""):
        self.cache, self.tasks, self.query_name = cache, list(tasks), query_name
        self.done, self.failed = 0, {}

    @property
    def finished(self) -> bool:
        return self.done >= len(self.tasks)

    def step(self, seconds: float = STEP_SECONDS) -> bool:
        """Make pictures for about ``seconds`` (at least one); True when every row has been handled."""
        t_end = time.perf_counter() + seconds
        while not self.finished:
            self._one(*self.tasks[self.done])
            self.done += 1
            if time.perf_counter() >= t_end:
                break
        return self.finished

    def _one(self, index, name, item, window):
        out = results_of()
        if out.query_name != self.query_name:
            self.done = len(self.tasks)  # another click replaced the rows
            return
        try:
            path, _made = core_thumbs.thumbnail(item, self.cache, name, window)
        except (ShapeSigError, OSError) as exc:
            self.failed[name] = str(exc)
            return
        icon = icon_of(path)
        if index is None:
            out.query_preview_path, out.query_preview_icon = path, icon
        elif index < len(out.results) and out.results[index].clip_name == name:
            row = out.results[index]
            row.preview_path, row.preview_icon = path, icon


def _tick():
    job = _STATE["job"]
    if job is None:
        return None
    try:
        done = job.step()
    except Exception:  # noqa: BLE001 - a picture is never worth an error in the UI; the rows keep no picture
        done = True
    _redraw()
    if done:
        _STATE["job"] = None
        return None
    return _TICK


def _redraw():
    wm = getattr(bpy.context, "window_manager", None)
    for window in getattr(wm, "windows", ()):
        for area in window.screen.areas:
            if area.type in ("VIEW_3D", "DOPESHEET_EDITOR", "NLA_EDITOR"):
                area.tag_redraw()


def current_job() -> Optional[ThumbJob]:
    """The job making the last click's pictures, or None when none is running."""
    return _STATE["job"]


def start_job(cache, rows, query_item, query_name) -> ThumbJob:
    """Start making the pictures of ``rows`` (RankResults, in the order of the result rows) and of the query, in
    the background (a timer); returns the job."""
    out = results_of()
    tasks = [(None, query_item.name, query_item, None)]
    for i, r in enumerate(rows):
        item = r.item  # the library item the row came from
        if item is not None and i < len(out.results):
            window = window_fraction(out.results[i])
            tasks.append((i, r.name, item, window))
    out.query_preview_path, out.query_preview_icon = "", 0
    job = _STATE["job"] = ThumbJob(cache, tasks, query_name)
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=0.0)
    return job


def why_pictures(cache, query_item, item, name, warp, window=None, count=core_thumbs.POSES):
    """(query picture, result picture): the query's key poses and the result's poses at the times the warp
    matches to them (inside ``window`` for a moment), written beside the entries; paths ("" when there is no
    index folder)."""
    import hashlib
    import numpy as np

    if cache.path is None:
        return "", ""
    qe = core_thumbs.local_entry_of(query_item, cache)
    re_ = core_thumbs.local_entry_of(item, cache, name)
    Pq, Pr = core_thumbs.poses_of(qe), core_thumbs.poses_of(re_)
    tq = core_thumbs.key_times(Pq, count)
    tr = core_thumbs.warped_times(tq, warp)
    if window is not None:
        tr = window[0] + tr * (window[1] - window[0])
    out = []
    for key, P, times in ((query_item.key, Pq, tq), (item.key, Pr, tr)):
        tag = hashlib.sha1(f"{key}|WHY|{np.round(times, 4).tolist()}|{core_thumbs.THUMB_VERSION}".encode())
        path = os.path.join(cache.path, tag.hexdigest() + ".png")
        if not os.path.isfile(path):
            cache._atomic_write(path, png_bytes(core_thumbs.draw_strip(P, times, window if P is Pr else None)))
        out.append(path)
    return tuple(out)
