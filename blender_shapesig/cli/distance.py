"""Distance between two clips: ``distance A B --metric ...``."""

from . import common as c


def run(args):
    from ..core.metrics import compare_clips, metric_label, parse_metric
    from ..core.clip.trim import trim_note, trimmed_range
    from ..core.io.text import json_float

    base, level = parse_metric(args.metric, args.level)
    a = c.load_one(args.a, args.asf, c.crop_of(args), args.bone_map)
    b = c.load_one(args.b, args.asf, c.crop_of(args), args.bone_map)
    got = compare_clips(a, b, base, level=level, depth=args.depth, allow_partial=args.allow_partial)
    d = got["distance"]
    label = metric_label(base, level)
    out = {"distance": json_float(d), "metric": label, "a": c.display_name(a), "b": c.display_name(b),
           "bones": got["bones"], "coverage": got["coverage"], "unmapped": got["unmapped"]}
    if base == "elastic":
        out["depth"] = args.depth
    # the frames compared (scene numbers, inclusive) and what trimming cut (core.clip.trim)
    out["trim"] = {"a": trimmed_range(a)["frames"], "b": trimmed_range(b)["frames"]}
    out["trimmed"] = {"a": trimmed_range(a)["cut"], "b": trimmed_range(b)["cut"]}
    text = "\n".join([f"{label}({c.shown(a.name)}, {c.shown(b.name)}) = {d:.6g}"]
                     + [c.shown(n) for n in map(trim_note, (a, b)) if n])
    return out, text


def add_parser(sub):
    p = sub.add_parser("distance", help="distance between two clips", description="Distance between two clips.")
    p.add_argument("a", metavar="A", help=c.CLIP_HELP)
    p.add_argument("b", metavar="B", help=c.CLIP_HELP)
    c.add_metric(p)
    c.add_common(p)
    p.set_defaults(func=run)
