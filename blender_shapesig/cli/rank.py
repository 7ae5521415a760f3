"""Rank a library by similarity to a query: ``rank QUERY CLIP... [--rerank K] [--cache DIR]``."""

import sys

from . import common as c


def library_items(specs, args, skipped):
    """Library items of the CLIP arguments (``core.io.sources.Library``), keyed by ``ClipSpec.key`` (file bytes,
    skeleton, action, crop): a cached file is not even read again. A folder stands for the clip files in it (an
    ``.amc`` finds its own ``.asf`` there). Missing files and unknown types fail here, at once; a file that is not
    a regular file or is over a cap (``core.io.files``), or a folder's file that cannot be keyed, is skipped into
    ``skipped``."""
    from ..core.io.sources import Library

    lib = Library(specs, lambda text: c.clip_spec(text, args.asf, c.crop_of(args), args.bone_map))
    items = lib.items()
    skipped += lib.skipped
    return items


def library_or_refuse(specs, args, verb):
    """(``library_items`` of ``specs``, the skipped files' lines, reported on stderr); CommandError "no clips to
    ``verb``" when none is left."""
    skipped = []
    items = library_items(specs, args, skipped)
    skipped = c.report_skipped(skipped)
    if not items:
        raise c.CommandError(f"no clips to {verb}" + (f" ({skipped[0]})" if skipped else ""))
    return items, skipped


def _rank_windows(query, items, args, progress):
    """``rank --windows``: moments of the clips (``core.search.moments``), the signature stage at level 2."""
    from ..core.search import rank_clips
    from ..core.search.engines import engine_for

    if args.metric not in (None, "sim", "sim2") or args.level not in (None, 2):
        raise c.CommandError("--windows ranks by sim2 (then elastic): leave --metric and --level out")
    return rank_clips(query, items, engine=engine_for(windows=True, explain=bool(args.explain)), rerank=args.rerank,
                      top=args.top, depth=args.depth, progress=progress, allow_partial=args.allow_partial)


def _fill_on(sched, items, cache, base, level, args):
    """``--scheduler``: the entries of the library files the cache lacks, computed on Dask by ``dedupe.parallel``'s
    mapper (as ``index --scheduler`` does) and stored once by this process; the ranking then only reads them.
    Returns the number of files computed. A file that cannot be read is left to the ranking (its warning)."""
    from ..core.metrics import DEFAULT_LEVEL, LOCAL
    from ..dedupe import parallel, sign_library

    with parallel.scheduler(sched) as s, c.progress_bar(args, "indexing") as bar:
        if base == LOCAL:
            return parallel.index_items(items, cache, s, bar)[1]
        lvl = level if base == "sim" and level else DEFAULT_LEVEL
        return sign_library(items, lvl, cache, parallel.mapper_for(s))[2]


def _known_query(spec, cache, base, args):
    """(the query's cached local entry, its item) when the default search ranks it (``cached_query_entry``), else
    (None, None): any other search, or a query not cached or that cannot be keyed, is read (and refused) as before."""
    from ..core.errors import ShapeSigError
    from ..core.io.sources import spec_item
    from ..core.metrics import LOCAL
    from ..core.search.local.rank import cached_query_entry

    if base != LOCAL or args.windows:
        return None, None
    try:
        item = spec_item(spec)
        return cached_query_entry(item, cache), item
    except (ShapeSigError, OSError):
        return None, None


def _explanation(query, item, result, args):
    """``--explain``: the result's per-joint shares and alignment cost (``core.elastic.explain``), from its DP path when
    the moment search made one, else from the elastic alignment of the two clips (or of the window)."""
    from ..core.elastic.explain import explain_clips

    if result.explain is not None:
        return result.explain
    if item is None:
        return None
    clip = next((x for x in item.clips() if x.name == result.name), None)
    window = None if result.start is None else (result.start, result.end)
    return None if clip is None else explain_clips(query, clip, window, depth=args.depth)


