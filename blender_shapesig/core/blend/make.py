"""Make blends an animator can use, in one call shared by the command line and the Blend operator:
``make_blends(clips, weights, ...)`` crops ranges, cuts one cycle, blends (two clips or more, masks), puts
blends of several rigs back onto the rig, plants the feet and closes loops, in that order;
``editable_timing`` / ``sample_at`` split a blend into a pose curve and an editable clock and bake it back.
See docs/blending.md.
"""

from dataclasses import replace

import numpy as np

from ..geometry.curves import geodesic_interpolate, uniform_times
from ..errors import ShapeSigError
from ..elastic import DEFAULT_DEPTH
from ..errors import check_weights
from .cycle import apply_cycle, close_loop, crop_range, one_cycle
from ..progress import check as check_progress
from .mix import blend_clip_series, blend_many

__all__ = ["make_blends", "FEET_MODES", "sample_at", "editable_timing"]

FEET_MODES = ("lock", "none")


def _labels(n):
    return [f"range of clip {chr(65 + i) if i < 26 else i + 1}" for i in range(n)]


def _select(own, mapped, ranges, loop):
    """(own, mapped, source notes): ranges and cycles applied to both versions of each clip (same frames)."""
    own, mapped = list(own), (list(mapped) if mapped is not None else None)
    ranges = list(ranges or ())
    if len(ranges) > len(own):
        raise ShapeSigError(f"ranges: {len(ranges)} ranges for {len(own)} clips")
    notes = [{"name": c.name, "range": None, "cycle": None} for c in own]
    for i, (rng, label) in enumerate(zip(ranges, _labels(len(own)))):
        if rng is None:
            continue
        own[i] = crop_range(own[i], rng, label)
        notes[i]["range"] = list(own[i].meta["range"])
        if mapped is not None:
            mapped[i] = mapped[i].crop(*own[i].meta["range"])
    if loop:
        work = mapped if mapped is not None else own
        first = one_cycle(work[0])
        cycles = [first] + [one_cycle(c, like=first) for c in work[1:]]
        for i, cyc in enumerate(cycles):
            info = cyc.meta["cycle"]
            notes[i]["cycle"] = {k: info[k] for k in ("start", "end", "period")}
            notes[i]["cycle"]["seconds"] = info["period"] / float(cyc.fps)
            if info.get("whole"):  # the clip already is one cycle: looped as it is
                notes[i]["cycle"]["whole"] = True
            own[i] = apply_cycle(own[i], info)
            if mapped is not None:
                mapped[i] = cyc
    return own, mapped, notes


def _blend(work, weights, kw, progress):
    """Step 3: one Clip per weight vector."""
    if len(work) == 2:
        return blend_clip_series(work[0], work[1], [w[1] for w in weights], progress=progress, **kw)
    if kw.pop("mask", None):
        raise ShapeSigError("a mask needs exactly two clips (its weights are B's); blend more clips without one")
    kw.pop("groups", None)
    out = []
    for i, w in enumerate(weights):
        warps = out[0].meta["warps"] if out else None
        if out and not out[0].meta["aligned"]:
            warps = None
        out.append(blend_many(work, w, warps=warps, **kw))
        if out[0].meta["aligned"] and i:
            out[-1].meta["elastic_distances"] = out[0].meta["elastic_distances"]
            out[-1].meta["elastic_distance"] = out[0].meta["elastic_distance"]
        check_progress(progress, i + 1, len(weights))
    return out


# sources lasting more than this many times as long as each other are refused unless asked (a 20,000-frame take
# blended with a 144-frame stride is a mistake more often than not)
MAX_DURATION_RATIO = 8.0


def check_durations(clips, allow_long=False):
    """ShapeSigError (one line) when the longest clip lasts more than ``MAX_DURATION_RATIO`` times the shortest."""
    seconds = [(c.frames - 1) / float(c.fps) for c in clips]
    long, short = int(np.argmax(seconds)), int(np.argmin(seconds))
    if allow_long or seconds[short] <= 0 or seconds[long] <= MAX_DURATION_RATIO * seconds[short]:
        return
    a, b = clips[long], clips[short]
    raise ShapeSigError(f"{a.name!r} ({seconds[long]:.1f} s) lasts {seconds[long] / seconds[short]:.0f} times as long "
                        f"as {b.name!r} ({seconds[short]:.1f} s), more than {MAX_DURATION_RATIO:g}: choose a frame "
                        f"range of the longer one or allow long blends")


