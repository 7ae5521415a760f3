"""Choose what of each source is blended: frame ranges (``crop_range``), one cycle of a periodic motion by the
self-similarity of the curve (``find_cycle``, ``one_cycle``) and seamless loops (``close_loop``: the residual spread
over the cycle, the seam eased and turned to the quietest step). See docs/blending.md, "Ranges and loops".
"""

import numpy as np

from ..geometry import so3
from ..clip.clip import Clip
from ..clip.skeleton import root_up
from ..errors import ShapeSigError, check_frame_range
from ..clip.prepare import COMPARE_FPS, prepare_rotations

# the loop's seam is eased over this window (seconds each side; see _ease_seam)
SEAM_SMOOTH = 0.025

__all__ = ["parse_range", "crop_range", "find_cycle", "one_cycle", "close_loop", "pose_steps"]


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


def find_cycle(clip: Clip, min_seconds=0.4, max_seconds=2.5):
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
        raise ShapeSigError(f"clip {clip.name!r} is too short to find a cycle "
                            f"({(clip.frames - 1) / fps:.2f} s; a cycle of {min_seconds:g} s or more needs more)")
    lags = np.arange(lo, hi + 1)
    D = _self_distance(R, lags)
    minima = [i for i in range(1, len(D) - 1) if D[i] <= D[i - 1] and D[i] <= D[i + 1]]
    med = float(np.median(D))
    if not minima or med <= 0:
        raise ShapeSigError(f"clip {clip.name!r} shows no cycle between {min_seconds:g} and {max_seconds:g} s")
    deepest = min(D[i] for i in minima)
    pick = next(i for i in minima if med - D[i] >= 0.6 * (med - deepest))
    score = float(D[pick] / med)
    if score > 0.5:
        raise ShapeSigError(f"clip {clip.name!r} shows no clear cycle (best self-distance {score:.2f} of the median)")
    # refine on the clip's own frames
    Rc = clip.rotations[:, cols]
    guess = int(round(lags[pick] / rate * fps))
    near = [p for p in range(guess - int(np.ceil(fps / rate)), guess + int(np.ceil(fps / rate)) + 1)
            if 2 <= p < clip.frames - 1]
    period = near[int(np.argmin(_self_distance(Rc, near)))] if near else guess
    return {"period": int(period), "seconds": period / fps, "score": score}


def one_cycle(clip: Clip, like: Clip = None, period=None) -> Clip:
    """The clip cropped to one cycle, frames s..s+P inclusive (``find_cycle``'s period P unless given): the
    window whose end pose is closest to its start pose, plus, with ``like``, the distance of its start pose to
    ``like``'s first pose (on the bones both share) so that clips start at the same phase.
    ``meta["cycle"]`` records start, end, period and score."""
    found = {"period": int(period), "score": None} if period else find_cycle(clip)
    P = found["period"]
    if P >= clip.frames:
        raise ShapeSigError(f"clip {clip.name!r}: a cycle of {P} frames does not fit in its {clip.frames} frames")
    cols = _pose_bones(clip)
    R = clip.rotations[:, cols]
    cost = _pose_distance(R[P:], R[:-P])
    if like is not None:
        shared = [b for b in like.bones if b in clip.bones]
        ci = _pose_bones(clip, shared)
        li = [like.bones.index(clip.bones[i]) for i in ci]
        cost = cost + _pose_distance(clip.rotations[:-P][:, ci], like.rotations[0, li][None])
    s = int(np.argmin(cost)) + clip.frame_start
    out = clip.crop(s, s + P)
    out.meta = dict(out.meta, cycle={"start": s, "end": s + P, "period": P, "score": found.get("score")})
    return out


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
