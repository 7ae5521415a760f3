"""SRVT geodesic blends into a .blend file: ``blend A B --weight s --out FILE.blend``."""

import os
import sys

from . import common as c


def parse_weights(args):
    from ..core.errors import check_inbetweens, check_weight

    if args.inbetweens is not None:
        k = check_inbetweens(args.inbetweens, "--inbetweens")  # 1..MAX_INBETWEENS, as the operator
        return [i / (k + 1) for i in range(1, k + 1)]
    if args.weight is None:
        raise c.CommandError("blend: give --weight s (0..1) or --inbetweens K")
    return [check_weight(args.weight, "--weight")]  # a finite number in [0, 1], as the operator


def run(args):
    weights = parse_weights(args)
    out_path = os.path.abspath(args.out)
    if not out_path.lower().endswith(".blend"):
        raise c.CommandError(f"--out must be a .blend file, got {args.out}")
    if not os.path.isdir(os.path.dirname(out_path)):
        raise c.CommandError(f"folder of --out does not exist: {os.path.dirname(out_path)}")
    if args.frames is not None and args.frames < 2:
        raise c.CommandError("--frames must be 2 or more")
    from ..core.blend import blend_clip_series, blend_name
    from ..core.metrics import check_coverage
    from ..core.rigs import apply_bone_map, onto_rig

    # one rig: its own bones, as before; two rigs: through the bone map, written back onto A's rig
    a = a_rig = c.load_one(args.a, args.asf, c.crop_of(args), "none")
    b = c.load_one(args.b, args.asf, c.crop_of(args), "none")
    if args.bone_map != "none" and a.bones != b.bones:
        a, b = apply_bone_map(a, args.bone_map), apply_bone_map(b, args.bone_map)
    check_coverage(a, b, args.allow_partial)

    bar = c.progress(args, len(weights), "blending")
    try:
        blended = blend_clip_series(
            a, b, weights, align=args.align, depth=args.depth, frames=args.frames,
            progress=lambda i, n: bar.update(),
        )
    finally:
        bar.close()
    if a.meta.get("rotation_space") == "comparison":  # across rigs: back onto A's rig through its bone map
        blended = [onto_rig(x, a_rig, a) for x in blended]
        kept = blended[0].meta.get("kept_bones", ())
        if kept:
            sys.stderr.write(f"{c.PROG}: note: bones without a counterpart keep A's motion: {', '.join(kept)}\n")
    for clip, w in zip(blended, weights):
        # The blend lives in A's rotation space (pose or armature axes); write_action converts by it.
        if "rotation_space" in a.meta:
            clip.meta.setdefault("rotation_space", a.meta["rotation_space"])
        if args.name:
            clip.name = args.name if len(weights) == 1 else f"{args.name}_{w:.2f}"
        else:
            clip.name = blend_name(a.name, b.name, w)
    from ..write_blend import write_blend

    names = write_blend(c.clip_spec(args.a, args.asf), blended, out_path)
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


def add_parser(sub):
    p = sub.add_parser(
        "blend",
        help="SRVT geodesic blend of two clips into a .blend file",
        description="Blend clip A towards clip B along the SRVT geodesic (eq. 5.14) and save the armature "
        "with the new action(s) in a .blend file.",
    )
    p.add_argument("a", metavar="A", help=c.CLIP_HELP)
    p.add_argument("b", metavar="B", help=c.CLIP_HELP)
    p.add_argument("--weight", type=float, help="blend weight s in [0, 1]; 0 gives A, 1 gives B")
    p.add_argument("--align", action="store_true", help="time-align B to A (elastic DP) before blending")
    p.add_argument("--depth", type=int, default=c.DEFAULT_DEPTH, help=f"DP search depth D for --align (default {c.DEFAULT_DEPTH})")
    p.add_argument("--frames", type=int, help="frames of the result (default: A's frame count)")
    p.add_argument(
        "--inbetweens", type=int, metavar="K", help="write K blends at weights 1/(K+1) .. K/(K+1) instead of --weight"
    )
    p.add_argument("--name", help="name of the new action (default <A>_x_<B>_<weight>)")
    p.add_argument("--out", required=True, metavar="FILE.blend", help="the .blend file to write")
    c.add_common(p)
    p.set_defaults(func=run)
