"""Choose what of each source is blended: frame ranges (``crop_range``), one cycle of a periodic motion by the
self-similarity of the curve (``find_cycle``, ``one_cycle``; a clip that already is one cycle, ``closed_cycle``, is
its own), the same cycle of another version of a clip (``apply_cycle``) and seamless loops (``close_loop``: the
residual spread over the cycle, the seam eased and turned to the quietest step). See docs/blending.md, "Ranges and
loops".
"""

import numpy as np

from ..geometry import so3
from ..clip.clip import Clip
from ..clip.skeleton import root_up
from ..errors import ShapeSigError, check_frame_range
from ..clip.prepare import COMPARE_FPS, prepare_rotations

# the loop's seam is eased over this window (seconds each side; see _ease_seam)
SEAM_SMOOTH = 0.025
# the cycles find_cycle looks for (seconds)
MIN_CYCLE, MAX_CYCLE = 0.4, 2.5
# a clip is one cycle when its last pose is back at its first (or one step before it, at the speed it ends with)
# within this share of its largest pose excursion from the first; measured on real clips (docs/blending.md): cycles
# cut from CMU takes 0.10-0.24, loops made by Mixamo and glTF exporters 0.00-0.05, other cuts 0.54 and more
CLOSED_GAP = 0.35

__all__ = ["parse_range", "crop_range", "find_cycle", "one_cycle", "closed_cycle", "apply_cycle", "close_loop",
           "pose_steps", "MIN_CYCLE", "MAX_CYCLE", "CLOSED_GAP"]


def parse_range(text, label="range"):
    """``"S:E"`` -> (S, E) integers, E after S (frames, inclusive; ``errors.check_frame_range``); None for
    None/empty."""
    if text is None or (isinstance(text, str) and not text.strip()):
        return None
    if isinstance(text, (tuple, list)):
        parts = list(text)
    else:
        parts = str(text).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        s, e = (int(str(x).strip()) for x in parts)
    except ValueError:
        raise ShapeSigError(f"{label}: expected START:END frame numbers, got {text!r}") from None
    return check_frame_range(s, e, what=label)


def crop_range(clip: Clip, rng, label="range") -> Clip:
    """The clip cropped to frames S..E of its own numbering (inclusive); ShapeSigError when the range is not
    inside the clip."""
    rng = parse_range(rng, label)
    if rng is None:
        return clip
    s, e = check_frame_range(*rng, clip.frame_start, clip.frame_end, f"{label} of {clip.name!r}")
    out = clip.crop(s, e)
    out.meta = dict(out.meta, range=(s, e))
    return out


def _pose_bones(clip, bones=None):
    """Indices of the moving bones (of ``bones`` when given) other than the root."""
    still = set(clip.still_bones())
    names = [b for b in (bones or clip.bones) if b not in still and b != clip.root_bone]
    names = names or [b for b in (bones or clip.bones) if b != clip.root_bone] or list(clip.bones)
    return [clip.bones.index(b) for b in names]


def _pose_distance(A, B):
    """Mean squared rotation angle between pose arrays A and B (..., joints, 3, 3) over the joints."""
    return np.mean(np.sum(so3.log(A @ np.swapaxes(B, -1, -2)) ** 2, axis=-1), axis=-1)


def _self_distance(R, lags):
    return np.array([_pose_distance(R[lag:], R[:-lag]).mean() for lag in lags])


def _rms_angle(xi):
    """Root mean square over the joints of rotation vectors (..., joints, 3): radians."""
    return np.sqrt(np.mean(np.sum(np.asarray(xi) ** 2, axis=-1), axis=-1))


def _duration(clip):
    return (clip.frames - 1) / float(clip.fps)


