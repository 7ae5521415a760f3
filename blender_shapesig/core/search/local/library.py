"""The local search's library file (``local_pack.bin`` in the cache's folder): every cached item's local entries in
one file that a new process opens with ``numpy.memmap`` instead of reading (``open_library``), written in one pass
from an iterable of files' entries (``write_library``): a header (magic, JSON index of files and clips, the arrays'
offsets, the file's total size; each distinct joint list once, a clip naming its lists by number: a rig's clips
share them) then the arrays, 64-byte aligned: ``windows`` (all windows stacked, float16, N x DIM)
with their squared norms (float32), ``sequences`` (float16), ``paths`` (float32, 10 a clip), ``coarse`` (``COARSE``
windows of each clip as float32, the prefilter of ``local.first_stage``), ``takes`` (float32, ``take.DIM`` a clip),
``take_masks`` (uint8, one per canonical joint; none set: the entry has no take) and ``descriptions`` (float32,
``description.PARTS`` a clip; NaN: none); a file written before the takes or the descriptions reads without them.
A file whose header, sizes or row ranges do not hold is refused in one line (ValueError); the cache then deletes
and rebuilds it. See docs/search.md, "At library scale".
"""

import json
import struct

import numpy as np

from . import description, features as local, take
from .entry import JOINT_LISTS, LocalEntry, Refusal, meta_fields

__all__ = ["MAGIC", "COARSE", "write_library", "open_library", "coarse_windows", "LibraryFile"]

MAGIC = b"SHAPESIG-LPACK3\n"
_READABLE = (MAGIC, b"SHAPESIG-LPACK2\n")  # version 2 kept each clip's joint lists in place (read as they are)
COARSE = 4  # windows of each clip kept for the prefilter (evenly spaced over its windows, both scales)
_ALIGN = 64
_SEQ_DIM = 3 * len(local.POINTS)  # an entry's sequence's width when its clip's meta does not say (older recipes)


_NO_TAKE = np.zeros(take.DIM, np.float32)
_NO_MASK = np.zeros(len(take.JOINTS), np.uint8)
_NO_DESCRIPTION = np.full(len(description.PARTS), np.nan, np.float32)  # an older recipe's entry: read back as none


def _description(e):
    """An entry's description as stored: none (NaN) for an entry of an older recipe, without one or with another
    number of parts (``description.description_of``; one kept in the pack until its file goes)."""
    d = description.description_of(e)
    return _NO_DESCRIPTION if d is None else d.astype(np.float32)


def coarse_windows(windows, k=COARSE) -> np.ndarray:
    """The clip's prefilter windows (``local.coarse_windows``)."""
    return local.coarse_windows(windows, k)


def _pad(n):
    return (-n) % _ALIGN


