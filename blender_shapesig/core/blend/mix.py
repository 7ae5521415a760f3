"""Mix clips: blends of two or more ``Clip`` objects (bones, subsets, masks, root motion, the sources' times).

``blend_clips(a, b, w)`` is the two-clip blend; ``blend_many([a, b, c, ...], [wa, wb, wc, ...])`` the blend of
several clips aligned to the first (the reference); both run the same code (``_mix``), and ``blend_many([a, b],
[1 - w, w])`` is ``blend_clips(a, b, w)``. See ``combine`` for the curves and docs/blending.md.
"""

import numpy as np

from ..clip.clip import Clip, shared_bones, still_joints
from ..geometry.curves import relative_rotvecs
from ..elastic.elastic import check_warp
from ..errors import ShapeSigError, check_integer, check_number
from ..elastic import DEFAULT_DEPTH
from ..clip.prepare import prepare_rotations
from ..errors import check_weights
from .combine import _Plan, blend_name, compute_warp, default_frames_many, mean_start
from ..clip.skeleton import root_up
from ..progress import check as check_progress
from .move_root import blend_root_path, interp_rows

__all__ = ["blend_clips", "blend_many", "blend_clip_series", "blend_fps"]


def _bone_list(bones):
    if bones is None:
        return None
    if isinstance(bones, str):
        bones = [b.strip() for b in bones.split(",")]
    out = []
    for b in bones:
        b = str(b).strip()
        if b and b not in out:
            out.append(b)
    if not out:
        raise ShapeSigError("bones: the bone subset is empty")
    return out


def blend_fps(a, b, *more):
    """A blend's frame rate: the highest of its sources' (no source's detail is lost)."""
    return max(float(c.fps) for c in (a, b) + more)


def blend_clips(a, b, weight, align=True, depth=DEFAULT_DEPTH, frames=None, bones=None, root="blend", *,
                warp=None, up_axis=None, penalty=0.0, name=None, time_base=True, mask=None, groups=None):
    """Blend clip ``a`` (weight 0) with clip ``b`` (weight 1) into a new Clip.

    * Bones are matched by name. Bones only in ``a`` keep A's motion (in the blended timing); bones
      only in ``b`` are dropped; both lists are in ``result.meta["unmatched_bones"]``.
    * ``bones``: blend only this subset (names or a comma-separated string; every name must be in
      both clips); the other bones keep A's motion in the blended timing. The warp is always
      computed on *all* shared bones that move (the timing of the whole body, e.g. foot contacts),
      so a subset blend stays in step with the rest of the body; pass ``warp=`` to override.
    * ``mask``: per-bone-group weights ``{group, canonical joint or bone: weight}`` (``mask.bone_weights``;
      ``groups``: custom groups ``{name: [joints or bones]}``): named bones blend at their own weight, the
      others at ``weight``; the timing and the root translation follow the hips' (the legs') weight. One warp.
    * ``align``/``depth``/``penalty``: the elastic alignment (see ``geodesic_blend``).
    * ``frames``: default ``round(((1 - w) D0 + w D1) fps) + 1``, D the durations in seconds, fps = ``blend_fps``:
      the weighted average of the durations whatever the rates. Frame start, bones and rotation modes are A's.
    * ``time_base``: align on the comparison time base (``prepare.prepare_rotations``); False: as read.
    * ``root="blend"``: the root translation is blended time-aligned: its height (along the up axis)
      directly, its horizontal per-frame displacements in the root's heading frame (twist of the
      root rotation about the up axis), then integrated from the blended start position, so a blend
      of two forward locomotions moves forward. ``root="a"``: A's root path (in the blended timing).
      ``up_axis``: 'X', 'Y', 'Z' or a vector in the root's parent space; default
      the clips' (``skeleton.root_up``: their meta, else estimated from their roots).
      When only one clip has a root translation, or the root bone is not shared, A's path is used.

    ``result.meta`` holds ``weight``, ``weights``, ``sources``, ``blended_bones``, ``unmatched_bones``,
    ``warp``, ``warps``, ``warp_bones``, ``elastic_distance`` (None without align), ``root_mode``, ``up_axis``,
    ``time_map`` (A's parameter u of every frame), ``source_times`` (per source, seconds from its first frame of
    every blended frame) and, with a mask, ``bone_weights``.
    """
    w = check_number(weight, "weight", 0.0, 1.0)
    return _mix([a, b], (1.0 - w, w), align, depth, frames, bones, root, None if warp is None else [warp],
                up_axis, penalty, name if name is not None else blend_name(a.name, b.name, w), time_base,
                (mask, groups, w))


