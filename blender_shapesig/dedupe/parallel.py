"""The parallel parts of ``dedupe``: signing the clips the cache lacks and the elastic checks, in a thread pool of
this process by default, or through ``dask.compute`` with ``--scheduler`` (a local Dask scheduler or a
``dask.distributed`` cluster). Dask is imported only here and only when asked (``require_dask``).
See docs/search.md, "Library report (dedupe)".
"""

import contextlib
import os

__all__ = ["LOCAL_SCHEDULERS", "DEFAULT_SCHEDULER", "require_dask", "scheduler", "dask_mapper", "thread_mapper",
           "mapper_for", "batches", "sign_item", "local_item", "index_items"]

LOCAL_SCHEDULERS = ("threads", "processes", "sync")
DEFAULT_SCHEDULER = "threads"  # the label of the run without --scheduler (a thread pool, no Dask)


def require_dask(name):
    """Import what scheduler ``name`` needs (``dask``; ``distributed`` for an address) or raise a one-line
    ShapeSigError naming the missing package. Called before any clip is read."""
    from ..core.errors import ShapeSigError

    package = "dask" if name in LOCAL_SCHEDULERS else "distributed"
    try:
        import dask  # noqa: F401

        if package == "distributed":
            import distributed  # noqa: F401
    except ImportError as exc:
        raise ShapeSigError(f"--scheduler {name} needs the optional package {package!r} "
                            f"(pip install 'dask[distributed]'): {exc}") from None


@contextlib.contextmanager
def scheduler(name=None):
    """What ``mapper_for`` takes: None without a scheduler (threads, no Dask), a local Dask scheduler's
    name, or a ``distributed.Client`` connected to the address ``name`` (closed on exit)."""
    if not name:
        yield None
        return
    require_dask(name)
    if name in LOCAL_SCHEDULERS:
        yield name
        return
    from distributed import Client

    client = Client(name, set_as_default=False, timeout="10s")
    try:
        yield client
    finally:
        client.close()


def thread_mapper(workers=None):
    """``mapper(fn, tasks) -> [fn(t) for t in tasks]`` on a pool of ``workers`` threads (default: one per
    core), results in task order."""
    from concurrent.futures import ThreadPoolExecutor

    workers = int(workers or os.cpu_count() or 1)

    def mapper(fn, tasks):
        tasks = list(tasks)
        if workers == 1 or len(tasks) < 2:
            return [fn(t) for t in tasks]
        pool = ThreadPoolExecutor(max_workers=workers)
        try:
            return list(pool.map(fn, tasks))
        finally:  # interrupted (a signal): the tasks not started are dropped, not run to the end
            pool.shutdown(wait=True, cancel_futures=True)

    return mapper


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


def mapper_for(sched):
    """The mapper of a ``scheduler()`` value: threads without Dask for None, else Dask."""
    return thread_mapper() if sched is None else dask_mapper(sched)


def sign_item(task):
    """One signing task: ``(item, level)`` -> ``(entries, None)`` or ``([], one-line error)``. The entries are
    computed by the index's own code (``index.item_entries`` on a memory-only store); the caller stores them."""
    from ..core.errors import ShapeSigError
    from ..core.search import SignatureCache, item_entries

    item, level = task
    try:
        return item_entries(item, level, SignatureCache()), None
    except (ShapeSigError, OSError) as exc:
        return [], f"{item.name}: {exc}"


def local_item(item):
    """One indexing task of the local search: ``item`` -> ``(entries, None)`` or ``([], one-line error)``,
    computed by ``local_rank.item_local_entries`` on a memory-only store; the caller stores them (once)."""
    from ..core.errors import ShapeSigError
    from ..core.search import SignatureCache
    from ..core.search.local.rank import item_local_entries

    try:
        return item_local_entries(item, SignatureCache()), None
    except (ShapeSigError, OSError) as exc:
        return [], f"{item.name}: {exc}"


def batches(fn, tasks, sched=None, batch=64, ahead=2):
    """Yield ``(chunk, [fn(t) for t in chunk])`` for the ``tasks`` in chunks of ``batch``, in order. On a
    ``distributed.Client`` the next ``ahead`` chunks are already on the cluster while the caller handles one, so
    the workers never wait for the client (nor for the slowest task of a chunk); elsewhere each chunk is one
    ``mapper_for(sched)`` call. A cluster that fails a task (e.g. its worker died more often than Dask retries)
    stops the run with a one-line ShapeSigError; the chunks yielded before stay the caller's."""
    tasks = list(tasks)
    chunks = [tasks[b0:b0 + batch] for b0 in range(0, len(tasks), batch)]
    if not _is_client(sched):
        mapper = mapper_for(sched)
        for chunk in chunks:
            yield chunk, mapper(fn, chunk)
        return
    from collections import deque

    pending, todo = deque(), iter(chunks)

    def submit():
        chunk = next(todo, None)
        if chunk is not None:
            pending.append((chunk, sched.map(fn, chunk, pure=False)))

    for _ in range(1 + ahead):
        submit()
    try:
        while pending:
            chunk, futures = pending.popleft()
            try:
                results = sched.gather(futures)
            except Exception as exc:  # noqa: BLE001 - a lost worker, a closed scheduler: one line
                raise _cluster_error(exc) from None
            submit()
            yield chunk, results
    finally:
        for _, futures in pending:  # stopped early (an error, a closed generator): free the cluster
            sched.cancel(futures)


def _is_client(sched):
    return sched is not None and not isinstance(sched, str) and hasattr(sched, "gather")


def _cluster_error(exc):
    from ..core.errors import ShapeSigError

    if type(exc).__name__ == "KilledWorker":  # Dask's retries of a clip ran out: its workers died running it
        why = "a worker died while computing a clip, more often than Dask retries"
    else:
        why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    return ShapeSigError(f"the Dask cluster stopped the run ({why}); what was finished is kept: run again to "
                         f"compute the rest")


def index_items(items, store, sched=None, progress=None, batch=64):
    """Fill ``store`` with the local entries of the ``items`` it lacks, computed by ``batches`` (threads, or Dask on
    ``sched``) in batches of ``batch`` items, each batch stored (by this process: once per clip, however many
    workers run) as soon as it is done, so a run stopped midway keeps what it finished. ``progress(done, total)``
    after each batch. Returns (clips, computed items, [one-line errors])."""
    from ..core.search.local import features as local

    skey = local.settings_key()
    todo = [it for it in items if not store.local.contains(it.key, skey)]
    errors, computed = [], 0
    done = len(items) - len(todo)
    if progress:
        progress(done, len(items))
    try:
        for chunk, results in batches(local_item, todo, sched, batch):
            for it, (entries, err) in zip(chunk, results):
                if err:
                    errors.append(err)
                    continue
                store.local.put(it.key, skey, entries)
                computed += 1
            done += len(chunk)
            if progress:
                progress(done, len(items))
    finally:
        store.save_pack()  # what was stored is in the library file even when the cluster failed
    clips = 0
    for it in items:
        got = store.local.get(it.key, skey)
        clips += sum(1 for e in got or () if not e.refused)
    return clips, computed, errors