def make_blends(clips, weights, *, mapped=None, back=None, ranges=None, loop=False, feet="lock",
                feet_required=True, mask=None, groups=None, align=True, depth=DEFAULT_DEPTH, frames=None,
                bones=None, root="blend", up_axis=None, progress=None, allow_long=False):
    """(blends, info): the module docstring's steps for ``clips`` (each on its own rig) and ``weights`` (a list of
    weight vectors, one weight per clip each, summing to 1; one blend per vector).

    ``mapped``: the clips in the comparison space (several rigs), ``back(blend, rig_clip, mapped_clip)`` writes a
    blend back onto the first clip's rig. ``ranges``: per clip None or ``"S:E"``/(S, E). ``feet``: "lock" or
    "none"; with ``feet_required=False`` a blend whose rig has no legs (or no rest skeleton) is kept unplanted and
    its report says why (``{"skipped": reason}``). ``mask``/``groups``: per-bone-group weights of B (two clips).
    ``progress(done, total)`` (``core.progress``): after each blend; returning True raises Cancelled.
    ``info``: ``{"sources": [{"name", "range", "cycle"}], "feet": [report per blend] or None, "loop": [meta loop]
    or None}``."""
    if feet not in FEET_MODES:
        raise ShapeSigError(f"feet: expected one of {', '.join(FEET_MODES)}, got {feet!r}")
    n = len(clips)
    weights = [check_weights(w, n) for w in weights]
    if not weights:
        raise ShapeSigError("weights: at least one weight vector is needed")
    own, mapped, notes = _select(clips, mapped, ranges, loop)
    check_durations(own, allow_long)
    work = own
    if mapped is not None:  # several rigs: the others' rotations relative to A's rest pose (rigs.rest_retarget)
        from ..rigs import rest_retarget

        work = [mapped[0]] + [rest_retarget(c, mapped[0]) for c in mapped[1:]]
    kw = dict(align=align, depth=depth, frames=frames, bones=bones, root=root, up_axis=up_axis, mask=mask,
              groups=groups)
    blends = _blend(work, weights, kw, progress)
    if back is not None:
        blends = [back(x, own[0], work[0]) for x in blends]
    reports = None
    if feet == "lock":
        from .feet import lock_feet

        reports = []
        for i, x in enumerate(blends):
            try:
                blends[i], report = lock_feet(x, own)
            except ShapeSigError as exc:
                if feet_required:
                    raise
                report = {"skipped": str(exc)}
            reports.append(report)
    loops = None
    if loop:
        blends = [close_loop(x) for x in blends]
        loops = [x.meta["loop"] for x in blends]
    return blends, {"sources": notes, "feet": reports, "loop": loops}


def sample_at(clip, positions, name=None):
    """The clip at fractional frame ``positions`` (0 = its first frame): rotations along geodesics (eq. 5.8), the
    root path linearly; positions are clamped to the clip."""
    n = clip.frames
    x = np.clip(np.asarray(positions, dtype=np.float64), 0.0, n - 1) / (n - 1)
    rot = geodesic_interpolate(clip.rotations, uniform_times(n), x)
    rt = clip.root_translation
    if rt is not None:
        rt = np.stack([np.interp(x, uniform_times(n), rt[:, i]) for i in range(rt.shape[1])], axis=1)
    return replace(clip, name=name or clip.name, rotations=rot, root_translation=rt)


def editable_timing(blend):
    """(the pose curve, keys): ``blend`` (a result of ``make_blends`` or ``blend_clips``) split as the module
    docstring says: the clip sampled uniformly in the reference's parameter u (the same frame count), and the clock
    as an array (nodes, 2) of (frame of the blend, frame of the pose curve), both from 0, at every warp node.
    ShapeSigError for a loop (its frames are turned to the quietest seam: it is written baked)."""
    if blend.meta.get("loop"):
        raise ShapeSigError(f"blend {blend.name!r} is a loop: its timing is written baked (no editable timing)")
    u_out = blend.meta.get("time_map")
    if u_out is None:
        raise ShapeSigError(f"blend {blend.name!r} has no time map (meta time_map)")
    u_out = np.maximum.accumulate(np.asarray(u_out, dtype=np.float64))
    n = blend.frames
    frames = np.arange(n, dtype=np.float64)
    curve = sample_at(blend, np.interp(uniform_times(n), u_out, frames))
    curve.meta = dict(blend.meta, timing="editable")
    nodes = np.array([0.0, 1.0])
    for warp in blend.meta.get("warps") or [blend.meta.get("warp")]:
        if warp is not None:
            nodes = np.union1d(nodes, np.clip(np.asarray(warp, dtype=np.float64)[:, 0], 0.0, 1.0))
    keys = np.stack([np.interp(nodes, u_out, frames), nodes * (n - 1)], axis=1)
    return curve, keys
