"""Per-thread work arrays reused by successive ``elastic_distance`` / ``elastic_align`` calls.

A 300 x 300-frame call needs about 3 MB of large temporaries (the SRVTs, the Gram matrix G and its inputs, the DP
values A). Allocated afresh, each comes from the allocator's heap or from new pages of the OS depending on its
state: in one state (reached, e.g., after a few ``elastic_align`` calls) every call paid ~430 page faults, about
0.8 ms of a 5 ms call on this machine's VM (docs/elastic.md, fourth pass). Reusing the same arrays makes the cost
independent of that state. ``memo`` keeps the small tables that depend only on the problem's shape. Only the single-call path uses them (the arrays never leave the call); the distance
matrix keeps its SRVTs and allocates as before. Arrays above ``MAX_BYTES`` are allocated per call and not kept, so
a thread retains at most a few times ``MAX_BYTES``; ``release()`` frees this thread's arrays.
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
