"""The signature cache (``SignatureCache``): a pure store of index entries keyed by (content key, level), in memory
and on disk in a folder it owns (``<the folder named>/blender_shapesig-cache/``, marked by a ``CACHEDIR.TAG`` it
wrote: one ``<sha1>.npz`` per library item, a manifest, the light pack), deleting nothing it did not write and
going on in memory with one ``warning`` when the folder cannot be used (the folder's checks: ``cache_folder``). It
never loads clips nor computes entries (``indexing.iter_entries`` does). See docs/search.md, "The index and its cache".
"""

import io
import json
import os
import stat
import threading
from typing import Optional

import numpy as np

from ..signatures import signatures
from .cache_folder import (
    _ENTRY_FILE, _OWN_FILE, _PACK, _TAG, _TAG_TEXT, _TMP_PREFIX, _TMP_SUFFIX, CACHE_SUBDIR, PRIVATE_PREFIX,
    _check_own_folder, _check_private, _marked, _Refused, _sweep, private_cache_dir,
)
from .signature.entry import IndexEntry
from .local.store import LocalEntries, hashed_name
from .signature.words import SKETCH_DIM

__all__ = ["SignatureCache", "CACHE_FORMAT", "COMPACT_MAX_DIRECTION"]

# Version of the on-disk entry format; an entry written by another version is discarded and rebuilt.
# 2: clips in armature space (Blender axes), see action_spaces.to_armature_space; 3: entries signed on the comparison
# time base (entry.make_entry), as metrics.clip_distance prepares the curves; 4: entries record the clip's own frame
# count (clip_frames) beside the prepared curve's; 5: local-search entries (core.search.local.features) in files of their own
# beside the signature entries (the pose pictures of core.search.thumbnails, <sha1>.png, beside them too); 6: both
# kinds of entries record the canonical joints of the clip's rig (rig_joints; the local ones their joints and still
# joints too), what a row's coverage and "unmapped" are computed from
CACHE_FORMAT = 6
# Compact index: directions longer than this (coordinates; 256 KB as float32) are not stored.
COMPACT_MAX_DIRECTION = 65_536

_ENTRY_FIELDS = ("name", "bones", "moving", "frames", "level", "norm", "fps", "source", "key", "exact",
                 "trimmed", "clip_frames", "rig_joints")


def _entry_from_meta(m, key, sketch):
    return IndexEntry(name=m["name"], bones=tuple(m["bones"]), moving=tuple(m["moving"]), frames=int(m["frames"]),
                      level=int(m["level"]), norm=float(m["norm"]), fps=float(m["fps"]), source=m["source"],
                      key=key, direction=None, increments=None, sketch=sketch, exact=bool(m["exact"]),
                      trimmed=tuple(int(f) for f in m.get("trimmed", ())), clip_frames=int(m.get("clip_frames", 0)),
                      rig_joints=tuple(str(j) for j in m.get("rig_joints", ())))


def _load_heavy(e: IndexEntry, z, i):
    """Read clip ``i``'s increments (and direction when stored) from the open file ``z``; ValueError on bad shapes."""
    e.increments = np.asarray(z[f"i{i}"], np.float32)
    nm = len(e.moving)
    if e.increments.shape != (e.frames - 1, nm, 3):
        raise ValueError("bad shapes")
    if e.exact:
        e.direction = np.asarray(z[f"d{i}"], np.float32)
        if e.direction.shape != (signatures.log_signature_dim(3 * nm, e.level) if nm else 0,):
            raise ValueError("bad shapes")


