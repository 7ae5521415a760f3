"""Transitions into a .blend or .bvh file: ``transition A B [--cut I:J] [--frames N] [--bridge CLIP_OR_FOLDER...]
--out FILE.blend|FILE.bvh``: the ranked cuts where A can hand over to B, and the joined clip on A's skeleton
(``core.blend.transition``)."""

import os

from . import common as c

__all__ = ["add_parser", "run", "parse_cut", "check_out", "write_clips"]

TOP = 5  # cuts listed


def parse_cut(text):
    """``"I:J"`` -> (I, J), frame indices from 0 of A and B (as the JSON's cuts); None for None."""
    if text is None:
        return None
    parts = str(text).split(":")
    try:
        i, j = (int(p) for p in parts)
    except ValueError:
        raise c.CommandError(f"--cut: expected I:J (frame indices of A and B from 0), got {text!r}") from None
    if i < 0 or j < 0:
        raise c.CommandError(f"--cut: frame indices start at 0, got {text!r}")
    return i, j


def check_out(args, sources=()):
    """The absolute --out path: a .blend or .bvh in an existing folder, never a source, an existing file only with
    ``--overwrite`` (``common.check_outputs``)."""
    out_path = os.path.abspath(args.out)
    if not out_path.lower().endswith((".blend", ".bvh")):
        raise c.CommandError(f"--out must be a .blend or .bvh file, got {c.shown(args.out)}")
    if not os.path.isdir(os.path.dirname(out_path)):
        raise c.CommandError(f"folder of --out does not exist: {c.shown(os.path.dirname(out_path))}")
    files = [c.clip_spec(s).path for s in sources if os.path.isfile(c.clip_spec(s).path)]
    c.check_outputs([out_path], args, files)
    return out_path


_SKELETON = ("rest_heads", "rest_tails", "parents", "rest_rotations", "rotation_space", "up_axis")


def write_clips(spec_a, clips, out_path, rig=None):
    """Write ``clips`` to ``out_path``: a .bvh holds one clip on its own skeleton (``core.io.bvh_write``; the
    skeleton entries it lacks from ``rig``, A's clip), a .blend A's armature with one action per clip
    (``write_blend_file``). Returns the names written."""
    if out_path.lower().endswith(".bvh"):
        if len(clips) != 1:
            raise c.CommandError(f"a .bvh file holds one clip, got {len(clips)}: write a .blend or make one clip")
        from dataclasses import replace

        from ..core.io.bvh_write import write_bvh

        clip = clips[0]
        if rig is not None:
            clip = replace(clip, meta=dict({k: rig.meta[k] for k in _SKELETON if k in rig.meta}, **clip.meta))
        write_bvh(clip, out_path)
        return [clips[0].name]
    from ..actions.write_blend_file import write_blend

    return write_blend(spec_a, clips, out_path)


def run(args):
    import time

    from ..core.blend.transition import best_cuts, transition

    cut = parse_cut(args.cut)
    out_path = check_out(args, [args.a, args.b] + list(args.bridge or ()))
    if args.frames is not None and args.frames < 1:
        raise c.CommandError("--frames must be 1 or more")
    crop = (None, None, c.crop_of(args)[2], args.trim or "auto")
    a = c.load_one(args.a, args.asf, crop, "none")
    b = c.load_one(args.b, args.asf, crop, "none")
    started = time.perf_counter()
    cuts = best_cuts(a, b, top=TOP)
    joined = transition(a, b, cut=cut if cut is not None else (cuts[0].a_frame, cuts[0].b_frame), frames=args.frames,
                        library=list(args.bridge) if args.bridge else None)
    elapsed = time.perf_counter() - started
    info = joined.meta["transition"]
    chosen = info["cut"]
    if args.name:
        joined.name = args.name
    tmp = c.temp_beside(out_path, os.path.splitext(out_path)[1].lower())  # complete or absent, then renamed
    try:
        names = write_clips(c.clip_spec(args.a, args.asf), [joined], tmp)
        os.replace(tmp, out_path)
    finally:
        for leftover in (tmp, tmp + "1", tmp + "@"):  # Blender's backup and partial names
            if os.path.exists(leftover):
                os.remove(leftover)
    out = {"cut": chosen, "cuts": [x.as_dict() for x in cuts], "frames": int(info["frames"]),
           "seconds": (joined.frames - 1) / float(joined.fps), "out": out_path, "action": names[0],
           "total_frames": int(joined.frames), "fps": float(joined.fps), "generator": info["inbetween"],
           "turn_degrees": info["turn_degrees"], "compute_seconds": round(elapsed, 4)}
    gen = info["inbetween"]["generator"]
    lines = [f"wrote {out_path}",
             f"  {names[0]}: A to frame {chosen['a_frame']}, {info['frames']} generated frames ({gen}), B from frame "
             f"{chosen['b_frame']}; {joined.frames} frames, {out['seconds']:.3f} s at {joined.fps:g} fps",
             "  best cuts (A frame, B frame, cost): " + ", ".join(f"{x.a_frame}:{x.b_frame} {x.cost:.3f}" for x in cuts)]
    return out, "\n".join(lines)


def add_parser(sub):
    p = sub.add_parser(
        "transition",
        help="join clip A into clip B at their best cut, with generated frames between",
        description="Find where clip A can hand over to clip B (ranked cuts: pose, velocity and foot contacts over "
        "a short window after a fit on the ground), then write A up to its cut, N generated frames and B from its "
        "cut, B moved so it continues where A goes, on A's skeleton and frame rate.",
    )
    p.add_argument("a", metavar="A", help=c.CLIP_HELP)
    p.add_argument("b", metavar="B", help=c.CLIP_HELP)
    p.add_argument("--cut", metavar="I:J", help="hand over at frame I of A and frame J of B (frame indices from 0, "
                   "as the JSON's cuts; default: the best cut)")
    p.add_argument("--frames", type=int, metavar="N", help="generated frames between the clips (default 0.3 s)")
    p.add_argument("--bridge", nargs="+", metavar="CLIP_OR_FOLDER",
                   help="make the generated frames from the library segment that best bridges the gap")
    p.add_argument("--name", help="name of the new action (default <A>_to_<B>)")
    p.add_argument("--out", required=True, metavar="FILE.blend|FILE.bvh", help="the file to write")
    c.add_overwrite(p)
    c.add_common(p, crop=False)
    p.set_defaults(func=run)
