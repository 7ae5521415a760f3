"""Library reports: near-duplicate clusters of a clip library (``dedupe``), outside core.

``dedupe_library(paths, out_dir, ...)`` discovers the clips (``core.io.sources``), signs what the signature cache
lacks (in parallel on Dask, ``parallel``), runs the two-stage search of ``core.search.dedupe`` (the elastic checks on
Dask too) and writes ``report.html`` and ``report.json`` (``report``).
"""

import os
import time

from ..core.search import dedupe as core_dedupe
from ..core.errors import ShapeSigError, UnreadableFileError
from ..core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL
from . import parallel

__all__ = ["dedupe_library", "library_items", "sign_library"]


def library_items(paths, unreadable=None, **options):
    """``(items, skipped)``: a LibraryItem per clip source found in ``paths`` (``core.io.sources.Library``, not
    strict: a ``ClipSpec`` in ``paths`` is taken as it is, e.g. an .amc with its own skeleton), and a one-line reason
    for each source whose key cannot be made (an .amc without a unique .asf). Files the readers do not open (not
    regular files, over a cap: ``core.io.files``) are never opened; their UnreadableFileErrors also go to
    ``unreadable`` when given. A path that does not exist is refused."""
    from ..core.io.sources import ClipSpec, Library

    lib = Library(paths, lambda text: ClipSpec.parse(text, **options), strict=False, unique=True)
    items = lib.items()
    if unreadable is not None:
        unreadable += [e for e in lib.skipped if isinstance(e, UnreadableFileError)]
    return items, lib.skipped_lines()


def sign_library(items, level, store, mapper, chunk=8):
    """``(pairs, errors)``: ``[(item, entry)]`` for every clip, the store's entries where it has them, the
    others signed by ``mapper`` (``parallel.sign_item`` per item) and put in the store."""
    have, missing = {}, []
    for n, it in enumerate(items):
        got = store.get(it.key, level)
        if got is None:
            missing.append(n)
        else:
            have[n] = got
    errors = []
    for n, (entries, error) in zip(missing, mapper(parallel.sign_item, [(items[n], level) for n in missing])):
        if error:
            errors.append(error)
            continue
        store.put(items[n].key, level, entries)
        have[n] = entries
    store.save_pack()
    pairs = [(items[n], e) for n in sorted(have) for e in have[n]]
    return pairs, errors, len(missing)


def dedupe_library(paths, out_dir, threshold=None, scheduler=None, *, k=core_dedupe.DEFAULT_K,
                   level=DEFAULT_LEVEL, depth=DEFAULT_DEPTH, cache_dir=None, plots=True, unreadable=None, **options):
    """Deduplicate the clips in ``paths`` (files, folders, ``FILE.blend#ACTION``, ClipSpecs) and write the report into
    ``out_dir``. ``threshold``: the relative-d_S* gate (default: relative to the library, ``core.search.dedupe``);
    ``scheduler``: None (a thread pool, no Dask), a local Dask scheduler name or a cluster address;
    ``cache_dir``: the signature cache folder (None: memory only); ``unreadable``: a list that receives the
    files skipped unopened (``library_items``). ``options``: ClipSpec fields (asf, fps, trim, bone_map). Returns
    the report dict."""
    from ..core.search import SignatureCache
    from .report import write_report

    t0 = time.perf_counter()
    if scheduler:
        parallel.require_dask(scheduler)  # before any clip is read
    items, skipped = library_items(paths, unreadable, **options)
    if not items:
        raise ShapeSigError("no readable clip found in " + ", ".join(map(str, paths)))
    store = SignatureCache(cache_dir, memory_limit=1 << 40)  # every entry stays loaded for the graph
    timings = {}
    with parallel.scheduler(scheduler) as sched:
        mapper = parallel.mapper_for(sched)
        t = time.perf_counter()
        pairs, errors, signed = sign_library(items, level, store, mapper)
        timings["signing"] = time.perf_counter() - t
        entries = [store.heavy(e) or e for _, e in pairs]
        t = time.perf_counter()
        result = core_dedupe.find_duplicates(entries, k, threshold, depth=depth, mapper=mapper, timings=timings)
        timings["search"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    os.makedirs(out_dir, exist_ok=True)
    info = {"scheduler": str(scheduler or parallel.DEFAULT_SCHEDULER), "dask": bool(scheduler), "level": level,
            "k": k, "signed": signed, "skipped": skipped + errors, "seconds": timings}
    if store.warning:  # the signature cache went on in memory only
        info["warnings"] = [store.warning]
    return write_report(out_dir, pairs, entries, result, info, plots=plots, store=store)
