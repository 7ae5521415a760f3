"""Signature search: rank a library of clips by the normalized log-signature distance sim^n (eq. 9.1),
optionally re-rank the best by the elastic distance d_S*.

    rank_clips(query, library, metric="sim", level=None, rerank=0, top=None, cache=None) -> RankList
    RankResult(name, distance, elastic, frames, ...)
    SignatureCache(path)       # on-disk index keyed by a hash of the clip data

Index entry (one per clip, ``IndexEntry``): the clip's bones, its *moving* joints (still joints are
dropped: their letters have zero coefficients in every Lyndon word that contains them), the unit
log-signature direction a/|a| at ``level`` on the moving joints only (float32, Lyndon coordinates),
|a|, the per-frame increments log(R[k+1] R[k]^T) of the moving joints (float32; they rebuild the
curve up to a right translation, which none of the distances sees) and a count sketch of the
direction (``SKETCH_DIM`` float32 buckets).

Why that is exact. The log-signature of a path that never moves along some coordinates lies in the
free Lie algebra over the other letters, so in the Lyndon basis (words over an ordered alphabet)
every coordinate of a word containing a still letter is 0, and the coordinates of the other words
are those of the log-signature computed on the moving letters alone (a sub-alphabet keeps its order,
so its Lyndon words and their bracketings are the same words of the full alphabet). Two clips of one
skeleton (the same bone tuple) therefore compare exactly by matching their words by *global* code
(word over the skeleton's letters 3j, 3j+1, 3j+2): sim = |u - v| with both directions zero outside
their own words. This equals ``signatures.normalized_distance`` on the two curves (tested).

Clips of different skeletons are compared on the bones both have, in the query's bone order
(``metrics.clip_distance``'s convention): their log-signatures are recomputed from the stored
increments on that subset (slower; a warning is given when the subset covers less than
``FEW_SHARED`` of the query's moving bones; no shared bone -> skipped with a warning).

Speed. Ranking one query against many clips of one skeleton: the sketches (one matrix product)
select the best ``max(EXACT_POOL, 4 top, rerank)`` candidates, and only those are compared exactly;
without ``top``, or when the library is no larger than the pool, every clip is compared exactly.
A compact index (``SignatureCache(max_direction=N)``) does not store directions longer than N coordinates;
those clips are ranked by their sketches alone and their results are flagged ``approximate``.
See docs/search.md for the measurements (recall of the sketch against the exact ranking, memory).
"""

import dataclasses
import hashlib
import io
import json
import os
import tempfile
import threading
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import signatures, tensor
from .clip import Clip, still_joints
from .curves import exp_rotvec, relative_rotvecs
from .errors import ShapeSigError
from .sources import LibraryItem, as_items, clip_item, clip_key, file_key, library

__all__ = [
    "DEFAULT_LEVEL", "SKETCH_DIM", "COMPACT_MAX_DIRECTION", "CACHE_FORMAT", "CACHE_ENV", "FEW_SHARED", "EXACT_POOL",
    "RankResult", "RankList", "LibraryItem", "IndexEntry", "SignatureCache",
    "rank_clips", "build_index", "compute_entries", "clip_key", "file_key", "default_cache_dir",
    "folder_library", "clip_items", "entry_distance", "word_codes",
]

# The one level the index and the search use unless told otherwise (sim^3: see docs/search.md).
DEFAULT_LEVEL = 3
# Count-sketch buckets per clip (float32): recall@10 against the exact ranking in docs/search.md.
SKETCH_DIM = 4096
SKETCH_SEED = 0x9E3779B97F4A7C15
# Compact index: directions longer than this (coordinates; 256 KB as float32) are not stored.
COMPACT_MAX_DIRECTION = 65_536
# At least this many sketch candidates are compared exactly.
EXACT_POOL = 64
# Warn when the shared bones cover less than this fraction of the query's moving bones.
FEW_SHARED = 0.5
# Version of the on-disk entry format; an entry written by another version is discarded and rebuilt.
CACHE_FORMAT = 2  # 2: clips in armature space (Blender axes), see action_io.to_armature_space
CACHE_ENV = "SHAPESIG_CACHE_DIR"
_MASK64 = (1 << 64) - 1


