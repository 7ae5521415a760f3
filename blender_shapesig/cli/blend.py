"""SRVT geodesic blends into a .blend file: ``blend A B [C ...] --weight s|wA,wB,... --out FILE.blend`` with frame
ranges, loops, masks and planted feet (``core.blend.make_blends``)."""

import math
import os

from . import common as c

_KEPT_SHOWN = 8  # bones named in the note on stderr (a CC rig keeps ~80: fingers, twist, face)


def parse_weights(args, count):
    """A list of weight vectors (one per blend, one weight per clip): ``--weight s`` (B's weight, two clips),
    ``--weight wA,wB,...`` (one per clip, summing to 1) or ``--inbetweens K`` (two clips)."""
    from ..core.errors import ShapeSigError, check_inbetweens, check_weight
    from ..core.errors import check_weights

    if args.inbetweens is not None:
        if count != 2:
            raise c.CommandError("--inbetweens needs exactly two clips; give --weight wA,wB,... for more")
        k = check_inbetweens(args.inbetweens, "--inbetweens")  # 1..MAX_INBETWEENS, as the operator
        return [(1.0 - i / (k + 1), i / (k + 1)) for i in range(1, k + 1)]
    if args.weight is None:
        raise c.CommandError("blend: give --weight s (0..1) or --inbetweens K" if count == 2 else
                             f"blend: give --weight with {count} weights wA,wB,... summing to 1")
    parts = [x.strip() for x in str(args.weight).split(",")]
    try:
        values = [float(x) for x in parts]
    except ValueError:
        raise c.CommandError(f"--weight: expected a number or one number per clip separated by commas, "
                             f"got {args.weight!r}") from None
    if len(values) == 1:
        if count != 2:
            raise c.CommandError(f"--weight: {count} clips need {count} weights wA,wB,... summing to 1")
        w = check_weight(values[0], "--weight")  # a finite number in [0, 1], as the operator
        return [(1.0 - w, w)]
    if not all(math.isfinite(v) for v in values):
        raise c.CommandError(f"--weight: expected finite numbers, got {args.weight}")
    try:
        return [check_weights(values, count, "--weight")]
    except ShapeSigError as exc:
        raise c.CommandError(str(exc)) from None


def _sources(paths):
    """The files of the CLIP arguments (``FILE#ACTION`` names FILE)."""
    return [c.clip_spec(p).path for p in paths]


def _check_out(args, paths=()):
    out_path = os.path.abspath(args.out)
    if not out_path.lower().endswith((".blend", ".bvh")):
        raise c.CommandError(f"--out must be a .blend or .bvh file, got {c.shown(args.out)}")
    if not os.path.isdir(os.path.dirname(out_path)):
        raise c.CommandError(f"folder of --out does not exist: {c.shown(os.path.dirname(out_path))}")
    c.check_outputs([out_path], args, _sources(paths))  # never a source; an existing file only with --overwrite
    if args.frames is not None and args.frames < 2:
        raise c.CommandError("--frames must be 2 or more")
    return out_path


def _read(args, paths, ranges):
    """(clips on their own rigs, clips in the comparison space or None): a clip with a range is read whole
    (no trimming: the range is in its own frame numbers)."""
    from ..core.metrics import check_coverage
    from ..core.rigs import apply_bone_map, other_rigs

    crop = c.crop_of(args)
    own = []
    for i, path in enumerate(paths):
        given = i < len(ranges) and ranges[i] is not None
        own.append(c.load_one(path, args.asf, (None, None, crop[2], "none") if given else crop, "none"))
    mapped = None
    if args.bone_map != "none" and any(other_rigs(own[0], x) for x in own[1:]):
        mapped = [apply_bone_map(x, args.bone_map) for x in own]
    work = mapped or own
    for x in work[1:]:
        check_coverage(work[0], x, args.allow_partial)
    return own, mapped


def _names(args, blended, clips, weights):
    from ..core.blend import blend_name

    for clip, w in zip(blended, weights):
        if args.name:
            clip.name = args.name if len(weights) == 1 else f"{args.name}_{w[1] if len(w) == 2 else w[0]:.2f}"
        elif len(clips) == 2:
            clip.name = blend_name(clips[0].name, clips[1].name, w[1])
        else:
            clip.name = blend_name(clips[0].name, [x.name for x in clips[1:]], w)