class SignatureCache:
    """Index entries keyed by (content key, level), kept in memory and, with a ``path``, on disk.

    ``path``: the folder named by the user; the files live in its subfolder ``CACHE_SUBDIR`` (``self.path``
    after opening; ``self.root`` is the folder named). When that folder cannot be used, ``self.path`` is None
    (memory only) and ``warning`` says why in one line; a write that fails later (a full disk, a read-only
    folder) stops the writing the same way, once. An entry file that cannot be read, belongs to another format
    version, key or level is deleted and counted in ``stats["invalid"]`` (the caller then computes the item
    again). ``path=None``: memory only.
    ``stats``: hits (memory or disk), disk_hits, misses (lookups that found nothing), invalid, writes.
    ``memory_limit``: bytes of directions/increments kept in memory beyond the sketches (least recently
    used are dropped and re-read from disk when needed; ignored without a path).
    ``max_direction``: compact index: directions longer than this many coordinates are not stored (``put``
    drops them), and those clips are ranked by their sketch alone (``RankResult.approximate``; the elastic
    re-rank stays exact). None (default): every direction is stored and every returned distance is exact.
    """

    FORMAT = CACHE_FORMAT

    def __init__(self, path=None, memory_limit=512 * 2 ** 20, max_direction=None):
        self.root = None if path is None else os.fspath(path)
        self.path = None      # the cache's own folder, once opened
        self.warning = None   # one line: why the cache went on in memory only
        self._writable = True
        self.memory_limit = int(memory_limit)
        self.max_direction = None if max_direction is None else int(max_direction)
        self._mem = {}      # (key, level) -> list[IndexEntry]
        self._heavy = {}    # (key, level, name) -> bytes of loaded heavy arrays, insertion = recency order
        self._lock = threading.RLock()
        self._sketch_memo = None
        self.local = LocalEntries(self)  # the local search's entries, a namespace of their own
        self._pack = None   # entry file name -> (size, mtime_ns, meta, sketches): the light pack (see save_pack)
        self._pack_dirty = False
        self.stats = {"hits": 0, "disk_hits": 0, "misses": 0, "invalid": 0, "writes": 0}
        if self.root is not None:
            try:
                self._open(os.path.join(self.root, CACHE_SUBDIR))
            except (OSError, _Refused) as exc:
                self.path = None
                self._memory_only(exc)

    # -- files
    def _open(self, folder):
        """Make (or find) the cache's own folder, marked by ``_TAG``; a folder of that name holding files but
        no marker is not ours: refused, untouched."""
        root = os.path.abspath(self.root)
        if os.path.basename(root).startswith(PRIVATE_PREFIX) and root == os.path.abspath(private_cache_dir()):
            _check_private(self.root)
        os.makedirs(self.root, exist_ok=True)
        try:
            os.mkdir(folder, 0o755)
        except FileExistsError:
            pass
        _check_own_folder(folder)
        self.path = folder
        if not _marked(folder):
            if os.listdir(folder):
                raise _Refused(f"{folder} holds files the cache did not write (it has no {_TAG})")
            self._atomic_write(os.path.join(folder, _TAG), _TAG_TEXT.encode("utf-8"))
        _sweep(folder)
        self._check_manifest()

    def _memory_only(self, exc):
        """Stop using the disk (nothing more is written) and keep the first reason as the one warning."""
        self._writable = False
        if self.warning is None:
            where = getattr(exc, "filename", None) or self.path or self.root
            why = (exc.strerror or str(exc)) if isinstance(exc, OSError) else str(exc)
            self.warning = (f"signature cache off ({why}: {where}); signatures are kept in memory only"
                            if isinstance(exc, OSError) else
                            f"signature cache off ({why}); signatures are kept in memory only")

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

    def _discard(self, fn):
        """Count and delete an unreadable or outdated entry file of this cache (its item is computed again)."""
        self.stats["invalid"] += 1
        try:
            os.remove(fn)
        except OSError:
            pass

    def _remove_entry_files(self):
        """Delete what this cache writes in its own folder (entry files, the pack, its temporary files), and
        nothing else."""
        self._pack, self._pack_dirty = {}, False
        self.local = LocalEntries(self)
        for n in os.listdir(self.path):
            if _OWN_FILE.fullmatch(n):
                try:
                    os.remove(os.path.join(self.path, n))
                except OSError:
                    pass

    def _atomic_write(self, target, data):
        """Write ``data`` (bytes, or a callable writing to the open file) to a temporary file, then rename it."""
        import tempfile  # (only when writing: 9 ms of a warm query's start)

        fd, tmp = tempfile.mkstemp(dir=self.path, prefix=_TMP_PREFIX, suffix=_TMP_SUFFIX)
        try:
            with os.fdopen(fd, "wb") as f:
                data(f) if callable(data) else f.write(data)
            os.replace(tmp, target)
        except BaseException:
            try:
                os.remove(tmp)
            except OSError:
                pass
            raise

    def _fingerprints_file(self, source):
        return os.path.join(self.path, "fingerprints-" + hashed_name(source) + ".json")

    def read_fingerprints(self, source) -> Optional[dict]:
        """The fingerprint record stored for ``source`` (a .blend file's path: the Blender layer's
        ``action_changes`` writes and checks it), or None (none, unreadable, or no folder)."""
        if self.path is None:
            return None
        try:
            with open(self._fingerprints_file(source), encoding="utf-8") as f:
                record = json.load(f)
        except (OSError, ValueError):
            return None
        return record if isinstance(record, dict) and record.get("source") == source else None

    def write_fingerprints(self, source, record: dict) -> bool:
        """Store ``record`` (JSON-able) for ``source``, replacing the previous one (a temporary file, then a
        rename); False when the folder cannot be written (the cache goes on in memory, ``warning``)."""
        if self.path is None or not self._writable:
            return False
        try:
            self._atomic_write(self._fingerprints_file(source),
                               json.dumps(dict(record, source=source), separators=(",", ":")).encode())
            return True
        except OSError as exc:
            self._memory_only(exc)
            return False

    def file_for(self, key, level):
        """The entry file of (key, level) (its name also depends on the format, sketch size and compact mode)."""
        compact = "" if self.max_direction is None else f"|C{self.max_direction}"
        return os.path.join(self.path, hashed_name(f"{key}|L{level}|F{CACHE_FORMAT}|K{SKETCH_DIM}{compact}") + ".npz")

    def _read(self, key, level, light=False):
        """The entries of a file, or None (missing; unreadable or outdated files are deleted). ``light``:
        meta and sketches only (directions and increments are read by ``heavy`` when needed)."""
        fn = self.file_for(key, level)
        try:
            st = os.lstat(fn)
        except OSError:
            return None
        if not stat.S_ISREG(st.st_mode):  # put there since the folder was opened: never opened
            self._discard(fn)
            return None
        if light:
            packed = self._packed(fn, st, key, level)
            if packed is not None:
                return packed
        try:
            with np.load(fn, allow_pickle=False) as z:
                meta = json.loads(bytes(z["meta"]).decode("utf-8"))
                if meta.get("format") != CACHE_FORMAT or meta.get("key") != key or meta.get("level") != level:
                    raise ValueError("outdated")
                entries = []
                for i, m in enumerate(meta["clips"]):
                    e = _entry_from_meta(m, key, np.asarray(z[f"s{i}"], np.float32))
                    if e.sketch.shape != (SKETCH_DIM,):
                        raise ValueError("bad sketch")
                    if not light:
                        _load_heavy(e, z, i)
                    entries.append(e)
                self._add_to_pack(fn, st, meta, [e.sketch for e in entries])
                return entries
        except Exception:  # noqa: BLE001 - any unreadable file is discarded (its item is computed again)
            self._discard(fn)
            return None

    def _write(self, key, level, entries):
        meta = {"format": CACHE_FORMAT, "key": key, "level": level, "clips": [
            {f: (list(getattr(e, f)) if f in ("bones", "moving", "rig_joints") else getattr(e, f)) for f in _ENTRY_FIELDS}
            for e in entries]}
        arrays = {"meta": np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)}
        for i, e in enumerate(entries):
            d = e.direction if e.exact else np.zeros(0, np.float32)
            arrays[f"s{i}"], arrays[f"d{i}"], arrays[f"i{i}"] = e.sketch, d, e.increments
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        fn = self.file_for(key, level)
        self._atomic_write(fn, buf.getvalue())
        self.stats["writes"] += 1
        self._add_to_pack(fn, os.stat(fn), meta, [e.sketch for e in entries])

    # -- the light pack: every entry file's meta and sketches in one file, so that a new process (a command-line
    # query) looks 1,000 items up with one read instead of opening 1,000 zip files. A packed entry is used only
    # while its entry file has the same size and mtime; the pack is rewritten by ``save_pack`` when it changed.
    def _load_pack(self):
        self._pack = {}
        try:
            if not stat.S_ISREG(os.lstat(os.path.join(self.path, _PACK)).st_mode):
                return
            with np.load(os.path.join(self.path, _PACK), allow_pickle=False) as z:
                index = json.loads(bytes(z["index"]).decode("utf-8"))
                sketches = np.asarray(z["sketches"], np.float32)
            if index.get("format") != CACHE_FORMAT or sketches.shape[1:] != (SKETCH_DIM,):
                return
            for name, size, mtime, meta, first in index["files"]:
                n = len(meta["clips"])
                self._pack[name] = (size, mtime, meta, sketches[first:first + n])
        except Exception:  # noqa: BLE001 - no pack, or an unreadable one: entry files are read one by one
            self._pack = {}

    def _packed(self, fn, st, key, level):
        if self._pack is None:
            self._load_pack()
        got = self._pack.get(os.path.basename(fn))
        if got is None or got[0] != st.st_size or got[1] != st.st_mtime_ns:
            return None
        meta = got[2]
        if meta.get("key") != key or meta.get("level") != level:
            return None
        return [_entry_from_meta(m, key, got[3][i]) for i, m in enumerate(meta["clips"])]

    def _add_to_pack(self, fn, st, meta, sketches):
        if self._pack is None:
            self._load_pack()
        self._pack[os.path.basename(fn)] = (st.st_size, st.st_mtime_ns, meta, np.asarray(sketches, np.float32))
        self._pack_dirty = True

    def save_pack(self):
        """Write the light pack when entries were read or written since it was loaded (``rank_clips`` and
        ``build_index`` call it at the end), and the local entries' pack (``local.save_pack``). Entries whose
        files are gone are left out."""
        self.local.save_pack()
        if self.path is None or not self._pack_dirty:
            return
        if not self._writable:
            return
        with self._lock:
            files, blocks, first = [], [], 0
            for name, (size, mtime, meta, sk) in self._pack.items():
                if not os.path.exists(os.path.join(self.path, name)):
                    continue
                files.append([name, size, mtime, meta, first])
                blocks.append(sk.reshape(-1, SKETCH_DIM))
                first += len(meta["clips"])
            index = json.dumps({"format": CACHE_FORMAT, "files": files}).encode("utf-8")
            sketches = np.concatenate(blocks) if blocks else np.zeros((0, SKETCH_DIM), np.float32)
            buf = io.BytesIO()
            np.savez(buf, index=np.frombuffer(index, dtype=np.uint8), sketches=sketches)
            try:
                self._atomic_write(os.path.join(self.path, _PACK), buf.getvalue())
            except OSError as exc:
                self._memory_only(exc)  # a read-only folder, a full disk: entries are read one by one
                return
            self._pack_dirty = False

    # -- memory
    def _remember(self, key, level, entries, on_disk=True):
        """Keep the entries in memory; the heavy arrays of entries on disk count towards ``memory_limit``
        (entries that are not on disk are never dropped)."""
        self._mem[(key, level)] = entries
        if self.path is None or not on_disk:
            return
        for e in entries:
            self._heavy[(key, level, e.name)] = e.heavy_nbytes
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

    # -- public
    def get(self, key, level):
        """The entries stored for (key, level) (light: see ``heavy``), or None (a miss)."""
        level = int(level)
        with self._lock:
            got = self._mem.get((key, level))
            if got is None and self.path is not None:
                got = self._read(key, level, light=True)
                if got is not None:
                    self.stats["disk_hits"] += 1
                    self._remember(key, level, got)
            self.stats["hits" if got is not None else "misses"] += 1
            return got

    def put(self, key, level, entries):
        """Store the entries of (key, level). In compact mode, directions longer than ``max_direction`` are
        dropped first (those entries become sketch-only: ``exact`` False)."""
        level = int(level)
        if self.max_direction is not None:
            for e in entries:
                if e.direction is not None and e.direction.size > self.max_direction:
                    e.direction, e.exact = None, False
        with self._lock:
            on_disk = self.path is not None and self._writable
            if on_disk:
                try:
                    self._write(key, level, entries)
                except OSError as exc:
                    self._memory_only(exc)
                    on_disk = False
            self._remember(key, level, entries, on_disk)

    def contains(self, key, level):
        """True when (key, level) is cached (memory or disk), without reading or counting anything."""
        return (key, int(level)) in self._mem or (self.path is not None and os.path.exists(self.file_for(key, level)))

    def forget(self, key, level):
        """Drop (key, level) from the memory layer (its file, if any, stays)."""
        with self._lock:
            self._mem.pop((key, int(level)), None)

    def heavy(self, entry: IndexEntry) -> Optional[IndexEntry]:
        """The entry with its direction and increments loaded (read from its file when needed), or None when
        its file is gone or has become unreadable (the caller computes it again)."""
        if entry.loaded:
            return entry
        fresh = self._read(entry.key, entry.level) if self.path is not None else None
        for e in fresh or ():
            if e.name == entry.name and e.bones == entry.bones and e.moving == entry.moving:
                entry.direction, entry.increments, entry.exact = e.direction, e.increments, e.exact
                with self._lock:
                    self._heavy[(entry.key, entry.level, entry.name)] = entry.heavy_nbytes
                    self._evict(protect=1)
                return entry
        return None

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
        """Forget every entry (and delete the files this cache wrote in its own folder)."""
        with self._lock:
            self._mem.clear()
            self._heavy.clear()
            self._sketch_memo = None
            self.local = LocalEntries(self)
            if self.path is not None:
                self._remove_entry_files()

    def disk_usage(self):
        """(files, bytes) of the entry files on disk."""
        if self.path is None:
            return 0, 0
        files = [os.path.join(self.path, n) for n in os.listdir(self.path) if _ENTRY_FILE.fullmatch(n)]
        return len(files), sum(os.path.getsize(f) for f in files)
