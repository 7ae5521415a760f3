"""Pairwise distance matrix with MDS and dendrogram: ``matrix CLIP... --out DIR``."""

import os

from . import common as c

_OUTPUTS = ("matrix.csv", "matrix.npy", "mds.png", "dendrogram.png")


def run(args):
    from .. import evaluation
    from ..core.metrics import metric_label
    from ..core.pairwise import clip_distance_matrix

    label = metric_label(args.metric, args.level)
    c.check_outputs([os.path.join(args.out, n) for n in _OUTPUTS], args)  # before the work
    skipped = []
    clips = c.load_many(args.clips, args.asf, args, skipped)
    skipped = c.report_skipped(skipped)
    if len(clips) < 2:
        raise c.CommandError("matrix needs at least two clips" + (f" ({skipped[0]})" if skipped else ""))
    names = evaluation.unique_names([c.name for c in clips])
    labels = None
    if args.labels:
        labels = evaluation.labels_from_csv(args.labels, names)
    with c.progress_bar(args, f"{label} matrix") as bar:
        D, seconds = clip_distance_matrix(clips, label, depth=args.depth, workers=args.workers, progress=bar)
    # the output folder is made only once there is something to write into it; the files appear when complete
    with c.Staged(args.out, args) as stage:
        paths = evaluation.write_matrix(D, [c.shown(n) for n in names], stage.path)  # names as data
        figures = []
        if not args.no_figures and len(clips) >= 3:
            shown = [c.plot_text(n) for n in names]  # names are data: no mathtext, no control characters
            plain = None if labels is None else [c.plot_text(x) for x in labels]
            figures.append(evaluation.plot_mds(D, shown, plain, os.path.join(stage.path, "mds.png"),
                                               title=f"MDS, {label}"))
            figures.append(evaluation.plot_dendrogram(D, shown, plain, os.path.join(stage.path, "dendrogram.png"),
                                                      title=f"Dendrogram, {label}"))
    paths, figures = stage.moved(paths), stage.moved(figures)
    out = {
        "matrix": paths["csv"],
        "npy": paths["npy"],
        "figures": figures,
        "metric": label,
        "clips": names,
        "seconds": seconds,
        "skipped": skipped,
    }
    text = f"wrote {paths['csv']} ({len(clips)} clips, {label}, {seconds:.2f} s)"
    if figures:
        text += "\n" + "\n".join(f"wrote {f}" for f in figures)
    return out, text


def add_parser(sub):
    p = sub.add_parser(
        "matrix",
        help="pairwise distance matrix, MDS and dendrogram",
        description="Pairwise distances between clips (in parallel), written as DIR/matrix.csv and "
        "DIR/matrix.npy with an MDS plot and a dendrogram.",
    )
    p.add_argument("clips", metavar="CLIP", nargs="+", help=c.CLIP_HELP)
    c.add_metric(p, local=False)
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    p.add_argument("--labels", metavar="CSV", help="colour the figures by the 'label' column of an index CSV")
    p.add_argument("--no-figures", action="store_true", help="write only the matrix")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    c.add_overwrite(p)
    c.add_common(p)
    p.set_defaults(func=run)
