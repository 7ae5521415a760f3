"""The signature cache's namespace for the local search (``LocalEntries``, a store's ``local``): every
item's local entries (``local.index_entry``, about 16 KB a clip, or a clip's one-line refusal) in a file of their own
beside its signature entries, named by the item's key and the settings' key; all of them also in one pack
(``LOCAL_PACK``), so that a new process (a command-line ``rank``) reads a library's entries in one read; and the
library's windows stacked once per library (``stack``). The safety rules are the cache's: atomic writes in
its own folder, an unreadable or outdated file deleted and computed again, a failed write turning the disk off.
"""

import functools
import hashlib
import io
import json
import os
import stat

import numpy as np

from . import description as local_description, features as local
from .entry import ARRAYS as _ARRAYS, JOINT_LISTS as _JOINT_LISTS, LocalEntry, Refusal, meta_fields
from .library import open_library, write_library

__all__ = ["LOCAL_PACK", "LocalEntries", "hashed_name"]

LOCAL_PACK = "local_pack.bin"
# Windows does not replace a file this process has memory-mapped: the library file is closed before it is written
# again (``LocalEntries.release``); elsewhere the old mapping stays valid and nothing is copied
MAPPED_FILES_LOCKED = os.name == "nt"


@functools.lru_cache(maxsize=1 << 18)
def hashed_name(text: str) -> str:
    """The cache's file name of an entry's description (its SHA-1), remembered: a click asks for every library
    item's file names (``contains``), and 1,000 hashes a click were a tenth of a warm click."""
    return hashlib.sha1(text.encode("utf-8", "surrogateescape")).hexdigest()


def _meta(e):
    if e.refused:
        return {"name": e.name, "refused": e.refused, "frames": 0, "bones": 0, "trimmed": [], "seconds": 0.0,
                **{k: [] for k in _JOINT_LISTS}}
    return {"name": e.name, "refused": "", "frames": int(e.frames), "first": e.first, "bones": int(e.bones),
            "trimmed": list(e.trimmed),
            "seconds": float(e.seconds), **{k: list(getattr(e, k)) for k in _JOINT_LISTS},
            "seq_dim": int(np.shape(e.sequence)[1])}


class _Rows(list):
    """A library file's rows of one cached file whose entries are not made yet (``LocalEntries._pack_entries``)."""


def _entry(m, arrays):
    if m.get("refused"):
        return Refusal(m["name"], str(m["refused"]))
    e = LocalEntry(**meta_fields(m), seconds=np.float32(m.get("seconds", 0.0)),
                   **{k: np.asarray(arrays[k], dt) for k, dt in _ARRAYS.items() if k in arrays})
    if (e.windows.ndim != 2 or e.sequence.ndim != 2 or len(e.windows) == 0
            or (e.take is not None and e.take.ndim != 1)):
        raise ValueError("bad shapes")
    return e