# ----------------------------------------------------------------------------------------- results

@dataclass
class RankResult:
    """One ranked clip. ``distance``: sim^n (or the chosen metric); ``elastic``: d_S* when re-ranked,
    else None; ``frames``: the clip's frame count; ``shared``: bones compared; ``approximate``: True
    when ``distance`` is a sketch estimate (only with a compact index, see SignatureCache); ``partial``:
    the clip shares fewer than FEW_SHARED of the query's moving bones (ranked after the others)."""

    name: str
    distance: float
    elastic: Optional[float] = None
    frames: int = 0
    key: str = ""
    source: str = ""
    shared: int = 0
    approximate: bool = False
    partial: bool = False

    def as_dict(self):
        return {"clip": self.name, "distance": self.distance, "elastic": self.elastic, "frames": self.frames,
                "source": self.source}


class RankList(list):
    """``rank_clips``' result: a list of RankResult, best first, plus ``warnings`` (one-line strings),
    ``skipped`` (names of clips that share no bone with the query) and ``stats`` (cache hits and
    misses of this call, clips compared exactly, seconds)."""

    def __init__(self, items=(), warnings=(), skipped=(), stats=None):
        super().__init__(items)
        self.warnings = list(warnings)
        self.skipped = list(skipped)
        self.stats = dict(stats or {})


# ----------------------------------------------------------------------------------------- library
# Library members, keys and clip files are owned by core.sources.

def clip_items(clips: Sequence[Clip]) -> List[LibraryItem]:
    """Library items for clips already in memory, keyed by their data."""
    return [clip_item(c) for c in clips]


def folder_library(paths, load=None, asf=None, start=None, recursive=True, end=None) -> List[LibraryItem]:
    """Library items for clip files given directly or found in folders (``sources.library``); ``load(spec)``
    reads one ClipSpec (default: the reader registry)."""
    return library(paths, recursive, load=load, asf=asf, start=start, end=end)


# -------------------------------------------------------------------------------------- word codes

