"""The parallel parts of ``dedupe`` on Dask: signing the clips the cache lacks and the elastic checks.

The same code runs on a local Dask scheduler (``threads``, the default; ``processes``; ``sync``) and, with an
address (``tcp://host:8786``), on a ``dask.distributed`` cluster through a ``Client``: ``dask.compute`` takes
either as its ``scheduler``. Dask is imported here only, and only when a library is deduplicated (the Blender
extension never needs it). A cluster's workers read the clip files by the paths given, so they must see the
same file system (or run on this machine).

Why threads by default: the elastic DP (numba, ``nogil``) runs in parallel in threads, and a process pool
costs a start-up and the pickling of the increments. Signing (BVH parsing in Python) holds the GIL; with many
misses ``--scheduler processes`` signs in parallel (docs/search.md, "Library report", measures both).
"""

import contextlib

__all__ = ["LOCAL_SCHEDULERS", "scheduler", "dask_mapper", "sign_item"]

LOCAL_SCHEDULERS = ("threads", "processes", "sync")


@contextlib.contextmanager
def scheduler(name=None):
    """What ``dask.compute`` takes as ``scheduler``: a local scheduler's name (None: threads), or a
    ``distributed.Client`` connected to the address ``name`` (closed on exit)."""
    name = name or "threads"
    if name in LOCAL_SCHEDULERS:
        yield name
        return
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - a dev requirement
        from ..core.errors import ShapeSigError

        raise ShapeSigError(f"--scheduler {name} needs dask.distributed (pip install distributed): {exc}") from None
    client = Client(name, set_as_default=False)
    try:
        yield client
    finally:
        client.close()


def dask_mapper(sched):
    """``mapper(fn, tasks) -> [fn(t) for t in tasks]`` computed by Dask on ``sched`` (``scheduler()``)."""

    def mapper(fn, tasks):
        import dask

        tasks = list(tasks)
        if not tasks:
            return []
        jobs = [dask.delayed(fn, pure=False)(t) for t in tasks]
        return list(dask.compute(*jobs, scheduler=sched))

    return mapper


def sign_item(task):
    """One signing task: ``(item, level)`` -> ``(entries, None)`` or ``([], one-line error)``. The entries are
    computed by the index's own code (``index.item_entries`` on a memory-only store); the caller stores them."""
    from ..core.errors import ShapeSigError
    from ..core.index import SignatureCache, item_entries

    item, level = task
    try:
        return item_entries(item, level, SignatureCache()), None
    except (ShapeSigError, OSError) as exc:
        return [], f"{item.name}: {exc}"
