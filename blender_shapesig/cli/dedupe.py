"""Near-duplicate clusters of a library: ``dedupe CLIP_OR_FOLDER... --out DIR [--threshold x] [--scheduler ADDRESS]``."""


from . import common as c


def run(args):
    from ..core import search as index
    from ..dedupe import dedupe_library

    if args.k < 1:
        raise c.CommandError("--k must be 1 or more")
    if args.threshold is not None and not args.threshold >= 0:
        raise c.CommandError("--threshold must be 0 or more")
    sched = c.check_scheduler(args.scheduler)
    import os

    c.check_outputs([os.path.join(args.out, n) for n in ("report.json", "report.html")], args)
    unreadable = []
    try:
        out = dedupe_library(args.paths, args.out, args.threshold, sched, k=args.k,
                             level=args.level or c.DEFAULT_LEVEL, depth=args.depth,
                             cache_dir=c.cache_dir(args, index), plots=not args.no_plots, unreadable=unreadable,
                             asf=args.asf or None, fps=args.fps, trim=args.trim, bone_map=args.bone_map)
    finally:
        c.report_skipped(unreadable)  # the report's "skipped" lists them with the other sources left out
    told = {str(e) for e in unreadable}
    for w in [s for s in out.get("skipped", ()) if s not in told] + list(out.get("warnings", ())):
        c.say("warning", w)
    lines = [f"{out['clips']} clips, {len(out['clusters'])} near-duplicate clusters; report: {c.shown(out['report'])}"]
    for n, members in enumerate(out["clusters"], 1):
        lines.append(f"{n:3d}. " + "  ".join(map(c.shown, members)))
    return out, "\n".join(lines)


def add_parser(sub):
    from ..core.measure_words import MEASURES

    p = sub.add_parser(
        "dedupe",
        help="near-duplicate clusters of a library (HTML + JSON report)",
        description="Find near-duplicate clips (renamed, other frame rate, trimmed or re-timed copies, the same "
        "take in another format): a signature k-NN graph, then the elastic distance of the candidate pairs. "
        "Writes DIR/report.html and DIR/report.json.",
    )
    p.add_argument("paths", metavar="CLIP_OR_FOLDER", nargs="+", help=c.CLIP_HELP + ", or a folder of them")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for report.html and report.json")
    c.add_overwrite(p)
    p.add_argument("--threshold", type=float, metavar="X",
                   help=f"the gate of the {MEASURES['relative'].status} ({MEASURES['relative'].description}) "
                   "(default: half its median over a sample of the k-NN pairs)")
    p.add_argument("--scheduler", metavar="ADDRESS", help=c.SCHEDULER_HELP)
    p.add_argument("--k", type=int, default=8, help="neighbours per clip in the signature graph (default 8)")
    p.add_argument("--level", type=int, help=f"signature level (default {c.DEFAULT_LEVEL})")
    p.add_argument("--depth", type=int, default=c.DEFAULT_DEPTH, help="elastic DP depth")
    p.add_argument("--no-plots", action="store_true", help="no PNG plots in the report")
    p.add_argument("--cache", metavar="DIR",
                   help="signature cache folder (default $SHAPESIG_CACHE_DIR, else the per-user cache folder)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write a signature cache")
    c.add_common(p, crop=False)
    p.set_defaults(func=run)