def blend_many(clips, weights, align=True, depth=DEFAULT_DEPTH, frames=None, bones=None, root="blend", *,
               warps=None, up_axis=None, penalty=0.0, name=None, time_base=True):
    """The blend of two or more clips with ``weights`` (one per clip, each in [0, 1], summing to 1): every clip
    aligned to the first (the reference: its bones, rig, rotation modes and first frame), their SRVTs averaged
    with the weights (eq. 5.14 generalised, see ``combine``), the timing ``sum_i w_i D_i phi_i(u)``, the start
    pose the weighted Karcher mean, the root displacements averaged in the heading frames.

    Bones are those the reference shares with every other clip; the reference's others keep its motion.
    ``warps``: one warp per clip after the first (onto the first) instead of computing them. For two clips
    this is ``blend_clips(a, b, weights[1])``. Symmetry: permuting the clips after the reference changes
    nothing (to round-off); without alignment (identity warps) any permutation of clips of the same bones gives
    the same curve; with alignment a different reference gives the blend through other pairwise warps (the DP's
    warps are not exactly transitive), see docs/blending.md."""
    clips = list(clips)
    if len(clips) < 2:
        raise ShapeSigError("blend_many: at least two clips are needed")
    ws = check_weights(weights, len(clips))
    if warps is not None and len(warps) != len(clips) - 1:
        raise ShapeSigError(f"warps: expected {len(clips) - 1} warps (one per clip after the first)")
    default = blend_name(clips[0].name, [c.name for c in clips[1:]], ws) if len(clips) > 2 else \
        blend_name(clips[0].name, clips[1].name, ws[1])
    return _mix(clips, ws, align, depth, frames, bones, root, warps, up_axis, penalty,
                name if name is not None else default, time_base, None)