def write_library(f, files, fmt):
    """Write the library file to the open binary file ``f`` from ``files``: an iterable (read twice: make it a
    list) of ``(name, size, mtime_ns, meta, entries)`` (``meta["clips"]`` one per entry; a refused entry has no
    arrays). Returns the number of clips with windows."""
    files = list(files)
    rows, nw, nq, nc = [], 0, 0, 0
    index, lists, at = [], [], {}

    def listed(v):  # a joint list by its number in the header's table (a rig's clips share one)
        t = tuple(str(j) for j in v)
        if t not in at:
            at[t] = len(lists)
            lists.append(list(t))
        return at[t]

    for name, size, mtime, meta, entries in files:
        meta = dict(meta, clips=[dict(m, **{k: listed(m[k]) for k in JOINT_LISTS if k in m}) for m in meta["clips"]])
        r = []
        for e in entries:
            if e.refused:
                r.append((0, 0, 0, 0, -1))
                continue
            w, q = len(e.windows), len(e.sequence)
            r.append((nw, nw + w, nq, nq + q, nc))
            nw, nq, nc = nw + w, nq + q, nc + 1
        index.append([name, int(size), int(mtime), meta, r])
        rows.append(r)
    dim = local.DIM
    # one width for every entry's sequence (recipes differ: the narrower are padded, read back at their width)
    width = max([np.shape(e.sequence)[1] for f in files for e in f[4] if not e.refused] + [_SEQ_DIM])
    specs = [("windows", np.float16, (nw, dim)), ("norms", np.float32, (nw,)), ("sequences", np.float16, (nq, width)),
             ("paths", np.float32, (nc, 10)), ("coarse", np.float32, (nc, COARSE, dim)),
             ("takes", np.float32, (nc, take.DIM)), ("take_masks", np.uint8, (nc, len(take.JOINTS))),
             ("descriptions", np.float32, (nc, len(description.PARTS)))]
    # the header's size must be known before the offsets: lay the arrays out after a generous estimate
    head = json.dumps({"format": fmt, "files": index, "lists": lists}).encode("utf-8")
    start = len(MAGIC) + 8 + len(head) + 4096
    start += _pad(start)
    arrays, end = {}, start
    for name, dt, shape in specs:
        nbytes = int(np.prod(shape)) * np.dtype(dt).itemsize
        arrays[name] = [end, list(shape), np.dtype(dt).str]
        end += nbytes + _pad(nbytes)
    header = json.dumps({"format": fmt, "files": index, "lists": lists, "arrays": arrays, "total": end}
                        ).encode("utf-8")
    if len(MAGIC) + 8 + len(header) > start:
        raise ValueError("header too large")  # cannot happen: the arrays' offsets add < 4 KB
    f.write(MAGIC + struct.pack("<Q", len(header)) + header)
    f.write(b"\0" * (start - f.tell()))

    def each():
        for (_, _, _, _, entries) in files:
            for e in entries:
                if not e.refused:
                    yield e

    def put(name, chunks):
        at0 = arrays[name][0]
        assert f.tell() == at0
        for c in chunks:
            f.write(np.ascontiguousarray(c).tobytes())
        f.write(b"\0" * (_pad(f.tell() - at0)))

    put("windows", (np.asarray(e.windows, np.float16) for e in each()))
    put("norms", (np.square(np.asarray(e.windows, np.float32)).sum(1) for e in each()))
    put("sequences", (np.pad(np.asarray(e.sequence, np.float16), ((0, 0), (0, width - np.shape(e.sequence)[1])))
                      for e in each()))
    put("paths", (np.asarray(e.path, np.float32).reshape(10) for e in each()))
    put("coarse", (coarse_windows(e.windows) for e in each()))
    # an entry made before the whole take was stored (an older recipe's, kept in the pack until its file goes) has
    # none: zeros, and a mask of no joints, which ``LibraryFile.entry`` reads back as no take
    put("takes", (np.asarray(_NO_TAKE if e.take is None else e.take, np.float32).reshape(take.DIM)
                   for e in each()))
    put("take_masks", (np.asarray(_NO_MASK if e.take is None else e.take_mask, np.uint8).reshape(len(take.JOINTS))
                       for e in each()))
    put("descriptions", (_description(e) for e in each()))
    return nc


