"""Labelled clip sets: the index CSV (``file,label[,skeleton][,start][,end][,step]``), display names, labels, and
reading an entry's clip through the one clip front door (``core.io.sources``)."""

import csv
import os
from dataclasses import dataclass
from typing import Optional

from ..core.io import sources
from ..core.clip.prepare import decimate_clip
from ..core.errors import ShapeSigError, UnreadableFileError
from ..core.io.files import file_problem

__all__ = ["IndexEntry", "read_index", "cut_clip", "unique_names", "labels_from_csv", "entry_spec", "entry_loader",
           "readable_entries"]


@dataclass(frozen=True)
class IndexEntry:
    """One row of an index CSV: ``file`` (relative to the data folder), ``label``, optional ``skeleton``
    (an .asf, relative to the data folder), ``start``/``end`` (crop, inclusive frame numbers) and ``step``
    (keep every step-th frame: the same take at 1/step of its rate, for the mixed-rate sets)."""

    file: str
    label: str
    skeleton: str = ""
    start: Optional[int] = None
    end: Optional[int] = None
    step: int = 1
    columns: tuple = ()  # every column of the row as (name, value) pairs (``column``)

    def column(self, name) -> str:
        """The row's value in column ``name`` (e.g. an actor for ``evaluate --group``); ShapeSigError if absent."""
        for k, v in self.columns:
            if k == name:
                return v
        raise ShapeSigError(f"the index has no column {name!r} (columns: {', '.join(k for k, _ in self.columns)})")


def _opt_int(value, where):
    value = (value or "").strip()
    if not value:
        return None
    try:
        return int(float(value))
    except ValueError:
        raise ShapeSigError(f"{where}: {value!r} is not a frame number") from None


def read_index(path):
    """Read an index CSV with columns file,label[,skeleton][,start][,end][,step] (header required); rows whose
    file starts with '#' are skipped."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as exc:
        raise ShapeSigError(f"cannot read index {path}: {exc.strerror or exc}") from None
    if not rows:
        raise ShapeSigError(f"{path}: no clips listed")
    missing = {"file", "label"} - set(rows[0].keys())
    if missing:
        raise ShapeSigError(f"{path}: missing column(s) {', '.join(sorted(missing))} (need file,label)")
    entries = []
    for i, row in enumerate(rows, start=2):
        f = (row.get("file") or "").strip()
        if not f or f.startswith("#"):
            continue
        label = (row.get("label") or "").strip()
        if not label:
            raise ShapeSigError(f"{path}:{i}: empty label")
        entries.append(IndexEntry(file=f, label=label, skeleton=(row.get("skeleton") or "").strip(),
                                  start=_opt_int(row.get("start"), f"{path}:{i}"),
                                  end=_opt_int(row.get("end"), f"{path}:{i}"),
                                  step=_opt_int(row.get("step"), f"{path}:{i}") or 1,
                                  columns=tuple((k, (v or "").strip()) for k, v in row.items() if k)))
    if not entries:
        raise ShapeSigError(f"{path}: no clips listed")
    return entries


def unique_names(names):
    """Make names unique by appending #2, #3 to repeats."""
    seen = {}
    out = []
    for n in names:
        if n in seen:
            seen[n] += 1
            out.append(f"{n}#{seen[n]}")
        else:
            seen[n] = 1
            out.append(n)
    return out


def labels_from_csv(path, names):
    """Labels for clip names from an index CSV (matched on the file stem); 'unknown' when absent."""
    by_stem = {}
    for e in read_index(path):
        by_stem[os.path.splitext(os.path.basename(e.file))[0]] = e.label
    return [by_stem.get(n.split("#")[0], by_stem.get(os.path.splitext(n)[0], "unknown")) for n in names]


def entry_spec(entry: IndexEntry, data, asf=None, fps=None, trim="auto", bone_map="auto") -> sources.ClipSpec:
    """The ClipSpec of an entry: paths relative to ``data``; the skeleton is the entry's, else ``asf``, else the
    only .asf beside the .amc; the entry's ``start``/``end`` crop (an explicit end wins over ``trim``);
    ``fps`` overrides the file's rate; ``bone_map`` the comparison space across rigs (computed on the cropped,
    trimmed clip: core.rigs' heading)."""
    skeleton = os.path.join(data, entry.skeleton) if entry.skeleton else asf
    return sources.ClipSpec.parse(os.path.join(data, entry.file), asf=skeleton, start=entry.start, end=entry.end,
                                  fps=fps, trim=trim or "auto", bone_map=bone_map)


def readable_entries(entries, data):
    """``(entries, skipped)``: the entries whose file the readers open, and an UnreadableFileError for each other
    one (a FIFO, a device, a dangling or looping link, a file over a cap: ``core.io.files``). A missing file stays
    (reading it names it)."""
    keep, skipped = [], []
    for entry in entries:
        path = sources.ClipSpec.parse(os.path.join(data, entry.file)).path
        problem = file_problem(path) if os.path.lexists(path) else None
        if problem is None:
            keep.append(entry)
        else:
            skipped.append(UnreadableFileError(problem, path))
    return keep, skipped


def cut_clip(clip, side, fraction):
    """The clip with ``fraction`` of its frames (rounded) cut at its ``side`` ("start" or "end"): a crop probe."""
    cut = int(round(fraction * clip.frames))
    if side == "start":
        return clip.crop(clip.frame_start + cut, None)
    if side == "end":
        return clip.crop(None, clip.frame_end - cut)
    raise ShapeSigError(f"a cut is at the start or the end, not {side!r}")


def entry_loader(data, asf=None, cache=None, fps=None, trim="auto", bone_map="auto", cut=None):
    """``loader(entry) -> Clip`` for ``evaluate``: ``sources.read_one`` of ``entry_spec`` (with ``fps``, ``trim``
    and ``bone_map``). ``cache`` (a dict) keeps the clips read, keyed by the spec, for runs that share files.
    ``cut``: (side, fraction): the clip is cut (``cut_clip``) before the bone map, as a shorter file would be."""

    def loader(entry):
        spec = entry_spec(entry, data, asf, fps, trim, "none" if cut else bone_map)
        if cache is None:
            clip = sources.read_one(spec)
        else:
            if spec not in cache:
                cache[spec] = sources.read_one(spec)
            clip = cache[spec]
        clip = decimate_clip(clip, entry.step)
        if cut:
            clip = sources.after_read([cut_clip(clip, *cut)], bone_map=bone_map)[0]
        return clip

    return loader
