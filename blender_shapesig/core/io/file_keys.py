"""Content keys, the hashing part of the cache key recipe: ``file_key`` (a file's SHA-1 with its size and mtime,
remembered per process and taken from an earlier process's record while the file's stat is unchanged:
``load_file_keys``, ``file_keys_record``) and ``clip_key`` (a clip in memory, by its bones and rotations).
``sources.ClipSpec.key`` builds a source's key on them. Pure Python, never imports bpy.
"""

import hashlib
import os
import time
from typing import Optional

import numpy as np

from ..clip.clip import Clip
from . import files

__all__ = ["RACY_NS", "file_key", "load_file_keys", "file_keys_record", "clip_key"]


_FILE_KEYS = {}  # (path, size, mtime_ns) -> content hash: a file is re-hashed only when its stat changes
# path -> [size, mtime_ns, inode, ctime_ns, hash, hashed at (ns)]: hashes an earlier process recorded
# (``load_file_keys``), and those of this process (``file_keys_record``)
_RECORDED, _HASHED = {}, {}
RACY_NS = 2_000_000_000  # a file whose change time is this close to its hashing is hashed again (git's racy rule)


def file_key(path, extra="") -> str:
    """SHA-1 of a file's bytes, with its size and mtime and ``extra`` (the rest of a ClipSpec's key), so that any
    edit of the file gives a new key. The hash is remembered for the process until the file's stat changes, and
    taken from an earlier process's record (``load_file_keys``) while the file's size, mtime, inode and change
    time are the recorded ones. UnreadableFileError for a file the readers would not open
    (``core.io.files.check_file``)."""
    path = os.path.abspath(os.fspath(path))
    st = files.check_file(path)  # never hash a FIFO or a device (it would never end), nor a file over the cap
    memo = (path, st.st_size, st.st_mtime_ns)
    digest = _FILE_KEYS.get(memo)
    if digest is None:
        stamp = [st.st_size, st.st_mtime_ns, st.st_ino, st.st_ctime_ns]
        row = _RECORDED.get(path)
        if row is None or row[:4] != stamp or not row[3] < row[5] - RACY_NS:
            hashed_at = time.time_ns()
            h = hashlib.sha1()
            with files.open_regular(path) as f:
                for block in iter(lambda: f.read(1 << 20), b""):
                    h.update(block)
            row = stamp + [h.hexdigest(), hashed_at]
            _HASHED[path] = row
        digest = _FILE_KEYS[memo] = row[4]
    return f"file:{digest}:{st.st_size}:{st.st_mtime_ns}:{extra}"


def load_file_keys(record) -> int:
    """Take the file hashes of a record ``file_keys_record`` made in an earlier process (malformed rows are
    ignored); returns how many."""
    rows = record.get("files") if isinstance(record, dict) else None
    n = 0
    for path, row in (rows.items() if isinstance(rows, dict) else ()):
        if (isinstance(path, str) and isinstance(row, list) and len(row) == 6 and isinstance(row[4], str)
                and all(isinstance(x, int) and not isinstance(x, bool) for x in row[:4] + row[5:])):
            _RECORDED[path] = row
            n += 1
    return n


def file_keys_record(limit=200_000) -> Optional[dict]:
    """The file hashes to record for a later process (the earlier record's and this process's, at most ``limit``,
    this process's first), or None when this process hashed no file."""
    if not _HASHED:
        return None
    rows = dict(list(_HASHED.items())[-limit:])
    for path, row in _RECORDED.items():
        if len(rows) >= limit:
            break
        rows.setdefault(path, row)
    return {"files": rows}


def clip_key(clip: Clip) -> str:
    """SHA-1 of a clip's bones and rotations (what every distance depends on)."""
    h = hashlib.sha1()
    h.update("\x1f".join(clip.bones).encode("utf-8", "surrogateescape"))
    R = np.ascontiguousarray(clip.rotations, dtype=np.float64)
    h.update(str(R.shape).encode())
    h.update(R.tobytes())
    return "clip:" + h.hexdigest()