def find_cycle(clip: Clip, min_seconds=MIN_CYCLE, max_seconds=MAX_CYCLE):
    """The period of a cyclic clip: ``{"period": frames, "seconds": s, "score": D(period) / median D}`` (score
    near 0: clearly periodic). ShapeSigError when the clip is too short or shows no cycle. See the module
    docstring."""
    fps = float(clip.fps)
    cols = _pose_bones(clip)
    R = prepare_rotations(clip.rotations[:, cols], fps)
    rate = COMPARE_FPS
    hi = min(int(max_seconds * rate), R.shape[0] - max(3, int(0.25 * rate)))
    lo = max(2, int(min_seconds * rate))
    if hi <= lo + 2:
        raise ShapeSigError(f"clip {clip.name!r} lasts {_duration(clip):.2f} s: too short to find a repeating "
                            f"stride in it (one of {min_seconds:g} s or more needs a longer clip)")
    lags = np.arange(lo, hi + 1)
    D = _self_distance(R, lags)
    minima = [i for i in range(1, len(D) - 1) if D[i] <= D[i - 1] and D[i] <= D[i + 1]]
    med = float(np.median(D))
    if not minima or med <= 0:
        raise ShapeSigError(f"clip {clip.name!r} does not repeat: no stride of {min_seconds:g} to "
                            f"{max_seconds:g} s found in it")
    deepest = min(D[i] for i in minima)
    pick = next(i for i in minima if med - D[i] >= 0.6 * (med - deepest))
    score = float(D[pick] / med)
    if score > 0.5:
        raise ShapeSigError(f"clip {clip.name!r} does not clearly repeat: its closest repeat of a stride differs "
                            f"by {score:.0%} of a typical pose change")
    # refine on the clip's own frames
    Rc = clip.rotations[:, cols]
    guess = int(round(lags[pick] / rate * fps))
    near = [p for p in range(guess - int(np.ceil(fps / rate)), guess + int(np.ceil(fps / rate)) + 1)
            if 2 <= p < clip.frames - 1]
    period = near[int(np.argmin(_self_distance(Rc, near)))] if near else guess
    return {"period": int(period), "seconds": period / fps, "score": score}


def closed_cycle(clip: Clip):
    """``{"wrap": bool, "gap": share}`` when the clip already is one cycle, else None. Its last pose is back at its
    first (``wrap`` False: the last frame repeats the first) or one step before it (``wrap`` True: the first frame
    follows the last), within ``CLOSED_GAP`` of its largest pose excursion from the first after allowing one frame's
    motion at the speed of its ends (``gap``: that share); and it keeps moving across the seam (the end's velocity
    carried one frame on lands within twice that share of its first or second pose). Loops made by exporters
    (Mixamo, glTF) and strides cut out of a take pass; a part of a stride or a stride and a half does not."""
    if clip.frames < 4:
        return None
    cols = _pose_bones(clip)
    R = clip.rotations[:, cols]
    Rt = np.swapaxes(R, -1, -2)
    spread = float(_rms_angle(so3.log(R @ Rt[0][None])).max())
    if not spread > 0:
        return None  # a held pose: nothing to loop
    gap = float(_rms_angle(so3.log(R[-1] @ Rt[0])))
    steps = pose_steps(R)
    share = max(gap - 0.5 * (steps[0] + steps[-1]), 0.0) / spread
    ahead = (R[-1] @ Rt[-2]) @ R[-1]  # one frame on at the end's velocity
    wrap, repeat = (float(_rms_angle(so3.log(ahead @ Rt[k]))) / spread for k in (0, 1))
    if share > CLOSED_GAP or min(wrap, repeat) > 2 * CLOSED_GAP:
        return None
    return {"wrap": bool(wrap < repeat and gap > 0.25 * steps[-1]), "gap": share}


