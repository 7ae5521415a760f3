"""Command line: ``python -m blender_shapesig COMMAND ...`` (issue 8).

Commands (see ``docs/cli.md`` and ``interfaces.md``): ``distance``, ``rank``, ``blend``, ``matrix``,
``evaluate``. Every command takes ``--json`` (one JSON object on stdout, nothing else there) and
``--debug`` (full traceback on errors). Errors exit with code 2 and one line on stderr.

bpy is imported lazily: only when a .blend file is read or written (.bvh and .amc are read without it). Blender's
C code writes to file descriptor 1, so all work runs with fd 1 pointed at stderr; stdout only receives
the final report.
"""

import argparse
import contextlib
import json
import math
import os
import sys
import traceback

from .core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL

PROG = "blender_shapesig"
EXIT_ERROR = 2


class CommandError(Exception):
    """Bad command-line usage or input: reported as one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors become a CommandError (one line) instead of usage + exit."""

    def error(self, message):
        where = self.prog[len(PROG):].strip()
        raise CommandError(f"{PROG}: error: {where + ': ' if where else ''}{message}")


# ---------------------------------------------------------------------------------------------
# Output plumbing


@contextlib.contextmanager
def _stdout_to_stderr():
    """Send everything written to stdout (Python and C level) to stderr until the block ends."""
    try:
        sys.stdout.flush()
    except Exception:
        pass
    saved_fd = None
    try:
        saved_fd = os.dup(1)
        os.dup2(2, 1)
    except OSError:
        saved_fd = None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        try:
            sys.stderr.flush()
        except Exception:
            pass
        if saved_fd is not None:
            try:
                # C-level buffers (Blender's printf) must be flushed before fd 1 is restored.
                import ctypes

                ctypes.CDLL(None).fflush(None)
            except Exception:
                pass
            os.dup2(saved_fd, 1)
            os.close(saved_fd)