def _thumbnails(folder, query_item, results, rows, cache, args=None):
    """``--thumbnails DIR``: the query's and every row's picture of key poses (``core.search.thumbnails``, made once
    in the cache folder) written into DIR as ``query.png``, ``01_<clip>.png``, ...; each row's ``"thumbnail"`` is
    its file (null with a warning when the clip has no key points, e.g. no legs). Returns the query's file."""
    import os
    import re

    from ..core.errors import ShapeSigError
    from ..core.search.thumbnails import frame_window, picture_bytes

    pictures = {}  # path -> PNG bytes, every one made before any is written

    def picture(item, name, window, file_name):
        try:
            data = picture_bytes(item, cache, name, window)
        except ShapeSigError as exc:
            c.say("warning", str(exc))
            return None
        path = os.path.join(folder, re.sub(r"[^\w.+-]+", "_", file_name) + ".png")
        pictures[path] = data
        return path

    for i, (r, row) in enumerate(zip(results, rows), 1):
        item = r.item
        window = frame_window(r.start, r.end, r.frames, r.trimmed)
        row["thumbnail"] = None if item is None else picture(item, r.name, window, f"{i:02d}_{r.name}")
    query = picture(query_item, query_item.name, None, "query")
    c.check_outputs(list(pictures), args)  # an existing picture is replaced only with --overwrite
    os.makedirs(folder, exist_ok=True)
    for path, data in pictures.items():
        c.write_output(path, data)  # complete or absent (a full disk leaves no 0-byte PNG)
    return query


def run(args):
    from ..core import search as index
    from ..core.metrics import DEFAULT_METRIC, metric_label, parse_metric

    base, level = parse_metric(args.metric or ("sim" if args.windows else DEFAULT_METRIC), args.level)
    sched = c.check_scheduler(args.scheduler)
    if sched:
        if args.windows:
            raise c.CommandError("--scheduler computes the clips' entries of the whole-clip search: leave it out "
                                 "with --windows")
        from ..dedupe.parallel import require_dask

        require_dask(sched)  # before any clip is read
    if args.rerank is not None and args.rerank < 0:
        raise c.CommandError("--rerank must be 0 or more")
    if args.top is not None and args.top < 1:
        raise c.CommandError("--top must be 1 or more")
    if args.explain < 0:
        raise c.CommandError("--explain must be 0 or more")
    from ..core.io.sources import clip_address, read_one, spec_item
    from ..core.clip.trim import trim_note, trim_record, trimmed_range
    from ..core.measure_words import ENGINES, MEASURES, metric_phrase

    spec = c.clip_spec(args.query, args.asf, c.crop_of(args), args.bone_map)
    cache = c.open_cache(args, index)  # one open of the folder (its sweep lists every entry)
    with c.remembered_file_keys(cache):
        # the query is keyed like the library: its entry is a cache hit when it was indexed before, and then the
        # default search does not read it at all
        known, query_item = _known_query(spec, cache, base, args)
        query = None if known else read_one(spec)
        query_item = query_item if known else spec_item(spec, load=lambda _spec: query)
        items, skipped = library_or_refuse(args.clips, args, "rank")
    computed = _fill_on(sched, items, cache, base, level, args) if sched else None
    with c.progress_bar(args, "signatures") as bar:
        if args.windows:
            results = _rank_windows(query, items, args, bar)
        else:
            results = index.rank_clips(query_item, items, metric=base, level=level, rerank=args.rerank or 0,
                                        top=args.top, cache=cache, depth=args.depth, progress=bar,
                                        allow_partial=args.allow_partial)
    warnings = list(getattr(results, "warnings", []))
    if cache.warning and cache.warning not in warnings:  # --windows reads no signature cache, but says so
        warnings.insert(0, cache.warning)
    for w in warnings:
        c.say("warning", w)
    # each result names the argument it came from (``RankResult.item``): "path" as given, "action" for a clip of a
    # file that holds several (a .blend, a .glb: sources.clip_address)
    rows = []
    for r in results:
        item = r.item
        path = item.path if item is not None else None
        action = clip_address(item.source or path, r.name, r.source)[1] if path else None
        rows.append(r.as_dict(path=path, action=action))  # the one row serialiser (core.search.rows)
        if args.explain and len(rows) <= args.explain:
            rows[-1]["explain"] = _explanation(query or query_item.clips()[0], item, r, args)
    if args.thumbnails:
        out_thumbs = _thumbnails(args.thumbnails, query_item, results, rows, cache, args)
    stats = dict(getattr(results, "stats", {}) or {})
    label = stats.get("metric", "sim2 windows") if args.windows else metric_label(base, level)
    name, record, first, frames = (known.name, known.trimmed, known.first, known.frames) if known else \
        (query.name, trim_record(query), query.frame_start, query.frames)
    trim = trimmed_range(record, [first, first + frames - 1])
    notes = [trim_note(name, record)] + [trim_note(r.name, r.trimmed) for r in results]
    out = {"query": name, "metric": label, "results": rows, "query_trim": trim["frames"],
           "query_trimmed": trim["cut"],
           "cache": {k: stats[k] for k in ("hits", "misses") if k in stats}, "skipped": skipped}
    if args.thumbnails:
        out["query_thumbnail"] = out_thumbs
    if sched:
        out["computed"] = computed  # library files whose entries the scheduler computed
    search = ENGINES["moments"].label if args.windows else metric_phrase(label)
    lines = [f"query: {c.shown(name)}  metric: {label} ({search})"]
    elastic_word = MEASURES["elastic"].column.lower()
    for i, r in enumerate(rows, 1):
        el = "" if r["elastic"] is None else f"  {elastic_word} {r['elastic']:.6g}"
        if r.get("metric") and r["metric"] != label:
            el += f"  ({r['metric']})"
        dist = "nan" if r["distance"] is None else f"{r['distance']:.6g}"
        win = f"  frames {r['start']}-{r['end']}" if "start" in r else ""
        lines.append(f"{i:3d}. {c.shown(r['clip'])}{win}  {dist}{el}")
        if "explain" in r:
            from ..core.elastic.explain import top_joints

            lines.append("       " + ", ".join(f"{n} {v:.0%}" for n, v in top_joints(r["explain"], 4)))
    lines += [c.shown(n) for n in notes if n]
    return out, "\n".join(lines)


