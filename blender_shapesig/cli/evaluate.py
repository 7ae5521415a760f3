"""Leave-one-out 1-NN evaluation of metrics on a labelled clip set: ``evaluate --index CSV ...``."""

import os

from . import common as c


def run(args):
    from .. import evaluation
    from ..core.metrics import metric_label

    if not os.path.isfile(args.index):
        raise c.CommandError(f"index file not found: {args.index}")
    if not os.path.isdir(args.data):
        raise c.CommandError(f"data folder not found: {args.data}")
    c.check_outputs([os.path.join(args.out, n) for n in ("summary.json", "report.md")], args)
    metrics = evaluation.DEFAULT_METRICS if not args.metrics else tuple(
        m.strip() for m in args.metrics.split(",") if m.strip()
    )
    for m in metrics:
        metric_label(m)
    entries, skipped = evaluation.readable_entries(evaluation.read_index(args.index), args.data)
    skipped = c.report_skipped(skipped)
    if not entries:
        raise c.CommandError(f"no readable clip listed in {args.index} ({skipped[0]})")
    groups = [e.column(args.group) for e in entries] if args.group else None
    read = dict(asf=args.asf, fps=args.fps, trim=args.trim, bone_map=args.bone_map)
    crops = ({side: evaluation.entry_loader(args.data, cut=(side, evaluation.CROP_FRACTION), **read)
              for side in ("start", "end")} if args.crops else None)
    stage = c.Staged(args.out, args)
    with stage:  # the outputs appear in --out when complete
        summary = evaluation.evaluate(
            entries,
            evaluation.entry_loader(args.data, **read),
            metrics,
            stage.path,
            depth=args.depth,
            workers=args.workers,
            figures=not args.no_figures,
            progress=None if args.no_progress else "tqdm",
            repeat=args.repeat,
            groups=groups,
            crops=crops,
        )
    summary = dict(stage.moved(summary), skipped=skipped, group=args.group)
    lines = [f"{summary['clips']} clips; wrote {os.path.join(args.out, 'summary.json')}"]
    for name, row in summary["metrics"].items():
        crop = f"  crops {row['crops']['start']}+{row['crops']['end']}/{row['crops']['of']}" if "crops" in row else ""
        lines.append(f"  {name:16s} accuracy {row['accuracy']:.3f}  mAP {row['map']:.3f}{crop}  {row['seconds']:.2f} s")
    return summary, "\n".join(lines)


def add_parser(sub):
    p = sub.add_parser(
        "evaluate",
        help="leave-one-out (or leave-one-group-out) 1-NN and mAP of several metrics on a labelled clip set",
        description="Read an index CSV (file,label[,skeleton][,start][,end]; paths relative to --data, start/end "
        "are inclusive frame numbers), compute the pairwise matrix of every metric, and write "
        "DIR/summary.json, confusion tables, matrices and figures.",
    )
    p.add_argument("--index", required=True, metavar="CSV", help="the index CSV")
    p.add_argument("--data", required=True, metavar="DIR", help="folder the CSV paths are relative to")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    c.add_overwrite(p)
    p.add_argument(
        "--metrics",
        help="comma-separated metric names (default: l2,elastic,group3,concat3,linear3,sim2,sim3); "
        "also local (the default search of rank), sim3_levelnorm, sim3_tensor, linear3_tensor, elastic_numpy, "
        "sim3+elastic5, ...",
    )
    p.add_argument("--group", metavar="COLUMN",
                   help="a column of the CSV (e.g. actor): each clip is ranked only against clips of other groups "
                   "(leave-one-group-out)")
    p.add_argument("--crops", action="store_true",
                   help="crop probes: every clip cut by 10%% at its start, then at its end, queries the full set; "
                   "summary.json counts, per metric, how many rank their source first")
    p.add_argument("--depth", type=int, default=c.DEFAULT_DEPTH, help=f"DP search depth D for elastic (default {c.DEFAULT_DEPTH})")
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    p.add_argument("--no-figures", action="store_true", help="write only the numbers")
    p.add_argument("--repeat", type=int, default=1, metavar="N",
                   help="time every matrix N times and report the shortest (default 1)")
    c.add_common(p, crop=False)
    p.set_defaults(func=run)