class LibraryFile:
    """An opened library file: ``files`` [[name, size, mtime_ns, meta, rows]] (rows: (w0, w1, q0, q1, clip) per
    clip, clip -1 when refused) and the memory-mapped arrays by name (``windows``, ``norms``, ``sequences``,
    ``paths``, ``coarse``); nothing is read until used."""

    def __init__(self, fmt, files, arrays):
        self.format, self.files, self.arrays = fmt, files, arrays
        self._has = None  # (has a take, has a description) per clip: made at the first entry, for all clips at once

    def entry(self, m, row):
        """The entry of one clip (``meta["clips"][i]``, its row) with memory-mapped arrays."""
        if m.get("refused"):
            return Refusal(m["name"], str(m["refused"]))
        w0, w1, q0, q1, k = row
        A = self.arrays
        e = LocalEntry(windows=A["windows"][w0:w1], sequence=A["sequences"][q0:q1, :int(m.get("seq_dim", _SEQ_DIM))],
                       path=A["paths"][k], rows=(id(self), w0, w1, k), **meta_fields(m))
        if self._has is None:
            D = self.descriptions()
            self._has = (A["take_masks"].any(axis=1) if "takes" in A else None,
                         np.isfinite(D).all(axis=1) if D is not None else None)
        has_take, has_description = self._has
        if has_take is not None and has_take[k]:
            e.take, e.take_mask, e.seconds = A["takes"][k], A["take_masks"][k], np.float32(m.get("seconds", 0.0))
        if has_description is not None and has_description[k]:
            e.describe = A["descriptions"][k]
        return e

    def descriptions(self):
        """(clips, ``description.PARTS``) the clips' descriptions as memory-mapped (NaN rows: none), or None for a file
        without them or of another recipe's width."""
        D = self.arrays.get("descriptions")
        return D if D is not None and D.shape[1] == len(description.PARTS) else None

    def stack(self):
        """The whole file as ``local.first_stage``'s library (no copy): windows, norms, coarse and, per clip, its
        window rows (``starts``, ``ends``) in file order."""
        starts, ends = [], []
        for *_, rows in self.files:
            for w0, w1, _, _, k in rows:
                if k >= 0:
                    starts.append(w0), ends.append(w1)
        return {"windows": self.arrays["windows"], "norms": self.arrays["norms"], "coarse": self.arrays["coarse"],
                "starts": np.asarray(starts, np.int64), "ends": np.asarray(ends, np.int64),
                "descriptions": self.descriptions()}


def open_library(fn) -> LibraryFile:
    """Open the library file ``fn`` (memory-mapped, read-only). ValueError (one line) when it is not one, is
    truncated or its index does not hold."""
    with open(fn, "rb") as f:
        magic = f.read(len(MAGIC))
        if magic not in _READABLE:
            raise ValueError(f"{fn}: not a library file of this version")
        (n,) = struct.unpack("<Q", f.read(8))
        f.seek(0, 2)
        size = f.tell()
        if n > size:
            raise ValueError(f"{fn}: damaged (header beyond the end)")
        f.seek(len(MAGIC) + 8)
        try:
            header = json.loads(f.read(n).decode("utf-8"))
        except (UnicodeDecodeError, ValueError):
            raise ValueError(f"{fn}: damaged (unreadable header)") from None
    if not isinstance(header, dict) or header.get("total") != size:
        raise ValueError(f"{fn}: damaged (size {size} bytes, its header says {header.get('total')})")
    arrays = {}
    for name, (offset, shape, dt) in header["arrays"].items():
        count = int(np.prod(shape))
        if offset + count * np.dtype(dt).itemsize > size:
            raise ValueError(f"{fn}: damaged (array {name} beyond the end)")
        # a plain ndarray view of the map: slicing it per entry costs a tenth of a memmap's (2,000 entries: 0.15 s)
        arrays[name] = (np.asarray(np.memmap(fn, dtype=np.dtype(dt), mode="r", offset=offset, shape=tuple(shape)))
                        if count else np.zeros(tuple(shape), np.dtype(dt)))
    nw, nq, nc = len(arrays["windows"]), len(arrays["sequences"]), len(arrays["paths"])
    lists = [tuple(str(j) for j in v) for v in header.get("lists", ())]
    for file in header["files"]:
        for m in file[3]["clips"]:
            for k in JOINT_LISTS:
                v = m.get(k)
                if isinstance(v, int):
                    if not 0 <= v < len(lists):
                        raise ValueError(f"{fn}: damaged (a clip's joint list is not in the file)")
                    m[k] = lists[v]
        for w0, w1, q0, q1, k in file[4]:
            if k >= 0 and not (0 <= w0 < w1 <= nw and 0 <= q0 < q1 <= nq and k < nc):
                raise ValueError(f"{fn}: damaged (a clip's rows are outside the arrays)")
    return LibraryFile(header.get("format"), header["files"], arrays)