def run(args):
    from ..core.blend import make_blends, parse_mask, parse_groups, parse_range
    from ..core.rigs import onto_rig

    paths = [args.a, args.b] + list(args.more or ())
    weights = parse_weights(args, len(paths))
    out_path = _check_out(args, paths)
    ranges = [parse_range(args.range_a, "--range-a"), parse_range(args.range_b, "--range-b")]
    mask = parse_mask(args.mask) if args.mask else None
    groups = parse_groups(args.group) if args.group else None
    own, mapped = _read(args, paths, ranges)

    with c.progress_bar(args, "blending") as bar:
        blended, info = make_blends(
            own, weights, mapped=mapped, back=onto_rig if mapped is not None else None, ranges=ranges,
            loop=args.loop, feet=args.feet or "lock", feet_required=args.feet is not None, mask=mask, groups=groups,
            align=args.align or args.loop, depth=args.depth, frames=args.frames, progress=bar,
            allow_long=args.allow_long)
    ref = mapped[0] if mapped is not None else own[0]
    kept = blended[0].meta.get("kept_bones", ()) if mapped is not None else ()
    if kept:
        more = len(kept) - _KEPT_SHOWN
        shown = ", ".join(kept[:_KEPT_SHOWN]) + (f", and {more} more (--json lists all)" if more > 0 else "")
        c.say("note", f"{len(kept)} bone(s) without a counterpart keep A's motion: {shown}")
    for clip in blended:
        # The blend lives in A's rotation space (pose or armature axes); write_action converts by it.
        if "rotation_space" in ref.meta:
            clip.meta.setdefault("rotation_space", ref.meta["rotation_space"])
    _names(args, blended, own, weights)
    for report in info["feet"] or ():
        if "skipped" in report:
            c.say("note", f"feet not planted: {report['skipped']}")
    from .transition import write_clips

    # complete or absent: saved under a temporary name, then renamed; .bvh: one clip, A's skeleton
    tmp = c.temp_beside(out_path, os.path.splitext(out_path)[1].lower())
    try:
        names = write_clips(c.clip_spec(args.a, args.asf), blended, tmp, own[0])
        c.check_outputs([out_path], args, _sources(paths))  # (again: the folder may have changed meanwhile)
        os.replace(tmp, out_path)
    finally:
        for leftover in (tmp, tmp + "1", tmp + "@"):  # Blender's backup and partial names
            if os.path.exists(leftover):
                os.remove(leftover)
    out = {
        "out": out_path,
        "actions": list(names),
        "frames": [int(x.frames) for x in blended],
        "seconds": [(x.frames - 1) / float(x.fps) for x in blended],
        "fps": [float(x.fps) for x in blended],
        "weights": [w[1] for w in weights] if len(paths) == 2 else [list(w) for w in weights],
        "align": bool(args.align or args.loop),
        "sources": info["sources"],
        "feet": info["feet"],
        "loop": info["loop"],
    }
    if mapped is not None:
        out["kept_bones"] = list(kept)
    if mask:
        out["bone_weights"] = blended[0].meta.get("bone_weights")
    text = "\n".join(
        [f"wrote {out_path}"] + [f"  {n}: {x.frames} frames, {(x.frames - 1) / x.fps:.3f} s at {x.fps:g} fps "
                                 f"(weights {', '.join(f'{v:g}' for v in w)})"
                                 for n, x, w in zip(names, blended, weights)]
        + _feet_lines(info["feet"]))
    return out, text


def _feet_lines(reports):
    """One line per blend: the planted contacts and their largest slide before and after."""
    lines = []
    for report in reports or ():
        if "skipped" in report:
            continue
        before = [d for f in report["feet"] for d in f["drift_before"]]
        after = [d for f in report["feet"] for d in f["drift_after"]]
        if after:
            lines.append(f"  feet: {len(after)} planted contact(s), largest slide {100 * max(before):.1f} cm -> "
                         f"{100 * max(after):.1f} cm, root lowered {100 * report['root_lowered']:.1f} cm")
    return lines


def add_parser(sub):
    p = sub.add_parser(
        "blend",
        help="SRVT geodesic blend of two or more clips into a .blend file",
        description="Blend clip A towards clip B (and more clips) along the SRVT geodesic (eq. 5.14) and save the "
        "armature with the new action(s) in a .blend file. Planted feet stay planted (--feet lock, default).",
    )
    p.add_argument("a", metavar="A", help=c.CLIP_HELP)
    p.add_argument("b", metavar="B", help=c.CLIP_HELP)
    p.add_argument("more", metavar="C", nargs="*", help="more clips (give one weight per clip with --weight)")
    p.add_argument("--weight", help="B's weight s in [0, 1] (0 gives A, 1 gives B), or one weight per clip "
                   "wA,wB,wC,... summing to 1")
    p.add_argument("--align", action="store_true", help="time-align the clips to A (elastic DP) before blending")
    p.add_argument("--depth", type=int, default=c.DEFAULT_DEPTH, help=f"DP search depth D for --align (default {c.DEFAULT_DEPTH})")
    p.add_argument("--frames", type=int, help="frames of the result (default: the weighted average duration)")
    p.add_argument(
        "--inbetweens", type=int, metavar="K", help="write K blends at weights 1/(K+1) .. K/(K+1) instead of --weight"
    )
    p.add_argument("--range-a", metavar="S:E", help="frames of A to blend (its own numbers, inclusive)")
    p.add_argument("--range-b", metavar="S:E", help="frames of B to blend (its own numbers, inclusive)")
    p.add_argument("--feet", choices=("lock", "none"), default=None,
                   help="lock (default): feet planted in the sources stay planted in the blend (two-bone IK on "
                        "the legs; skipped with a note when a rig has no legs); none: as blended")
    p.add_argument("--allow-long", action="store_true",
                   help="blend clips lasting more than 8 times as long as each other (refused by default)")
    p.add_argument("--loop", action="store_true",
                   help="a seamless cycle: one stride of each clip (cycle detection), aligned, closed")
    p.add_argument("--mask", metavar="GROUP=w,...",
                   help="per-bone-group weights of B (two clips): groups upper, legs, arms, spine, head, left_arm, "
                        "right_arm, left_leg, right_leg, a canonical joint or a bone; root motion follows the legs")
    p.add_argument("--group", action="append", metavar="NAME=JOINT+JOINT",
                   help="a custom group for --mask (joints or bone names; repeatable)")
    p.add_argument("--name", help="name of the new action (default <A>_x_<B>_<weight>)")
    p.add_argument("--out", required=True, metavar="FILE.blend|FILE.bvh",
                   help="the .blend file to write, or a .bvh file (one blend, on A's skeleton)")
    c.add_overwrite(p)
    c.add_common(p)
    p.set_defaults(func=run)