def description():
    """``rank --help``'s text: the engines in their words (``core.measure_words``)."""
    from ..core.measure_words import ENGINES, MEASURES, OPTIONS

    local, sim, moments = ENGINES["local"], ENGINES["sim"], ENGINES["moments"]
    return (
        f"Rank clips by their distance to QUERY, best first. The default search, --metric local, is "
        f"{local.short}: {local.description}. --metric sim3 is {sim.short}: {sim.description}; it finds the same "
        f"take in another file format as often as the default (docs/evaluation.md); with --rerank K the first K "
        f"are re-ordered by the {MEASURES['elastic'].status} (the panel's {OPTIONS['rerank'].label}). --windows "
        f"ranks {moments.label}: {moments.description}. Signatures are cached in --cache DIR, else "
        "$SHAPESIG_CACHE_DIR, else the per-user cache folder (~/.cache), in a subfolder blender_shapesig-cache that "
        "it alone writes; --no-cache keeps them in memory only."
    )


def add_parser(sub):
    from ..core.measure_words import ENGINES, MEASURES

    elastic, moments = MEASURES["elastic"], ENGINES["moments"]
    p = sub.add_parser("rank", help="rank clips by similarity to a query", description=description())
    p.add_argument("query", metavar="QUERY", help=c.CLIP_HELP)
    p.add_argument("clips", metavar="CLIP", nargs="+", help=c.CLIP_HELP + ", or a folder of clip files")
    c.add_metric(p, depth_help=f"DP search depth D of the {elastic.status} (default {c.DEFAULT_DEPTH})",
                 default=None)
    p.add_argument("--rerank", type=int, default=None, metavar="K",
                   help=f"re-order the first K by the {elastic.status}, {elastic.symbol} (local: the shortlist its "
                   "second stage re-scores, default 20; with --windows: refine the first K moments by the "
                   "free-window elastic DP, default 10)")
    p.add_argument("--windows", action="store_true",
                   help=f"{moments.label}: {moments.description} (JSON: start, end)")
    p.add_argument("--explain", type=int, nargs="?", const=5, default=0, metavar="K",
                   help=f"explain the first K results (default 5): per-joint shares of the {elastic.status} and "
                   "the alignment cost over time")
    p.add_argument("--top", type=int, metavar="K", help="keep the K best results")
    p.add_argument("--cache", metavar="DIR",
                   help="signature cache folder (default $SHAPESIG_CACHE_DIR, else the per-user cache folder)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write a signature cache")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="compute the entries the cache lacks on Dask (optional package) first, as the index "
                   "command does: a cluster's scheduler address (tcp://host:8786) or a local Dask scheduler: "
                   "threads, processes, sync (default: computed here, one clip after another)")
    c.add_overwrite(p)
    p.add_argument("--thumbnails", metavar="DIR",
                   help="write a picture of each result's key poses (and the query's) into DIR as PNG files; each "
                   "JSON row adds \"thumbnail\" (its file)")
    c.add_common(p)
    p.set_defaults(func=run)