@lru_cache(maxsize=64)
def _local_letters(n_letters, level):
    """Letters (words, level) of the Lyndon words over n_letters letters, levels 1..level in the order of
    ``signatures.log_signature`` (level by level, lexicographic), padded with -1."""
    blocks = []
    for m in range(1, level + 1):
        codes = tensor.lyndon_words(n_letters, m)
        powers = n_letters ** np.arange(m - 1, -1, -1, dtype=np.int64)
        letters = (codes[:, None] // powers[None, :]) % n_letters
        pad = np.full((letters.shape[0], level - m), -1, dtype=np.int64)
        blocks.append(np.hstack([letters, pad]))
    out = np.vstack(blocks) if blocks else np.zeros((0, level), np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=256)
def _word_codes(n_bones, moving, level):
    letters_global = np.array([3 * j + a for j in moving for a in range(3)], dtype=np.int64)
    local = _local_letters(len(letters_global), level)
    base = 3 * n_bones + 1
    if base ** level >= 2 ** 62:
        raise ShapeSigError(f"too many bones ({n_bones}) for a level-{level} index")
    g = np.where(local >= 0, letters_global[np.maximum(local, 0)] + 1, 0)
    powers = base ** np.arange(level - 1, -1, -1, dtype=np.int64)
    codes = g @ powers
    codes.setflags(write=False)
    return codes


def word_codes(n_bones, moving, level):
    """Global integer codes of the Lyndon words over the letters of the ``moving`` joints (indices into a
    skeleton of ``n_bones``), in the order of the log-signature computed on those joints alone."""
    return _word_codes(int(n_bones), tuple(int(j) for j in moving), int(level))


def _splitmix64(x):
    x = (x + np.uint64(SKETCH_SEED)) & np.uint64(_MASK64)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@lru_cache(maxsize=256)
def _sketch_map(n_bones, moving, level, dim):
    codes = _word_codes(n_bones, moving, level).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = _splitmix64(codes)
    bucket = (h % np.uint64(dim)).astype(np.int64)
    sign = np.where((h >> np.uint64(40)) & np.uint64(1), 1.0, -1.0)
    return bucket, sign


def sketch(direction, n_bones, moving, level, dim=SKETCH_DIM):
    """Count sketch of a log-signature direction: word w adds sign(w) * u_w to bucket(w), both from a
    hash of the word's global code, so sketches of clips with different moving joints are comparable
    and |sketch(u) - sketch(v)| estimates |u - v| (unbiased in the square)."""
    bucket, sign = _sketch_map(int(n_bones), tuple(int(j) for j in moving), int(level), int(dim))
    return np.bincount(bucket, weights=sign * np.asarray(direction, np.float64), minlength=dim).astype(np.float32)


# ------------------------------------------------------------------------------------------ entries

@dataclass
class IndexEntry:
    """The index record of one clip (see the module docstring)."""

    name: str
    bones: Tuple[str, ...]
    moving: Tuple[int, ...]
    frames: int
    level: int
    norm: float
    direction: Optional[np.ndarray]   # float32 unit vector, or zeros when norm == 0
    increments: Optional[np.ndarray]  # float32 (frames-1, len(moving), 3)
    sketch: np.ndarray                # float32 (SKETCH_DIM,)
    fps: float = 0.0
    source: str = ""
    key: str = ""
    exact: bool = True                # False: the direction is not stored (compact index), sketch only

    @property
    def nbytes(self):
        return sum(a.nbytes for a in (self.direction, self.increments, self.sketch) if a is not None)


def make_entry(clip: Clip, level=DEFAULT_LEVEL, key="") -> IndexEntry:
    """Compute the index entry of a clip at ``level``."""
    level = int(level)
    R = clip.rotations
    if R.shape[0] < 2:
        raise ShapeSigError(f"clip {clip.name!r} has {R.shape[0]} frame(s); at least two are needed")
    moving = tuple(int(j) for j in np.flatnonzero(~still_joints(R)))
    inc = relative_rotvecs(R[:, list(moving)]) if moving else np.zeros((R.shape[0] - 1, 0, 3))
    if moving:
        dx = inc.reshape(inc.shape[0], -1)
        path = np.vstack([np.zeros((1, dx.shape[1])), np.cumsum(dx, axis=0)])
        a = signatures.path_log_signature(path, level)
        norm = float(np.linalg.norm(a))
    else:
        a, norm = np.zeros(0), 0.0
    direction = (a / norm if norm > signatures.ZERO_NORM else np.zeros_like(a)).astype(np.float32)
    if norm <= signatures.ZERO_NORM:
        norm = 0.0
    sk = sketch(direction, len(clip.bones), moving, level) if moving else np.zeros(SKETCH_DIM, np.float32)
    return IndexEntry(name=clip.name, bones=tuple(clip.bones), moving=moving, frames=int(R.shape[0]),
                      level=level, norm=norm, direction=direction, increments=inc.astype(np.float32),
                      sketch=sk, fps=float(clip.fps), source=clip.source, key=key)


def entry_distance(a: IndexEntry, b: IndexEntry) -> float:
    """Exact sim between two entries of the same skeleton (same bone tuple), from their directions."""
    if a.bones != b.bones:
        raise ShapeSigError(f"entries {a.name!r} and {b.name!r} have different skeletons")
    za, zb = a.norm == 0.0, b.norm == 0.0
    if za or zb:
        return 0.0 if (za and zb) else 1.0
    u, v = a.direction, b.direction
    if a.moving == b.moving:
        return float(np.linalg.norm(u - v))  # no cancellation for near-duplicates
    ca = word_codes(len(a.bones), a.moving, a.level)
    cb = word_codes(len(b.bones), b.moving, b.level)
    _, ia, ib = np.intersect1d(ca, cb, assume_unique=True, return_indices=True)
    u64, v64 = u.astype(np.float64), v.astype(np.float64)
    common = u64[ia] - v64[ib]
    only = (u64 @ u64 - u64[ia] @ u64[ia]) + (v64 @ v64 - v64[ib] @ v64[ib])
    return float(np.sqrt(max(common @ common + only, 0.0)))


def _curve_from_increments(inc):
    """A curve (frames, joints, 3, 3) starting at the identity with the given increments."""
    inc = np.asarray(inc, dtype=np.float64)
    n, j = inc.shape[:2]
    steps = exp_rotvec(inc)
    out = np.empty((n + 1, j, 3, 3))
    out[0] = np.eye(3)
    for k in range(n):
        out[k + 1] = steps[k] @ out[k]
    return out


def _increments_on(entry: IndexEntry, bones: Sequence[str]):
    """The entry's increments (frames-1, len(bones), 3) on the given bones (zero for still ones)."""
    pos = {entry.bones[j]: i for i, j in enumerate(entry.moving)}
    out = np.zeros((entry.frames - 1, len(bones), 3))
    for k, b in enumerate(bones):
        i = pos.get(b)
        if i is not None:
            out[:, k] = entry.increments[:, i]
    return out


def _pair_increments(q: IndexEntry, e: IndexEntry, bones):
    """Both entries' increments on ``bones``; bones still in both dropped (as clip_distance does)."""
    a, b = _increments_on(q, bones), _increments_on(e, bones)
    keep = (np.abs(a).max(axis=(0, 2), initial=0.0) > 0) | (np.abs(b).max(axis=(0, 2), initial=0.0) > 0)
    if keep.any():
        a, b = a[:, keep], b[:, keep]
    return a, b


def _sim_from_increments(a, b, level):
    def logsig(inc):
        dx = inc.reshape(inc.shape[0], -1)
        return signatures.path_log_signature(np.vstack([np.zeros((1, dx.shape[1])), np.cumsum(dx, 0)]), level)

    return signatures.normalized_difference(logsig(a), logsig(b))


# -------------------------------------------------------------------------------------------- cache

def default_cache_dir() -> str:
    """``$SHAPESIG_CACHE_DIR`` if set, else the user's cache folder (XDG_CACHE_HOME or ~/.cache, or the
    temporary folder) + ``blender_shapesig``. Blender passes the extension's user directory instead."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return env
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    if not os.path.isdir(os.path.dirname(base.rstrip(os.sep)) or base):
        base = tempfile.gettempdir()
    return os.path.join(base, "blender_shapesig", "signatures")


_ENTRY_FIELDS = ("name", "bones", "moving", "frames", "level", "norm", "fps", "source", "key", "exact")


class SignatureCache:
    """Index entries keyed by (content key, level), kept in memory and, with a ``path``, on disk.

    On disk: one ``<sha1>.npz`` per library item (all its clips) and a ``manifest.json`` with the format
    version. An entry file that cannot be read, belongs to another format version, key or level is
    deleted and counted in ``stats["invalid"]``; the item is then recomputed. ``path=None``: memory only.
    ``stats``: hits (memory or disk), disk_hits, misses (computed), invalid, writes.
    ``memory_limit``: bytes of directions/increments kept in memory beyond the sketches (least recently
    used are dropped and re-read from disk when needed; ignored without a path).
    ``max_direction``: compact index: directions longer than this many coordinates are not stored, and
    those clips are ranked by their sketch alone (``RankResult.approximate``; the elastic re-rank stays
    exact). None (default): every direction is stored and every returned distance is exact.
    """

    def __init__(self, path=None, memory_limit=512 * 2 ** 20, max_direction=None):
        self.path = None if path is None else os.fspath(path)
        self.memory_limit = int(memory_limit)
        self.max_direction = None if max_direction is None else int(max_direction)
        self._mem = {}      # (key, level) -> list[IndexEntry]
        self._heavy = {}    # id(entry) -> bytes, insertion = recency order
        self._lock = threading.RLock()
        self._sketch_memo = None
        self.stats = {"hits": 0, "disk_hits": 0, "misses": 0, "invalid": 0, "writes": 0}
        if self.path is not None:
            os.makedirs(self.path, exist_ok=True)
            self._check_manifest()

    # -- files
    def _check_manifest(self):
        manifest = os.path.join(self.path, "manifest.json")
        ok = False
        try:
            with open(manifest, encoding="utf-8") as f:
                ok = json.load(f).get("format") == CACHE_FORMAT
        except (OSError, ValueError, AttributeError):
            ok = False
        if not ok:
            if os.path.exists(manifest):
                self.stats["invalid"] += 1
            self._remove_entry_files()
            self._atomic_write(manifest, json.dumps({"format": CACHE_FORMAT, "program": "blender_shapesig",
                                                     "sketch_dim": SKETCH_DIM}).encode())

    def _remove_entry_files(self):
        for n in os.listdir(self.path):
            if n.endswith(".npz"):
                try:
                    os.remove(os.path.join(self.path, n))
                except OSError:
                    pass

    def _atomic_write(self, target, data: bytes):
        fd, tmp = tempfile.mkstemp(dir=self.path, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, target)
        except BaseException:
            try:
                os.remove(tmp)
            except OSError:
                pass
            raise

    def file_for(self, key, level):
        compact = "" if self.max_direction is None else f"|C{self.max_direction}"
        name = hashlib.sha1(f"{key}|L{level}|F{CACHE_FORMAT}|K{SKETCH_DIM}{compact}".encode()).hexdigest()
        return os.path.join(self.path, name + ".npz")

    def _read(self, key, level, light=False):
        """The entries of a file, or None (missing; unreadable or outdated files are deleted). ``light``:
        meta and sketches only (directions and increments are read by ``heavy`` when needed)."""
        fn = self.file_for(key, level)
        if not os.path.exists(fn):
            return None
        try:
            with np.load(fn, allow_pickle=False) as z:
                meta = json.loads(bytes(z["meta"]).decode("utf-8"))
                if meta.get("format") != CACHE_FORMAT or meta.get("key") != key or meta.get("level") != level:
                    raise ValueError("outdated")
                entries = []
                for i, m in enumerate(meta["clips"]):
                    e = IndexEntry(
                        name=m["name"], bones=tuple(m["bones"]), moving=tuple(m["moving"]), frames=int(m["frames"]),
                        level=int(m["level"]), norm=float(m["norm"]), fps=float(m["fps"]), source=m["source"],
                        key=key, direction=None, increments=None, sketch=np.asarray(z[f"s{i}"], np.float32),
                        exact=bool(m["exact"]))
                    if e.sketch.shape != (SKETCH_DIM,):
                        raise ValueError("bad sketch")
                    if light:
                        entries.append(e)
                        continue
                    e.increments = np.asarray(z[f"i{i}"], np.float32)
                    nm = len(e.moving)
                    if e.increments.shape != (e.frames - 1, nm, 3):
                        raise ValueError("bad shapes")
                    if e.exact:
                        e.direction = np.asarray(z[f"d{i}"], np.float32)
                        if e.direction.shape != (signatures.log_signature_dim(3 * nm, level) if nm else 0,):
                            raise ValueError("bad shapes")
                    entries.append(e)
                return entries
        except Exception:  # noqa: BLE001 - any unreadable file is discarded and rebuilt
            self.stats["invalid"] += 1
            try:
                os.remove(fn)
            except OSError:
                pass
            return None

    def _write(self, key, level, entries):
        meta = {"format": CACHE_FORMAT, "key": key, "level": level, "clips": [
            {f: (list(getattr(e, f)) if f in ("bones", "moving") else getattr(e, f)) for f in _ENTRY_FIELDS}
            for e in entries]}
        arrays = {"meta": np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)}
        for i, e in enumerate(entries):
            d = e.direction if e.exact else np.zeros(0, np.float32)
            arrays[f"s{i}"], arrays[f"d{i}"], arrays[f"i{i}"] = e.sketch, d, e.increments
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        self._atomic_write(self.file_for(key, level), buf.getvalue())
        self.stats["writes"] += 1

    # -- public
    def get(self, key, level):
        """The entries stored for (key, level), or None (a miss)."""
        with self._lock:
            got = self._mem.get((key, level))
            if got is not None:
                self.stats["hits"] += 1
                return got
            if self.path is not None:
                got = self._read(key, level, light=True)
                if got is not None:
                    self.stats["hits"] += 1
                    self.stats["disk_hits"] += 1
                    self._remember(key, level, got)
                    return got
            return None

    def put(self, key, level, entries):
        with self._lock:
            if self.path is not None:
                self._write(key, level, entries)
            self._remember(key, level, entries)

    def _remember(self, key, level, entries):
        self._mem[(key, level)] = entries
        if self.path is None:
            return
        for e in entries:
            self._heavy[(key, level, e.name)] = e.nbytes - e.sketch.nbytes
        self._evict(protect=len(entries))

    def _evict(self, protect=1):
        """Drop the least recently loaded directions/increments beyond ``memory_limit`` (never the last
        ``protect`` loaded); they are re-read from disk when needed."""
        total = sum(self._heavy.values())
        while total > self.memory_limit and len(self._heavy) > protect:
            (k, lv, name), nb = next(iter(self._heavy.items()))
            del self._heavy[(k, lv, name)]
            for e in self._mem.get((k, lv), ()):
                if e.name == name:
                    e.direction = e.increments = None
            total -= nb

    def contains(self, key, level):
        """True when (key, level) is cached (memory or disk), without reading or counting anything."""
        return (key, int(level)) in self._mem or (self.path is not None and os.path.exists(self.file_for(key, level)))

    def heavy(self, entry: IndexEntry, item: Optional[LibraryItem] = None):
        """Make sure the entry's direction and increments are loaded (read from disk when needed). If its
        file has become unreadable meanwhile, the entry is recomputed from ``item`` (else ShapeSigError)."""
        if (entry.direction is not None or not entry.exact) and entry.increments is not None:
            return entry
        fresh = self._read(entry.key, entry.level) if self.path is not None else None
        if fresh is None and item is not None:
            with self._lock:
                self._mem.pop((entry.key, entry.level), None)
            fresh = self.entries(item, entry.level)
        if fresh is None:
            raise ShapeSigError(f"the index entry of {entry.name!r} is gone; build the index again")
        for e in fresh:
            if e.name == entry.name and e.bones == entry.bones and e.moving == entry.moving:
                if e.increments is None or (e.exact and e.direction is None):
                    e = self.heavy(e)
                entry.direction, entry.increments, entry.exact = e.direction, e.increments, e.exact
                with self._lock:
                    self._heavy[(entry.key, entry.level, entry.name)] = entry.nbytes - entry.sketch.nbytes
                    self._evict(protect=1)
                return entry
        raise ShapeSigError(f"the index entry of {entry.name!r} changed; build the index again")

    def entries(self, item: LibraryItem, level=DEFAULT_LEVEL):
        """The item's entries: from the cache, or computed (its clips loaded) and stored."""
        level = int(level)
        got = self.get(item.key, level)
        if got is not None:
            return got
        with self._lock:
            self.stats["misses"] += 1
        clips = item.clips()
        out = []
        for c in clips:
            e = make_entry(c, level, key=item.key)
            if self.max_direction is not None and e.direction.size > self.max_direction:
                e.direction, e.exact = None, False
            if not e.source:
                e.source = item.source
            out.append(e)
        self.put(item.key, level, out)
        return out

    def sketch_matrix(self, entries):
        """(S, squared norms) of the entries' sketches stacked, memoized for the last list of entries (a
        repeated query over the same library does not restack them)."""
        key = tuple(id(e) for e in entries)
        memo = self._sketch_memo
        if memo is not None and memo[0] == key:
            return memo[2], memo[3]
        S = np.stack([e.sketch for e in entries]) if entries else np.zeros((0, SKETCH_DIM), np.float32)
        sq = np.einsum("ij,ij->i", S, S, dtype=np.float64)
        self._sketch_memo = (key, list(entries), S, sq)
        return S, sq

    def clear(self):
        """Forget every entry (and delete the entry files)."""
        with self._lock:
            self._mem.clear()
            self._heavy.clear()
            self._sketch_memo = None
            if self.path is not None:
                self._remove_entry_files()

    def disk_usage(self):
        """(files, bytes) of the entry files on disk."""
        if self.path is None:
            return 0, 0
        files = [os.path.join(self.path, n) for n in os.listdir(self.path) if n.endswith(".npz")]
        return len(files), sum(os.path.getsize(f) for f in files)


# -------------------------------------------------------------------------------------------- index

def compute_entries(items, level=DEFAULT_LEVEL, cache=None, progress=None, errors=None):
    """[(item, entry)] for every clip of every item, through the cache. ``progress(done, total, name)``
    may return False to stop early. A ShapeSigError while loading an item is recorded in ``errors`` (a
    list of one-line messages) when given, else raised."""
    cache = cache if cache is not None else SignatureCache()
    items = as_items(items)
    out = []
    for i, item in enumerate(items):
        if progress is not None and progress(i, len(items), item.name) is False:
            break
        try:
            for e in cache.entries(item, level):
                out.append((item, e))
        except ShapeSigError as exc:
            if errors is None:
                raise
            errors.append(f"{item.name}: {exc}")
    if progress is not None:
        progress(len(items), len(items), "")
    return out


def build_index(items, level=DEFAULT_LEVEL, cache=None, progress=None):
    """Fill the cache for every item; returns a dict with clips, errors, cache stats and seconds."""
    t0 = time.perf_counter()
    errors = []
    got = compute_entries(items, level, cache, progress, errors)
    return {"clips": len(got), "errors": errors, "seconds": time.perf_counter() - t0,
            "stats": dict(cache.stats) if cache is not None else {}}


# ------------------------------------------------------------------------------------------ ranking

def _query_entry(query, level, cache):
    """(item or None, entry) of the query."""
    if isinstance(query, IndexEntry):
        return None, query
    if isinstance(query, Clip):
        query = clip_items([query])[0]
    if isinstance(query, LibraryItem):
        entries = cache.entries(query, level)
        if len(entries) != 1:
            raise ShapeSigError(f"query {query.name!r} holds {len(entries)} clips; choose one")
        return query, entries[0]
    raise ShapeSigError(f"the query must be a Clip, got {type(query).__name__}")


def rank_clips(query, library, metric="sim", level=None, rerank=0, top=None, cache=None, *,
               depth=9, progress=None, exclude=(), pool=None) -> RankList:
    """Rank ``library`` (Clips or LibraryItems) by their distance to ``query`` (a Clip), best first.

    ``metric``: ``sim`` (sim^n, through the index) or any name of ``metrics.parse_metric`` (computed
    pairwise from the cached increments). ``level``: the signature level (default DEFAULT_LEVEL, or the
    digits of e.g. ``sim2``). ``rerank=K``: the first K results are re-ordered by the elastic distance
    d_S* (depth ``depth``), which fills their ``elastic``. ``top``: keep the first ``top``. ``cache``: a
    SignatureCache (default: a fresh in-memory one). ``exclude``: item keys or names to leave out (e.g.
    the query's own action). ``pool``: sketch candidates compared exactly (default max(EXACT_POOL,
    4 top, rerank)). Clips of other skeletons are compared on the shared bones; clips sharing fewer than
    FEW_SHARED of the query's moving bones are ``partial``: warned about and ranked after all others (their
    distances cover a different, smaller part of the body), and never re-ranked above them; clips sharing
    none are skipped with a warning in ``result.warnings``.
    """
    from .metrics import curve_distance, parse_metric

    t0 = time.perf_counter()
    base, lvl = parse_metric(metric, level)
    sig_level = lvl if base == "sim" else DEFAULT_LEVEL
    rerank = max(int(rerank or 0), 0)
    if top is not None:
        top = int(top)
        if top < 1:
            raise ShapeSigError(f"top must be at least 1, got {top}")
    cache = cache if cache is not None else SignatureCache()
    before = dict(cache.stats)
    # a private copy: the cache may drop the arrays of its own object to keep within memory_limit
    q_item, q_entry = _query_entry(query, sig_level, cache)
    q = dataclasses.replace(cache.heavy(q_entry, q_item))
    items = [it for it in as_items(library) if it.key not in exclude and it.name not in exclude]
    errors = []
    pairs = compute_entries(items, sig_level, cache, progress, errors)
    warnings = list(errors)
    skipped = []

    q_moving = {q.bones[j] for j in q.moving}
    same, other = [], []
    for item, e in pairs:
        (same if e.bones == q.bones else other).append((item, e))

    results = []

    def result(e, d, shared, approximate=False):
        return RankResult(name=e.name, distance=float(d), frames=e.frames, key=e.key, source=e.source,
                          shared=shared, approximate=approximate)

    exact_count = 0
    if base == "sim":
        candidates = same
        npool = pool if pool is not None else max(EXACT_POOL, 4 * (top or 0), rerank)
        if top is not None and len(same) > npool:
            S, sq = cache.sketch_matrix([e for _, e in same])
            qs = q.sketch.astype(np.float64)
            approx = sq + qs @ qs - 2.0 * (S @ q.sketch).astype(np.float64)
            best = np.argpartition(approx, npool - 1)[:npool]
            candidates = [same[i] for i in best]
        for item, e in candidates:
            cache.heavy(e, item)
            if q.exact and e.exact:
                results.append(result(e, entry_distance(q, e), len(q.bones)))
                exact_count += 1
            else:  # compact index: the sketch estimate
                d = 1.0 if (q.norm == 0.0) != (e.norm == 0.0) else float(np.linalg.norm(q.sketch - e.sketch))
                results.append(result(e, d, len(q.bones), approximate=True))
    else:
        other = same + other

    for item, e in other:
        shared = [b for b in q.bones if b in set(e.bones)]
        if not shared:
            skipped.append(e.name)
            warnings.append(f"{e.name}: shares no bones with the query {q.name!r}; skipped")
            continue
        moving_shared = q_moving & set(shared)
        partial = bool(q_moving) and len(moving_shared) < FEW_SHARED * len(q_moving)
        if partial:
            warnings.append(f"{e.name}: shares only {len(moving_shared)} of the query's {len(q_moving)} moving "
                            f"bones; ranked after the clips that share most of them")
        cache.heavy(e, item)
        a, b = _pair_increments(q, e, shared)
        if base == "sim":
            d = _sim_from_increments(a, b, sig_level)
        else:
            d = curve_distance(_curve_from_increments(a), _curve_from_increments(b), base, level=lvl, depth=depth)
        exact_count += 1
        results.append(result(e, d, len(shared)))
        results[-1].partial = partial

    # Distances over a small part of the body are not comparable with whole-body ones (a clip that shares
    # only the head can look close): clips sharing few of the query's moving bones form a second tier.
    results.sort(key=lambda r: (r.partial, r.distance, r.name))
    if rerank and results:
        full = sum(1 for r in results if not r.partial)
        head = results[:min(rerank, full)] if full else results[:rerank]
        by_key = {(e.key, e.name): (item, e) for item, e in pairs}
        for r in head:
            item, e = by_key[(r.key, r.name)]
            e = cache.heavy(e, item)
            shared = [b for b in q.bones if b in set(e.bones)]
            a, b = _pair_increments(q, e, shared)
            if base == "elastic":
                r.elastic = r.distance
            else:
                from .elastic import elastic_distance

                r.elastic = float(elastic_distance(_curve_from_increments(a), _curve_from_increments(b), depth=depth))
        head.sort(key=lambda r: (r.elastic, r.distance, r.name))
        results[:len(head)] = head
    if top is not None:
        results = results[:top]
    stats = {k: cache.stats[k] - before.get(k, 0) for k in cache.stats}
    stats.update(compared=exact_count, library=len(pairs), seconds=time.perf_counter() - t0)
    return RankList(results, warnings, skipped, stats)