def _mix(clips, ws, align, depth, frames, bones, root, warps, up_axis, penalty, name, time_base, masking):
    """The blend of ``clips`` with timing/root weights ``ws``: see ``blend_clips`` and ``blend_many``."""
    _check_blend_inputs(clips, root)
    frames = check_integer(frames, "frames", minimum=2, allow_none=True)
    ref = clips[0]
    shared, blended = _blended_bones(clips, bones)
    idx = [{x: i for i, x in enumerate(c.bones)} for c in clips]
    warp_bones = _warp_bones(clips, shared, idx)
    given_warp = warps is not None
    if given_warp:
        warps, edists = [check_warp(x, strict=True) for x in warps], [None] * (len(clips) - 1)
    else:
        R = [c.rotations[:, [ix[x] for x in warp_bones]] for c, ix in zip(clips, idx)]
        if time_base:  # a warp maps normalized times and the preparation keeps durations: it applies as is
            R = [prepare_rotations(r, c.fps) for r, c in zip(R, clips)]
        pairs = [compute_warp(R[0], r, align, depth, penalty) for r in R[1:]]
        warps, edists = [p[0] for p in pairs], [p[1] for p in pairs]

    W, bone_weights = ws, None
    if masking is not None and masking[0]:
        from .mask import bone_weights as resolve

        per_bone, hips_w = resolve(ref, blended, masking[0], masking[2], masking[1])
        bone_weights = dict(zip(blended, (float(x) for x in per_bone)))
        W = (1.0 - per_bone, per_bone)
        ws = (1.0 - hips_w, hips_w)
    durations = [(c.frames - 1) / float(c.fps) for c in clips]
    fps = blend_fps(*clips)
    if frames is None:
        frames = default_frames_many([c.frames for c in clips], ws, durations, fps)
    plan = _Plan([c.frames for c in clips], ws, warps, frames, durations)

    # Every bone of the reference in the blended timing, then the blended bones replaced.
    rel_a = relative_rotvecs(ref.rotations)
    out = plan.r0_out(ref.rotations, rel_a)
    cols = [[ix[x] for x in blended] for ix in idx]
    qs = [plan.q_on_grid(0, rel_a[:, cols[0]])]
    qs += [plan.q_on_grid(i, relative_rotvecs(c.rotations[:, cols[i]])) for i, c in enumerate(clips) if i > 0]
    Bg, steps = plan.blend_q(qs, W)
    start = mean_start([c.rotations[0, col] for c, col in zip(clips, cols)], W)
    out[:, cols[0]] = plan.resample(Bg, steps) @ start[None]
    translation, root_mode, up = _blend_translation(plan, clips, idx, blended, Bg, start, root, up_axis)

    only_a = [x for x in ref.bones if x not in shared]
    others = [x for c in clips[1:] for x in c.bones if x not in idx[0]]
    others = list(dict.fromkeys(others))
    meta = {
        "weight": (masking[2] if masking is not None else ws[1]) if len(clips) == 2 else None,
        "weights": tuple(float(x) for x in ws),
        "sources": tuple(c.name for c in clips),
        "blended_bones": tuple(blended),
        "unmatched_bones": tuple(only_a + others),
        "unmatched_a": tuple(only_a),
        "unmatched_b": tuple(others),
        "warp": warps[0],
        "warps": tuple(warps),
        "warp_bones": tuple(warp_bones),
        "elastic_distance": edists[0],
        "elastic_distances": tuple(edists),
        "aligned": bool(align) or given_warp,
        "root_mode": root_mode,
        "up_axis": None if up is None else tuple(float(x) for x in up),
        "time_map": plan.u_out,
        # the feet pass's contract (core.blend.feet): seconds from each source's first frame of every blended frame
        "source_times": [t * d for t, d in zip(plan.source_times(), durations)],
    }
    if bone_weights is not None:
        meta["bone_weights"] = bone_weights
    if ref.meta.get("rotation_space") is not None:
        # the blend is in A's rotation space (write_action converts an armature-space blend back to pose)
        meta["rotation_space"] = ref.meta["rotation_space"]
    return Clip(
        name=name,
        bones=ref.bones,
        rotations=out,
        fps=fps,
        frame_start=ref.frame_start,
        root_translation=translation,
        root_bone=ref.root_bone,
        rotation_modes=ref.rotation_modes,
        source="blend of " + " and ".join(c.name for c in clips),
        meta=meta,
    )


def _check_blend_inputs(clips, root):
    """ShapeSigError for clips of different rotation spaces, a bad root mode or a clip of fewer than two
    frames."""
    if not all(isinstance(c, Clip) for c in clips):
        raise ShapeSigError("blend_clips: expected Clip objects")
    spaces = [(c.name, c.meta.get("rotation_space")) for c in clips if c.meta.get("rotation_space") is not None]
    for (na, sa), (nb, sb) in zip(spaces, spaces[1:]):
        if sa != sb:
            raise ShapeSigError(f"clips {na!r} and {nb!r} have rotations in different spaces "
                                f"({sa} and {sb}); read both in the same space")
    if root not in ("blend", "a"):
        raise ShapeSigError(f"root: expected 'blend' or 'a', got {root!r}")
    for c in clips:
        if c.frames < 2:
            raise ShapeSigError(f"clip {c.name!r}: needs at least two frames, has {c.frames}")


