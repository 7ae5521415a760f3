"""Per-thread work arrays reused by successive single ``elastic_distance`` / ``elastic_align`` calls (the SRVTs, the
Gram matrix, the DP values), so a call's cost does not depend on the allocator's state; ``memo`` keeps the small
tables that depend only on the problem's shape, arrays above ``MAX_BYTES`` are not kept, ``release()`` frees this
thread's arrays. See docs/elastic.md, "Implementation notes".
"""

import threading

import numpy as np

__all__ = ["MAX_BYTES", "MEMO_KEYS", "array", "memo", "release"]

MAX_BYTES = 8 * 2**20
MEMO_KEYS = 1024

_LOCAL = threading.local()
_MEMO = {}


def array(name, shape, reuse=True):
    """An uninitialized float64 C-contiguous array of ``shape``: this thread's array ``name``, grown when needed
    (a caller must not hold two arrays of the same name at once); ``reuse`` False: a new array."""
    size = 1
    for n in shape:
        size *= int(n)
    if not reuse or size * 8 > MAX_BYTES:
        return np.empty(shape)
    pool = getattr(_LOCAL, "pool", None)
    if pool is None:
        pool = _LOCAL.pool = {}
    buf = pool.get(name)
    if buf is None or buf.size < size:
        buf = pool[name] = np.empty(size)
    return buf[:size].reshape(shape)


def memo(key, make):
    """A small read-only table that depends only on ``key`` (frame counts, depth, a step table: time steps,
    entry coefficients, band, thin-step index), made once by ``make()`` and shared by every thread (all are
    dropped beyond ``MEMO_KEYS`` keys). Callers must not modify it."""
    value = _MEMO.get(key)
    if value is None:
        if len(_MEMO) >= MEMO_KEYS:
            _MEMO.clear()
        value = _MEMO[key] = make()
    return value


def release():
    """Drop this thread's work arrays."""
    _LOCAL.pool = {}
