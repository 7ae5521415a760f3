"""Fill the cache for a library: ``index CLIP_OR_FOLDER... [--cache DIR] [--scheduler ADDRESS]``."""

import time

from . import common as c


def run(args):
    from ..core import search as index
    from ..dedupe import parallel
    from .rank import library_or_refuse

    sched = c.check_scheduler(args.scheduler)
    t0 = time.perf_counter()
    cache = c.open_cache(args, index)  # one open of the folder (its sweep lists every entry)
    with c.remembered_file_keys(cache):
        items, _skipped = library_or_refuse(args.paths, args, "index")
    with parallel.scheduler(sched) as s, c.progress_bar(args, "indexing") as bar:
        clips, computed, errors = parallel.index_items(items, cache, s, bar)
    warnings = ([cache.warning] if cache.warning else []) + errors
    for w in warnings:
        c.say("warning", w)
    out = {"clips": clips, "computed": computed, "seconds": time.perf_counter() - t0}
    return out, f"{clips} clips indexed ({computed} files computed) in {out['seconds']:.1f} s"


def add_parser(sub):
    p = sub.add_parser(
        "index",
        help="fill the cache for a library (the default search's entries), nothing else",
        description="Compute what the default search keeps per clip for every clip the cache lacks and store it "
        "(one library file opened without reading every entry), so that the first rank over the library is fast.",
    )
    p.add_argument("paths", metavar="CLIP_OR_FOLDER", nargs="+", help=c.CLIP_HELP + ", or a folder of them")
    p.add_argument("--scheduler", metavar="ADDRESS", help=c.SCHEDULER_HELP)
    p.add_argument("--cache", metavar="DIR",
                   help="signature cache folder (default $SHAPESIG_CACHE_DIR, else the per-user cache folder)")
    c.add_common(p, crop=False)
    p.set_defaults(func=run)