def _blended_bones(clips, bones):
    """(shared bones, the bones to blend: all shared or the subset, in the reference's order)."""
    shared = shared_bones(*clips)
    if not shared:
        names = " and ".join(repr(c.name) for c in clips)
        raise ShapeSigError(f"clips {names} share no bones")
    subset = _bone_list(bones)
    if subset is None:
        return shared, list(shared)
    missing = [x for x in subset if x not in shared]
    if missing:
        names = " and ".join(repr(c.name) for c in clips)
        raise ShapeSigError(f"bone(s) {', '.join(missing)} not in both clips {names}")
    return shared, [x for x in clips[0].bones if x in subset]


def _warp_bones(clips, shared, idx):
    """The bones the alignment is computed on: every shared bone that moves in at least one clip."""
    still = np.ones(len(shared), dtype=bool)
    for c, ix in zip(clips, idx):
        still &= still_joints(c.rotations[:, [ix[x] for x in shared]])
    return [x for x, s in zip(shared, still) if not s] or list(shared)


def _blend_translation(plan, clips, idx, blended, Bg, start, root, up_axis):
    """(root translation of the blend, root mode used, up axis or None): the reference's path in the blended
    timing, or with ``root="blend"`` (every clip moves its root, the reference's root is shared) the blended
    path of ``blend_root_path`` with the timing weights."""
    a = clips[0]
    translation = None
    if a.root_translation is not None:
        translation = interp_rows(plan.u_out, plan.times0, a.root_translation)
    roots = [c.root_bone if c.root_bone in ix else None for c, ix in zip(clips, idx)]
    # across rigs the paths must be of one kind (rigs.hips_path: the hips in leg lengths), else A's path alone
    one_kind = len({c.meta.get("root_path") for c in clips}) == 1
    if not (root == "blend" and one_kind and all(c.root_translation is not None for c in clips)
            and all(r is not None for r in roots)):
        return translation, "a", None
    rots = [plan.r_on_grid(i, c.rotations[:, [idx[i][r]]])[:, 0] for i, (c, r) in enumerate(zip(clips, roots))]
    if roots[0] in blended:
        rotb = Bg[:, blended.index(roots[0])] @ start[blended.index(roots[0])]
    else:
        rotb = rots[0]
    up = root_up(clips, up_axis)
    path = blend_root_path(plan, [c.root_translation for c in clips], rots, rotb, up, plan.weights)
    return interp_rows(plan.u_out, plan.grid, path), "blend", up


def blend_clip_series(a, b, weights, align=True, depth=DEFAULT_DEPTH, frames=None, bones=None, root="blend", *,
                      up_axis=None, penalty=0.0, progress=None, time_base=True, mask=None, groups=None):
    """``blend_clips`` at several weights with one warp (computed once). ``progress(done, total)``
    (``core.progress``) is called after each blend; returning True raises Cancelled. Returns a list of Clips."""
    weights = [check_number(x, "weight", 0.0, 1.0) for x in weights]
    if not weights:
        raise ShapeSigError("weights: at least one weight is needed")
    kw = dict(up_axis=up_axis, penalty=penalty, mask=mask, groups=groups)
    first = blend_clips(a, b, weights[0], align, depth, frames, bones, root, time_base=time_base, **kw)
    out = [first]
    check_progress(progress, 1, len(weights))
    warp = first.meta["warp"]
    for i, x in enumerate(weights[1:], start=2):
        c = blend_clips(a, b, x, align, depth, frames, bones, root, warp=warp, **kw)
        c.meta["elastic_distance"] = first.meta["elastic_distance"]
        c.meta["elastic_distances"] = first.meta["elastic_distances"]
        c.meta["aligned"] = first.meta["aligned"]
        out.append(c)
        check_progress(progress, i, len(weights))
    return out
