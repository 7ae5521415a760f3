"""Two threads for one DP of the numba kernel (``_dp_kernels.dp_numba`` with ``threads=2``): the column that splits
a band's nodes in two (``column_split``) and the rows in blocks, the left columns on a helper thread and the right
ones on the calling thread once the helper has finished them (``dp_two_threads``). Every node is computed by the
kernel's own code, so the values are those of one thread bit for bit (docs/elastic.md, "Implementation notes").
"""

import numpy as np

__all__ = ["PARALLEL_MIN_NODES", "ROW_BLOCK", "column_split", "dp_two_threads"]

# Two threads for one DP only above this many band nodes (below, starting the second thread costs more than
# it saves); ``ROW_BLOCK`` rows per hand-over between them.
PARALLEL_MIN_NODES = 20_000
ROW_BLOCK = 12
_POOL = []


def column_split(lo, hi, n1, share=0.5):
    """The column s with a ``share`` of the band's nodes before it (the columns j < s to the helper thread, the
    others to the calling one)."""
    count = np.zeros(n1 + 2, dtype=np.int64)
    np.add.at(count, lo[1:], 1)
    np.add.at(count, hi[1:] + 1, -1)
    per_column = np.cumsum(count)[:n1 + 1]
    total = np.cumsum(per_column)
    return int(np.searchsorted(total, total[-1] * share)) + 1


def dp_two_threads(rows, A, args, n0, n1, split):
    """Rows of the DP in blocks on two threads (``rows(A, *args, i0, i1, j0, j1)``: the kernel's rows i0 <= i < i1,
    columns j0 <= j <= j1, ``_dp_kernels._dp_rows``): the left columns (j < split) depend only on left columns of
    earlier rows, so a helper thread runs through them freely; this thread computes the right columns of a block of rows
    once the helper has finished the left columns of that block (a node reads rows before its own only). Every
    node is computed by the same code as in one thread: the values are bit-identical."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    if not _POOL:
        _POOL.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="shapesig-dp"))
    blocks = list(range(1, n0 + 1, ROW_BLOCK)) + [n0 + 1]
    done = [threading.Event() for _ in blocks[:-1]]

    def left():
        for b in range(len(done)):
            rows(A, *args, blocks[b], blocks[b + 1], 0, split - 1)
            done[b].set()

    fut = _POOL[0].submit(left)
    try:
        for b in range(len(done)):
            while not done[b].wait(0.05):
                if fut.done():  # the helper failed: re-raise its error
                    fut.result()
            rows(A, *args, blocks[b], blocks[b + 1], split, n1)
    finally:
        fut.result()