def _finite(x):
    """A float for JSON: NaN / inf become None (JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _progress(args, total, desc):
    """A tqdm progress bar on stderr (a no-op object when tqdm is missing or --no-progress)."""
    if getattr(args, "no_progress", False) or total is None or total < 2:
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dev requirement
        return _NoBar()
    return tqdm(total=total, desc=desc, file=sys.stderr, leave=False, dynamic_ncols=True)


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


# ---------------------------------------------------------------------------------------------
# Reading clips


# core.sources is the one front door: the command line only turns a CLIP argument and its options into a
# ClipSpec, so the signature-cache keys of its libraries are ClipSpec.key, those of the panel's folder libraries.


def _crop_of(args):
    """``(start, end, fps, trim)`` of the command line (what ClipSpec takes besides the path and skeleton)."""
    if args is None:
        return None
    return (getattr(args, "start", None), getattr(args, "end", None), getattr(args, "fps", None),
            getattr(args, "trim", None) or "auto")


def _spec(text, asf=None, crop=None, bone_map="auto"):
    """The ClipSpec of one CLIP argument with ``--asf``, ``(start, end[, fps, trim])`` and ``--bone-map``."""
    from .core.sources import ClipSpec

    start, end, *rest = crop or (None, None)
    fps, trim = rest if rest else (None, "auto")
    return ClipSpec.parse(text, asf=asf or None, start=start, end=end, fps=fps, trim=trim, bone_map=bone_map)


def _bone_map_of(args):
    return getattr(args, "bone_map", "auto") if args is not None else "auto"


def load_one(spec, asf=None, crop=None, bone_map="auto"):
    """The one clip a CLIP argument names, cropped, through ``--bone-map``."""
    from .core.sources import read_one

    return read_one(_spec(spec, asf, crop, bone_map))


def load_many(specs, asf=None, args=None):
    """Every clip the CLIP arguments name (a .blend may hold several), cropped by ``args``."""
    from .core.sources import read

    out = []
    bar = _progress(args, len(specs), "loading") if args is not None else _NoBar()
    try:
        for spec in specs:
            out.extend(read(_spec(spec, asf, _crop_of(args), _bone_map_of(args))))
            bar.update()
    finally:
        bar.close()
    return out


def _display_name(clip):
    return clip.name


# ---------------------------------------------------------------------------------------------
# Commands


def cmd_distance(args):
    from .core.metrics import compare_clips, metric_label, parse_metric

    base, level = parse_metric(args.metric, args.level)
    a = load_one(args.a, args.asf, _crop_of(args), args.bone_map)
    b = load_one(args.b, args.asf, _crop_of(args), args.bone_map)
    got = compare_clips(a, b, base, level=level, depth=args.depth, allow_partial=args.allow_partial)
    d = got["distance"]
    label = metric_label(base, level)
    out = {"distance": _finite(d), "metric": label, "a": _display_name(a), "b": _display_name(b),
           "bones": got["bones"], "coverage": got["coverage"]}
    if base == "elastic":
        out["depth"] = args.depth
    text = f"{label}({a.name}, {b.name}) = {d:.6g}"
    return out, text


def _library_items(specs, args):
    """Library items of the CLIP arguments, keyed by ``ClipSpec.key`` (file bytes, skeleton, action, crop): a
    cached file is not even read again. Missing files and unknown types fail here, at once."""
    from .core.sources import spec_item

    return [spec_item(_spec(s, args.asf, _crop_of(args), args.bone_map).check()) for s in specs]


def _cache_dir(args, search):
    """The signature cache folder of ``rank``: --cache DIR, else $SHAPESIG_CACHE_DIR, else the per-user cache
    (``core.index.default_cache_dir``); None (memory only) with --no-cache or when the folder cannot be made."""
    if args.no_cache:
        if args.cache:
            raise CommandError("--cache and --no-cache contradict each other")
        return None
    cache_dir = args.cache or search.default_cache_dir()
    try:
        os.makedirs(cache_dir, exist_ok=True)
    except OSError as exc:
        if args.cache:
            raise CommandError(f"cannot make the cache folder {cache_dir!r}: {exc.strerror or exc}") from None
        sys.stderr.write(f"{PROG}: warning: no signature cache ({cache_dir}: {exc.strerror or exc})\n")
        return None
    return cache_dir


def cmd_rank(args):
    from .core import search
    from .core.metrics import metric_label, parse_metric

    base, level = parse_metric(args.metric, args.level)
    if args.rerank is not None and args.rerank < 0:
        raise CommandError("--rerank must be 0 or more")
    if args.top is not None and args.top < 1:
        raise CommandError("--top must be 1 or more")
    from .core.sources import read_one, spec_item

    spec = _spec(args.query, args.asf, _crop_of(args), args.bone_map)
    query = read_one(spec)
    # the query is keyed like the library: its signature is a cache hit when it was indexed before
    query_item = spec_item(spec, load=lambda _spec: query)
    items = _library_items(args.clips, args)
    if not items:
        raise CommandError("no clips to rank")
    cache = search.SignatureCache(_cache_dir(args, search))
    bar = _progress(args, len(items), "signatures")
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
        sys.stderr.write(f"{PROG}: warning: {w}\n")
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
        rows.append({"clip": r.name, "distance": _finite(r.distance), "elastic": _finite(r.elastic),
                     "path": path, "action": action, "coverage": r.coverage})
    label = metric_label(base, level)
    stats = dict(getattr(results, "stats", {}) or {})
    out = {"query": query.name, "metric": label, "results": rows,
           "cache": {k: stats[k] for k in ("hits", "misses") if k in stats}}
    lines = [f"query: {query.name}  metric: {label}"]
    for i, r in enumerate(rows, 1):
        el = "" if r["elastic"] is None else f"  elastic {r['elastic']:.6g}"
        dist = "nan" if r["distance"] is None else f"{r['distance']:.6g}"
        lines.append(f"{i:3d}. {r['clip']}  {dist}{el}")
    return out, "\n".join(lines)


def _parse_weights(args):
    from .core.errors import check_inbetweens, check_weight

    if args.inbetweens is not None:
        k = check_inbetweens(args.inbetweens, "--inbetweens")  # 1..MAX_INBETWEENS, as the operator
        return [i / (k + 1) for i in range(1, k + 1)]
    if args.weight is None:
        raise CommandError("blend: give --weight s (0..1) or --inbetweens K")
    return [check_weight(args.weight, "--weight")]  # a finite number in [0, 1], as the operator


def cmd_blend(args):
    weights = _parse_weights(args)
    out_path = os.path.abspath(args.out)
    if not out_path.lower().endswith(".blend"):
        raise CommandError(f"--out must be a .blend file, got {args.out}")
    if not os.path.isdir(os.path.dirname(out_path)):
        raise CommandError(f"folder of --out does not exist: {os.path.dirname(out_path)}")
    if args.frames is not None and args.frames < 2:
        raise CommandError("--frames must be 2 or more")
    from .core.blend import blend_clip_series, blend_name
    from .core.metrics import check_coverage
    from .core.rigs import apply_bone_map, onto_rig

    # one rig: its own bones, as before; two rigs: through the bone map, written back onto A's rig
    a = a_rig = load_one(args.a, args.asf, _crop_of(args), "none")
    b = load_one(args.b, args.asf, _crop_of(args), "none")
    if args.bone_map != "none" and a.bones != b.bones:
        a, b = apply_bone_map(a, args.bone_map), apply_bone_map(b, args.bone_map)
    check_coverage(a, b, args.allow_partial)

    bar = _progress(args, len(weights), "blending")
    try:
        blended = blend_clip_series(
            a, b, weights, align=args.align, depth=args.depth, frames=args.frames,
            progress=lambda i, n: bar.update(),
        )
    finally:
        bar.close()
    if a.meta.get("rotation_space") == "comparison":  # across rigs: back onto A's rig through its bone map
        blended = [onto_rig(c, a_rig, a) for c in blended]
        kept = blended[0].meta.get("kept_bones", ())
        if kept:
            sys.stderr.write(f"{PROG}: note: bones without a counterpart keep A's motion: {', '.join(kept)}\n")
    for clip, w in zip(blended, weights):
        # The blend lives in A's rotation space (pose or armature axes); write_action converts by it.
        if "rotation_space" in a.meta:
            clip.meta.setdefault("rotation_space", a.meta["rotation_space"])
        if args.name:
            clip.name = args.name if len(weights) == 1 else f"{args.name}_{w:.2f}"
        else:
            clip.name = blend_name(a.name, b.name, w)
    from .write_blend import write_blend

    names = write_blend(_spec(args.a, args.asf), blended, out_path)
    out = {
        "out": out_path,
        "actions": list(names),
        "frames": [int(c.frames) for c in blended],
        "seconds": [(c.frames - 1) / float(c.fps) for c in blended],
        "fps": [float(c.fps) for c in blended],
        "weights": weights,
        "align": bool(args.align),
    }
    if a.meta.get("rotation_space") == "comparison":
        out["kept_bones"] = list(blended[0].meta.get("kept_bones", ()))
    text = "\n".join(
        [f"wrote {out_path}"] + [f"  {n}: {c.frames} frames, {(c.frames - 1) / c.fps:.3f} s at {c.fps:g} fps "
                                 f"(weight {w:g})" for n, c, w in zip(names, blended, weights)]
    )
    return out, text


def cmd_matrix(args):
    from . import evaluation
    from .core.metrics import check_metric
    from .core.pairwise import clip_distance_matrix

    label = check_metric(args.metric, args.level)
    clips = load_many(args.clips, args.asf, args)
    if len(clips) < 2:
        raise CommandError("matrix needs at least two clips")
    names = evaluation.unique_names([c.name for c in clips])
    labels = None
    if args.labels:
        labels = evaluation.labels_from_csv(args.labels, names)
    bar = _progress(args, len(clips) * (len(clips) - 1) // 2, f"{label} matrix")
    try:
        D, seconds = clip_distance_matrix(clips, label, depth=args.depth, workers=args.workers, progress=bar.update)
    finally:
        bar.close()
    # the output folder is made only once there is something to write into it
    os.makedirs(args.out, exist_ok=True)
    paths = evaluation.write_matrix(D, names, args.out)
    figures = []
    if not args.no_figures and len(clips) >= 3:
        figures.append(
            evaluation.plot_mds(D, names, labels, os.path.join(args.out, "mds.png"), title=f"MDS, {label}")
        )
        figures.append(
            evaluation.plot_dendrogram(
                D, names, labels, os.path.join(args.out, "dendrogram.png"), title=f"Dendrogram, {label}"
            )
        )
    out = {
        "matrix": paths["csv"],
        "npy": paths["npy"],
        "figures": figures,
        "metric": label,
        "clips": names,
        "seconds": seconds,
    }
    text = f"wrote {paths['csv']} ({len(clips)} clips, {label}, {seconds:.2f} s)"
    if figures:
        text += "\n" + "\n".join(f"wrote {f}" for f in figures)
    return out, text


def cmd_evaluate(args):
    from . import evaluation
    from .core.metrics import check_metric

    if not os.path.isfile(args.index):
        raise CommandError(f"index file not found: {args.index}")
    if not os.path.isdir(args.data):
        raise CommandError(f"data folder not found: {args.data}")
    metrics = evaluation.DEFAULT_METRICS if not args.metrics else tuple(
        m.strip() for m in args.metrics.split(",") if m.strip()
    )
    for m in metrics:
        check_metric(m)
    entries = evaluation.read_index(args.index)
    summary = evaluation.evaluate(
        entries,
        evaluation.entry_loader(args.data, args.asf, fps=args.fps, trim=args.trim, bone_map=args.bone_map),
        metrics,
        args.out,
        depth=args.depth,
        workers=args.workers,
        figures=not args.no_figures,
        progress=None if args.no_progress else "tqdm",
        repeat=args.repeat,
    )
    lines = [f"{summary['clips']} clips; wrote {os.path.join(args.out, 'summary.json')}"]
    for name, row in summary["metrics"].items():
        lines.append(f"  {name:16s} accuracy {row['accuracy']:.3f}  {row['seconds']:.2f} s")
    return summary, "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Parser


def _add_common(p, asf=True, crop=True):
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else there")
    p.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    if asf:
        p.add_argument("--asf", help="skeleton (.asf) for .amc clips (default: the only .asf beside each .amc)")
    if asf:  # every clip-reading command
        p.add_argument("--bone-map", default="auto", metavar="auto|none|FILE.json",
                       help="match bones of different rigs through the canonical joints: auto (built-in name "
                            "tables, default), none (exact bone names), or a saved map {\"bone\": \"joint\"}")
        p.add_argument("--allow-partial", action="store_true",
                       help="compare / blend even when under half of the moving joints are shared")
    if crop:
        p.add_argument("--start", type=int, metavar="FRAME",
                       help="crop every clip to start at this frame (inclusive; wins over --trim at the start)")
        p.add_argument("--end", type=int, metavar="FRAME", help="crop every clip to end at this frame (inclusive)")
    p.add_argument("--trim", choices=("auto", "none"), default="auto",
                   help="auto (default): drop detected rest-pose / ramp frames at both ends of every clip; "
                        "none: keep every frame")
    p.add_argument("--fps", type=float, metavar="F",
                   help="frame rate of every clip (default: the file's: BVH Frame Time, AMC 120, an action's or "
                        "its scene's)")


def _metric_help(default):
    return (
        "l2 (d_P*), elastic (d_S*), group (rho^n), concat (sigma_*^n), linear (sigma_L^n) or sim (sim^n, eq. 9.1); "
        f"a level may be appended (sim3) (default: {default})"
    )


def _add_metric(p, depth_help=f"DP search depth D for elastic (default {DEFAULT_DEPTH})"):
    p.add_argument("--metric", default="sim", help=_metric_help("sim"))
    p.add_argument("--level", type=int, help=f"signature truncation level (default {DEFAULT_LEVEL})")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH, help=depth_help)


def build_parser():
    clip_help = "a .bvh, .amc, .blend (every armature action) or FILE.blend#ACTION"
    parser = _Parser(
        prog=PROG,
        description="Shape analysis of motion-capture clips: SRVT elastic distance, geodesic blends, signatures.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("distance", help="distance between two clips", description="Distance between two clips.")
    p.add_argument("a", metavar="A", help=clip_help)
    p.add_argument("b", metavar="B", help=clip_help)
    _add_metric(p)
    _add_common(p)
    p.set_defaults(func=cmd_distance)

    p = sub.add_parser(
        "rank",
        help="rank clips by similarity to a query",
        description="Rank clips by their distance to QUERY, best first. Signatures are cached in --cache DIR, "
        "else $SHAPESIG_CACHE_DIR, else the per-user cache folder (~/.cache/blender_shapesig/signatures); "
        "--no-cache keeps them in memory only.",
    )
    p.add_argument("query", metavar="QUERY", help=clip_help)
    p.add_argument("clips", metavar="CLIP", nargs="+", help=clip_help)
    _add_metric(p, depth_help=f"DP search depth D for the elastic re-rank (default {DEFAULT_DEPTH})")
    p.add_argument("--rerank", type=int, default=0, metavar="K", help="re-order the first K by elastic distance")
    p.add_argument("--top", type=int, metavar="K", help="keep the K best results")
    p.add_argument("--cache", metavar="DIR",
                   help="signature cache folder (default $SHAPESIG_CACHE_DIR, else the per-user cache folder)")
    p.add_argument("--no-cache", action="store_true", help="do not read or write a signature cache")
    _add_common(p)
    p.set_defaults(func=cmd_rank)

    p = sub.add_parser(
        "blend",
        help="SRVT geodesic blend of two clips into a .blend file",
        description="Blend clip A towards clip B along the SRVT geodesic (eq. 5.14) and save the armature "
        "with the new action(s) in a .blend file.",
    )
    p.add_argument("a", metavar="A", help=clip_help)
    p.add_argument("b", metavar="B", help=clip_help)
    p.add_argument("--weight", type=float, help="blend weight s in [0, 1]; 0 gives A, 1 gives B")
    p.add_argument("--align", action="store_true", help="time-align B to A (elastic DP) before blending")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH, help=f"DP search depth D for --align (default {DEFAULT_DEPTH})")
    p.add_argument("--frames", type=int, help="frames of the result (default: A's frame count)")
    p.add_argument(
        "--inbetweens", type=int, metavar="K", help="write K blends at weights 1/(K+1) .. K/(K+1) instead of --weight"
    )
    p.add_argument("--name", help="name of the new action (default <A>_x_<B>_<weight>)")
    p.add_argument("--out", required=True, metavar="FILE.blend", help="the .blend file to write")
    _add_common(p)
    p.set_defaults(func=cmd_blend)

    p = sub.add_parser(
        "matrix",
        help="pairwise distance matrix, MDS and dendrogram",
        description="Pairwise distances between clips (in parallel), written as DIR/matrix.csv and "
        "DIR/matrix.npy with an MDS plot and a dendrogram.",
    )
    p.add_argument("clips", metavar="CLIP", nargs="+", help=clip_help)
    _add_metric(p)
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    p.add_argument("--labels", metavar="CSV", help="colour the figures by the 'label' column of an index CSV")
    p.add_argument("--no-figures", action="store_true", help="write only the matrix")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _add_common(p)
    p.set_defaults(func=cmd_matrix)

    p = sub.add_parser(
        "evaluate",
        help="leave-one-out 1-NN accuracy of several metrics on a labelled clip set",
        description="Read an index CSV (file,label[,skeleton][,start][,end]; paths relative to --data, start/end "
        "are inclusive frame numbers), compute the pairwise matrix of every metric, and write "
        "DIR/summary.json, confusion tables, matrices and figures.",
    )
    p.add_argument("--index", required=True, metavar="CSV", help="the index CSV")
    p.add_argument("--data", required=True, metavar="DIR", help="folder the CSV paths are relative to")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--metrics",
        help="comma-separated metric names (default: l2,elastic,group3,concat3,linear3,sim2,sim3); "
        "also sim3_levelnorm, sim3_tensor, linear3_tensor, elastic_numpy, sim3+elastic5, ...",
    )
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH, help=f"DP search depth D for elastic (default {DEFAULT_DEPTH})")
    p.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    p.add_argument("--no-figures", action="store_true", help="write only the numbers")
    p.add_argument("--repeat", type=int, default=1, metavar="N",
                   help="time every matrix N times and report the shortest (default 1)")
    _add_common(p, crop=False)
    p.set_defaults(func=cmd_evaluate)
    return parser


# ---------------------------------------------------------------------------------------------


def _emit(args, out, text):
    if getattr(args, "json", False):
        sys.stdout.write(json.dumps(out) + "\n")
    elif text:
        sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _error(message, debug):
    if debug:
        traceback.print_exc(file=sys.stderr)
    line = " ".join(str(message).split()) or "error"
    if not line.startswith(PROG):
        line = f"{PROG}: error: {line}"
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
    return EXIT_ERROR


def main(argv=None):
    """Run the command line; returns the exit code (0, or 2 on errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except CommandError as exc:
        return _error(exc, debug)
    except SystemExit as exc:  # --help
        return int(exc.code or 0) if isinstance(exc.code, int) else 0
    if not getattr(args, "command", None):
        return _error("no command given: choose distance, rank, blend, matrix or evaluate (see --help)", False)
    try:
        with _stdout_to_stderr():
            out, text = args.func(args)
    except KeyboardInterrupt:
        sys.stderr.write(f"{PROG}: interrupted\n")
        return 130
    except Exception as exc:  # every failure: one line (and the traceback with --debug)
        from .core.errors import ShapeSigError

        if isinstance(exc, (CommandError, ShapeSigError)):
            return _error(exc, debug)
        if isinstance(exc, OSError):
            return _error(f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": "), debug)
        return _error(f"{type(exc).__name__}: {exc}", debug)
    _emit(args, out, text)
    return 0
