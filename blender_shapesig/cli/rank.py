"""Rank a library by similarity to a query: ``rank QUERY CLIP... [--rerank K] [--cache DIR]``."""

import sys

from . import common as c


def library_items(specs, args):
    """Library items of the CLIP arguments, keyed by ``ClipSpec.key`` (file bytes, skeleton, action, crop): a
    cached file is not even read again. Missing files and unknown types fail here, at once."""
    from ..core.sources import spec_item

    return [spec_item(c.clip_spec(s, args.asf, c.crop_of(args), args.bone_map).check()) for s in specs]


def recording_trims(items, trims):
    """The items, each recording in ``trims[(key, clip name)]`` the trimmed range (``core.trim.trimmed_range``)
    of the clips it reads in this run (a clip whose signature is cached is not read: its range stays unknown)."""
    import dataclasses

    from ..core.trim import trimmed_range

    def wrap(item):
        def load():
            got = item.load()
            for clip in [got] if hasattr(got, "rotations") else list(got):
                trims[(item.key, clip.name)] = (trimmed_range(clip), clip)
            return got
        return dataclasses.replace(item, load=load)

    return [wrap(it) for it in items]


def run(args):
    from ..core import search
    from ..core.metrics import metric_label, parse_metric

    base, level = parse_metric(args.metric, args.level)
    if args.rerank is not None and args.rerank < 0:
        raise c.CommandError("--rerank must be 0 or more")
    if args.top is not None and args.top < 1:
        raise c.CommandError("--top must be 1 or more")
    from ..core.sources import read_one, spec_item

    spec = c.clip_spec(args.query, args.asf, c.crop_of(args), args.bone_map)
    query = read_one(spec)
    # the query is keyed like the library: its signature is a cache hit when it was indexed before
    query_item = spec_item(spec, load=lambda _spec: query)
    trims = {}
    items = recording_trims(library_items(args.clips, args), trims)
    if not items:
        raise c.CommandError("no clips to rank")
    cache = search.SignatureCache(c.cache_dir(args, search))
    bar = c.progress(args, len(items), "signatures")
    done = [0]

    def progress(i, total, name):
        if i > done[0]:
            bar.update(i - done[0])
            done[0] = i

    try:
        results = search.rank_clips(query_item, items, metric=base, level=level, rerank=args.rerank or 0,
                                    top=args.top, cache=cache, depth=args.depth, progress=progress,
                                    allow_partial=args.allow_partial)
    finally:
        bar.close()
    for w in getattr(results, "warnings", []):
        sys.stderr.write(f"{c.PROG}: warning: {w}\n")
    # each result maps back to the argument it came from: "path" as given, "action" for a .blend (a whole
    # .blend item holds several actions: the clip's name is the action's)
    by_key, seen = {}, {}
    for it in items:
        by_key.setdefault(it.key, []).append(it)  # byte-identical copies (same key) are told apart in order
    rows = []
    for r in results:
        group = by_key.get(r.key) or [None]
        item = group[min(seen.get(r.key, 0), len(group) - 1)]
        seen[r.key] = seen.get(r.key, 0) + (len(group) > 1)
        path = item.path if item is not None else None
        action = (item.action or r.name) if path and path.lower().endswith(".blend") else None
        got = trims.get((r.key, r.name), ({"frames": None, "cut": None}, None))[0]
        rows.append({"clip": r.name, "distance": c.finite(r.distance), "elastic": c.finite(r.elastic),
                     "path": path, "action": action, "coverage": r.coverage,
                     "trim": got["frames"], "trimmed": got["cut"]})
    label = metric_label(base, level)
    stats = dict(getattr(results, "stats", {}) or {})
    from ..core.trim import trim_note, trimmed_range

    out = {"query": query.name, "metric": label, "results": rows, "query_trim": trimmed_range(query)["frames"],
           "query_trimmed": trimmed_range(query)["cut"],
           "cache": {k: stats[k] for k in ("hits", "misses") if k in stats}}
    lines = [f"query: {query.name}  metric: {label}"]
    for i, r in enumerate(rows, 1):
        el = "" if r["elastic"] is None else f"  elastic {r['elastic']:.6g}"
        dist = "nan" if r["distance"] is None else f"{r['distance']:.6g}"
        lines.append(f"{i:3d}. {r['clip']}  {dist}{el}")
    shown = [trims[(r.key, r.name)][1] for r in results if (r.key, r.name) in trims]
    lines += [n for n in map(trim_note, [query] + shown) if n]
    return out, "\n".join(lines)


def add_parser(sub):
    p = sub.add_parser(
        "rank",
        help="rank clips by similarity to a query",
        description="Rank clips by their distance to QUERY, best first. Signatures are cached in --cache DIR, "
        "else $SHAPESIG_CACHE_DIR, else the per-user cache folder (~/.cache/blender_shapesig/signatures); "
        "--no-cache keeps them in memory only.",
    )
    p.add_argument("query", metavar="QUERY", help=c.CLIP_HELP)
    p.add_argument("clips", metavar="CLIP", nargs="+", help=c.CLIP_HELP)
    c.add_metric(p, depth_help=f"DP search depth D for the elastic re-rank (default {c.DEFAULT_DEPTH})")
    p.add_argument("--rerank", type=int, default=0, metavar="K", help="re-order the first K by elastic distance")
    p.add_argument("--top", type=int, metavar="K", help="keep the K best results")
    p.add_argument("--cache", metavar="DIR",
                   help="signature cache folder (default $SHAPESIG_CACHE_DIR, else the per-user cache folder)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write a signature cache")
    c.add_common(p)
    p.set_defaults(func=run)