class LocalEntries:
    """Local-search entries keyed by (item key, settings key): the ``local`` namespace of a ``store.SignatureCache``
    (``cache``), whose folder, lock, stats and safe writes it uses."""

    def __init__(self, cache):
        self._cache = cache
        self._local = {}          # (key, settings key) -> [entry]
        self._local_memo = None   # the last library's stack
        self._lpack = None        # file name -> (size, mtime_ns, meta, entries): the pack, once loaded
        self._lpack_dirty = False
        self._lib = None          # the opened library file (local_library.LibraryFile)
        self.warning = None       # one line when the library file was damaged (it is rebuilt)

    @property
    def path(self):
        return self._cache.path

    @property
    def _lock(self):
        return self._cache._lock

    def _format(self):
        return self._cache.FORMAT  # the cache's one version of its files (store.CACHE_FORMAT)

    def file_for(self, key, settings_key):
        return os.path.join(self.path, hashed_name(f"{key}|LOCAL|{settings_key}|F{self._format()}") + ".npz")

    # -- the pack: every local file's entries in one memory-mapped file (``local_library``), used while the file
    # has the same size and mtime; a damaged pack is deleted (one line in ``warning``) and written again
    def _load_local_pack(self):
        self._lpack, self._lib = {}, None
        fn = os.path.join(self.path, LOCAL_PACK)
        try:
            if not stat.S_ISREG(os.lstat(fn).st_mode):
                raise ValueError("not a regular file")
            lib = open_library(fn)
        except FileNotFoundError:
            return
        except (OSError, ValueError, KeyError, TypeError) as exc:
            self.warning = f"the library file was damaged and is rebuilt ({exc})"
            self._cache._discard(fn)
            self._lpack_dirty = True
            return
        if lib.format != self._format():
            return
        self._lib = lib
        for name, size, mtime, meta, rows in lib.files:  # entries made when read (``_pack_entries``)
            self._lpack[name] = (size, mtime, meta, _Rows(rows))

    def _pack_entries(self, name):
        """The entries of the pack's file ``name``, made from the library file at their first read (a library
        file also holds the files of other settings, kept until their files go: nobody reads those)."""
        size, mtime, meta, got = self._lpack[name]
        if isinstance(got, _Rows):
            got = [self._lib.entry(m, r) for m, r in zip(meta["clips"], got)]
            self._lpack[name] = (size, mtime, meta, got)
        return got

    def _pack_local(self, fn, meta, entries):
        if self._lpack is None:
            self._load_local_pack()
        st = os.stat(fn)
        self._lpack[os.path.basename(fn)] = (st.st_size, st.st_mtime_ns, meta, entries)
        self._lpack_dirty = True

    def release(self):
        """Close the memory-mapped library file: every entry read from it gets its arrays copied into memory (in
        place, so lists holding the entries follow) and the store forgets the map, so that the file can be
        replaced; the next process maps the new one."""
        with self._lock:
            if self._lib is None:
                return
            lists = [self._pack_entries(name) for name in (self._lpack or {})] + list(self._local.values())
            for entries in lists:
                for e in entries:
                    if not e.refused and e.rows is not None:
                        e.rows = None
                        for k, v in e.arrays().items():  # (an older recipe's entry has no take)
                            setattr(e, k, np.array(v))
            self._local_memo = None
            self._lib = None

    def save_pack(self):
        """Write the pack when local entries were read or written since it was loaded (files gone: left out)."""
        if self.path is None or not self._lpack_dirty or not self._cache._writable:
            return
        if MAPPED_FILES_LOCKED:
            self.release()
        with self._lock:
            files = [(name, size, mtime, meta, self._pack_entries(name))
                     for name, (size, mtime, meta, _) in list(self._lpack.items())
                     if os.path.exists(os.path.join(self.path, name))]
            try:
                self._cache._atomic_write(os.path.join(self.path, LOCAL_PACK),
                                   lambda f: write_library(f, files, self._format()))
            except OSError as exc:
                self._cache._memory_only(exc)
                return
            self._lpack_dirty = False

    # -- files
    def _read_local(self, key, settings_key):
        fn = self.file_for(key, settings_key)
        try:
            st = os.lstat(fn)
        except OSError:
            return None
        if not stat.S_ISREG(st.st_mode):  # a FIFO would hang np.load: never opened
            self._cache._discard(fn)
            return None
        if self._lpack is None:
            self._load_local_pack()
        got = self._lpack.get(os.path.basename(fn))
        if got is not None and (got[0], got[1]) == (st.st_size, st.st_mtime_ns) and got[2].get("key") == key \
                and got[2].get("settings") == settings_key:
            return self._pack_entries(os.path.basename(fn))
        try:
            with np.load(fn, allow_pickle=False) as z:
                meta = json.loads(bytes(z["meta"]).decode("utf-8"))
                if (meta.get("format") != self._format() or meta.get("key") != key
                        or meta.get("settings") != settings_key):
                    raise ValueError("outdated")
                out = [_entry(m, {} if m.get("refused") else
                              {k: z[f"{k}{i}"] for k in _ARRAYS if f"{k}{i}" in z.files})
                       for i, m in enumerate(meta["clips"])]
            self._pack_local(fn, meta, out)
            return out
        except Exception:  # noqa: BLE001 - any unreadable file is discarded (its item is computed again)
            self._cache._discard(fn)
            return None

    def _write_local(self, key, settings_key, entries):
        meta = {"format": self._format(), "key": key, "settings": settings_key, "clips": [_meta(e) for e in entries]}
        arrays = {"meta": np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)}
        for i, e in enumerate(entries):
            if not e.refused:
                arrays.update({f"{k}{i}": np.asarray(v, _ARRAYS[k]) for k, v in e.arrays().items()})
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        fn = self.file_for(key, settings_key)
        self._cache._atomic_write(fn, buf.getvalue())
        self._cache.stats["writes"] += 1
        self._pack_local(fn, meta, list(entries))

    # -- public
    def get(self, key, settings_key):
        """The local-search entries stored for (key, settings key), or None (a miss)."""
        with self._lock:
            got = self._local.get((key, settings_key))
            if got is None and self.path is not None:
                got = self._read_local(key, settings_key)
                if got is not None:
                    self._cache.stats["disk_hits"] += 1
                    self._local[(key, settings_key)] = got
            self._cache.stats["hits" if got is not None else "misses"] += 1
            return got

    def put(self, key, settings_key, entries):
        """Store the local-search entries of (key, settings key) (memory, and disk when the cache has a folder)."""
        with self._lock:
            if self.path is not None and self._cache._writable:
                try:
                    self._write_local(key, settings_key, entries)
                except OSError as exc:
                    self._cache._memory_only(exc)
            self._local[(key, settings_key)] = list(entries)

    def contains(self, key, settings_key=None):
        """True when the local-search entries of (key, settings key; default ``local.DEFAULT``'s) are cached
        (memory or disk), reading nothing."""
        settings_key = settings_key or local.settings_key()
        return (key, settings_key) in self._local or (
            self.path is not None and os.path.exists(self.file_for(key, settings_key)))

    def stack(self, entries):
        """``local.stack`` of the entries (the library's windows in one block), memoized for the last list of
        entries: a repeated query over the same library does not restack them. Entries read from the library file
        are not copied: the block is the file's memory map, with their rows and the prefilter's coarse windows."""
        key = tuple(id(e) for e in entries)
        memo = self._local_memo
        if memo is not None and memo[0] == key:
            return memo[2]
        lib = self._lib
        rows = [e.rows for e in entries]
        if entries and lib is not None and all(r is not None and r[0] == id(lib) for r in rows):
            R = np.asarray([r[1:] for r in rows], np.int64)
            k = R[:, 2]
            whole = len(k) == len(lib.arrays["coarse"]) and np.array_equal(k, np.arange(len(k)))
            block = {"windows": lib.arrays["windows"], "norms": lib.arrays["norms"], "starts": R[:, 0],
                     "ends": R[:, 1], "coarse": lib.arrays["coarse"] if whole else np.asarray(lib.arrays["coarse"][k])}
            D = lib.descriptions()
            block["descriptions"] = None if D is None else (D if whole else np.asarray(D[k]))
        else:
            block = dict(local.stack(entries), descriptions=local_description.described_rows(entries))
        self._local_memo = (key, list(entries), block)
        return block