def _turn(clip: Clip, wrap: bool, shift: int) -> Clip:
    """A clip that is one cycle as frames 0..M with frame M the first again (``wrap``: the first frame appended,
    the root one step on at the end's velocity), the residual spread over the cycle (``close_loop``'s closure), and
    turned to start at its frame ``shift``."""
    R, rt = clip.rotations, clip.root_translation
    if wrap:
        R = np.concatenate([R, R[:1]])
        if rt is not None:
            rt = np.concatenate([rt, rt[-1:] + (rt[-1:] - rt[-2:-1])])
    M = R.shape[0] - 1
    s = np.arange(M + 1) / M
    R = so3.exp(-s[:, None, None] * so3.log(R[-1] @ np.swapaxes(R[0], -1, -2))[None]) @ R
    idx = (shift + np.arange(M + 1)) % M
    R = R[idx]
    if rt is not None:
        offset = rt[-1] - rt[0]
        rt = rt[:M][idx] + np.outer((shift + np.arange(M + 1)) // M, offset)
    return Clip(name=clip.name, bones=clip.bones, rotations=R, fps=clip.fps, frame_start=clip.frame_start,
                root_translation=rt, root_bone=clip.root_bone, rotation_modes=clip.rotation_modes,
                source=clip.source, meta=dict(clip.meta))


def apply_cycle(clip: Clip, cycle: dict) -> Clip:
    """The cycle ``one_cycle`` found (its ``meta["cycle"]``) taken from ``clip``, a version of the same frames (the
    source on its own rig when the cycle was found on the mapped one)."""
    if cycle.get("whole"):
        out = _turn(clip, cycle["wrap"], cycle["shift"])
    else:
        out = clip.crop(cycle["start"], cycle["end"])
    out.meta = dict(out.meta, cycle=dict(cycle))
    return out


def one_cycle(clip: Clip, like: Clip = None, period=None) -> Clip:
    """The clip cropped to one cycle, frames s..s+P inclusive (``find_cycle``'s period P unless given): the
    window whose end pose is closest to its start pose, plus, with ``like``, the distance of its start pose to
    ``like``'s first pose (on the bones both share) so that clips start at the same phase. A clip that already is
    one cycle (``closed_cycle``) and holds less than two of the periods ``find_cycle`` sees, is its own cycle, closed
    and turned to start at ``like``'s phase (``apply_cycle``). ``meta["cycle"]`` records start, end, period and
    score (and for a whole clip ``whole``, ``wrap`` and ``shift``)."""
    if period:
        found = {"period": int(period), "score": None}
    else:
        closed = closed_cycle(clip)
        try:
            found = find_cycle(clip)
        except ShapeSigError as exc:
            if closed is None and _duration(clip) < MIN_CYCLE:
                raise ShapeSigError(f"clip {clip.name!r} lasts {_duration(clip):.2f} s: too short to loop (a loop "
                                    f"needs a stride of {MIN_CYCLE:g} s or more)") from None
            if closed is None:
                raise ShapeSigError(f"{exc}; nor does it end where it starts, so it cannot loop as it is "
                                    f"(a loop needs one stride or more of a repeating motion)") from None
            found = None
        if closed is not None and (found is None or clip.frames - 1 < 2 * found["period"]):
            return _whole_cycle(clip, closed, like)
    P = found["period"]
    if P >= clip.frames:
        raise ShapeSigError(f"clip {clip.name!r}: a cycle of {P} frames does not fit in its {clip.frames} frames")
    cols = _pose_bones(clip)
    R = clip.rotations[:, cols]
    cost = _pose_distance(R[P:], R[:-P])
    if like is not None:
        cost = cost + _like_cost(clip, like, clip.rotations[:-P])
    s = int(np.argmin(cost)) + clip.frame_start
    out = clip.crop(s, s + P)
    out.meta = dict(out.meta, cycle={"start": s, "end": s + P, "period": P, "score": found.get("score")})
    return out


def _like_cost(clip, like, rotations):
    """Per frame of ``rotations`` (``clip``'s bones), the pose distance to ``like``'s first pose on shared bones."""
    shared = [b for b in like.bones if b in clip.bones]
    ci = _pose_bones(clip, shared)
    li = [like.bones.index(clip.bones[i]) for i in ci]
    return _pose_distance(rotations[:, ci], like.rotations[0, li][None])


def _whole_cycle(clip, closed, like):
    """The whole clip as its cycle (``closed_cycle``), at ``like``'s phase when given."""
    wrap = closed["wrap"]
    M = clip.frames if wrap else clip.frames - 1
    shift = 0
    if like is not None:
        shift = int(np.argmin(_like_cost(clip, like, _turn(clip, wrap, 0).rotations[:M])))
    info = {"start": clip.frame_start, "end": clip.frame_end, "period": int(M), "score": None, "whole": True,
            "wrap": wrap, "shift": shift, "gap": closed["gap"]}
    return apply_cycle(clip, info)


def close_loop(clip: Clip) -> Clip:
    """The clip (one cycle: its last frame is meant to repeat its first) closed into a seamless loop: see the
    module docstring. ``meta["loop"]``: the distinct frames M, the root's offset per cycle and the residual
    angle (degrees) spread over the cycle."""
    M = clip.frames - 1
    if M < 2:
        raise ShapeSigError(f"clip {clip.name!r}: a loop needs at least three frames")
    R = clip.rotations
    C = so3.log(R[-1] @ np.swapaxes(R[0], -1, -2))  # (joints, 3)
    s = np.arange(M + 1) / M
    out = so3.exp(-s[:, None, None] * C[None]) @ R
    out[:M] = _ease_seam(out[:M], clip.fps)
    out[-1] = out[0]
    rt = clip.root_translation
    offset = None
    if rt is not None:
        up = root_up([clip])
        dh = (rt[-1] - rt[0]) @ up
        rt = rt - np.outer(s * dh, up)
        offset = rt[-1] - rt[0]
    # the seam where the motion is quietest: the cycle turned to start after its smallest step
    seam = (int(np.argmin(pose_steps(out))) + 1) % M
    if seam:
        out = np.concatenate([out[seam:M], out[:seam + 1]])
        if rt is not None:
            rt = np.concatenate([rt[seam:M], rt[:seam + 1] + offset])
    meta = dict(clip.meta, loop={"frames": int(M), "offset": None if offset is None else [float(x) for x in offset],
                                 "closure_degrees": float(np.degrees(np.linalg.norm(C, axis=-1).max())),
                                 "seam": seam})
    return Clip(name=clip.name, bones=clip.bones, rotations=out, fps=clip.fps, frame_start=clip.frame_start,
                root_translation=rt, root_bone=clip.root_bone, rotation_modes=clip.rotation_modes,
                source=clip.source, meta=meta)


def _ease_seam(R, fps):
    """The cycle's M poses (periodic: M-1 is followed by 0) with the seam eased: each pose moved towards the
    circular mean of its neighbours within SEAM_SMOOTH seconds (``exp(mean_j log(R[k+j] R[k]^T)) R[k]``), fully
    at the seam, fading linearly to nothing 3 SEAM_SMOOTH away. Capture noise then makes the step M-1 -> 0 no
    rougher than the cycle's typical step; the rest of the cycle is untouched."""
    M = len(R)
    h = max(1, int(round(SEAM_SMOOTH * fps)))
    if M < 6 * h + 2:
        return R
    k = np.arange(M)
    d = np.minimum(k + 0.5, M - 0.5 - k) - 0.5  # frames from the seam (0 for frames 0 and M-1)
    alpha = np.clip(1.0 - (d - h) / (2.0 * h), 0.0, 1.0)
    near = np.flatnonzero(alpha > 0)
    Rt = np.swapaxes(R[near], -1, -2)
    xi = sum(so3.log(R[(near + j) % M] @ Rt) for j in range(-h, h + 1)) / (2 * h + 1)
    out = R.copy()
    out[near] = so3.exp(alpha[near, None, None] * xi) @ R[near]
    return out


def pose_steps(rotations):
    """Per frame step k -> k+1, the root mean square rotation angle over the joints (radians)."""
    R = np.asarray(rotations)
    return np.sqrt(_pose_distance(R[1:], R[:-1]))
