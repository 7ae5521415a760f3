"""The comparison time base: ``prepare_rotations`` / ``prepare_clip`` low-pass a curve's angular velocity in the Lie
algebra (a Gaussian of ``SMOOTH_SECONDS``) and sample it at ``COMPARE_FPS`` over its duration, so a comparison
does not depend on the rate a clip was captured at. Durations are kept. See docs/model.md, "Time base".
"""

from dataclasses import replace

import numpy as np

from ..geometry import so3
from ..geometry.curves import as_curve, geodesic_interpolate
from ..errors import ShapeSigError, check_number

__all__ = ["COMPARE_FPS", "SMOOTH_SECONDS", "SIGNATURE_SMOOTH_SECONDS", "smooth_increments", "lattice_frames", "lattice_cut", "resample_seconds", "prepare_rotations",
           "prepare_clip", "decimate_clip", "retime", "check_fps"]

COMPARE_FPS = 30.0
SMOOTH_SECONDS = 0.05  # the SRVT measures and the blends' alignment
SIGNATURE_SMOOTH_SECONDS = 0.0  # the signature measures: the common rate only
# frame rates a clip may plausibly have (BVH Frame Time, an action's scene, --fps)
MIN_FPS, MAX_FPS = 1.0, 1000.0
_EPS = 1e-9  # (frames - 1) / fps * target is a whole number up to rounding: 4 k / 120 * 30 = k


def check_fps(fps, what="frame rate"):
    """``fps`` as a float, ShapeSigError when it is not a plausible rate (1 to 1000 frames per second)."""
    value = check_number(fps, what, 0.0)
    if not MIN_FPS <= value <= MAX_FPS:
        raise ShapeSigError(f"{what} {value:g} is not a plausible frame rate ({MIN_FPS:g} to {MAX_FPS:g} fps)")
    return value


def _gaussian(sigma_frames):
    radius = max(1, int(np.ceil(4.0 * sigma_frames)))
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    w = np.exp(-0.5 * (x / sigma_frames) ** 2)
    return w / w.sum(), radius


def smooth_increments(steps, fps, seconds=SMOOTH_SECONDS):
    """The increments ``steps`` (intervals, joints, 3) low-passed by a Gaussian of ``seconds`` (std) applied to
    the angular velocity (steps * fps), reflected at both ends. ``seconds <= 0`` or one interval: unchanged."""
    steps = np.asarray(steps, dtype=np.float64)
    sigma = float(seconds) * float(fps)
    n = steps.shape[0]
    if sigma <= 0.0 or n < 2:
        return steps.copy()
    w, r = _gaussian(sigma)
    idx = np.arange(-r, n + r)
    # reflect about the ends (…, 1, 0 | 0, 1, …, n-1 | n-1, n-2, …), repeatedly for kernels wider than the clip
    period = 2 * n
    idx = np.mod(idx, period)
    idx = np.where(idx >= n, period - 1 - idx, idx)
    padded = steps[idx]
    out = np.zeros_like(steps)
    for k, wk in enumerate(w):
        out += wk * padded[k:k + n]
    return out


def lattice_frames(frames, fps, target_fps):
    """J + 1, the number of comparison samples t_j = j / ``target_fps`` (j = 0..J) within a clip of ``frames``
    frames at ``fps``: J = floor(D target_fps), D = (frames - 1) / fps (at least one interval, J >= 1, when the
    clip has two frames or more)."""
    if frames < 2:
        return frames
    return max(1, int(np.floor((frames - 1) / float(fps) * float(target_fps) + _EPS))) + 1


def lattice_cut(frames, fps, target_fps):
    """How many leading frames of the clip hold the lattice: frames 0..ceil(t_J fps), the first frame at or after
    the last lattice time t_J (every frame when the clip is shorter than one lattice step)."""
    if frames < 2:
        return frames
    t_last = (lattice_frames(frames, fps, target_fps) - 1) / float(target_fps)
    return min(frames, int(np.ceil(t_last * float(fps) - _EPS)) + 1)


def resample_seconds(R, fps, target_fps, keep_end=True):
    """The piecewise-geodesic curve R (sampled at ``fps``) at ``target_fps``.

    ``keep_end`` (the warps of the blends, which map normalized times): over the whole duration D, the last
    sample the last frame, the grid step adjusted to D / round(D target_fps). False (the comparisons): on the
    lattice t_j = j / target_fps, j = 0..J, anchored at the first frame, the remainder D - t_J (less than one
    step) dropped; see the module docstring."""
    R = as_curve(R)
    n = R.shape[0]
    if n < 2 or float(fps) == float(target_fps):
        return R
    duration = (n - 1) / float(fps)
    if keep_end:
        m = max(2, int(round(duration * float(target_fps))) + 1)
        return geodesic_interpolate(R, None, np.linspace(0.0, 1.0, m))
    m = lattice_frames(n, fps, target_fps)
    u = np.minimum(np.arange(m) / float(target_fps) / duration, 1.0)  # shorter than one step: its two ends
    return geodesic_interpolate(R, None, u)


def prepare_rotations(R, fps, target_fps=COMPARE_FPS, smooth=SMOOTH_SECONDS, keep_end=True):
    """The curve R (at ``fps``) low-passed in the Lie algebra (``smooth`` seconds) and sampled at ``target_fps``
    (None: keep the rate). ``keep_end`` False: the comparison lattice (the clip is first cut at the frame that
    closes the last lattice interval, so that the low-pass reflects at the same time on every copy of a
    motion). See the module docstring."""
    R = as_curve(R)
    fps = check_fps(fps)
    target = None if target_fps is None else check_fps(target_fps, "target frame rate")
    if target is not None and not keep_end:
        R = R[:lattice_cut(R.shape[0], fps, target)]
    if R.shape[0] >= 3 and smooth and smooth > 0:
        steps = smooth_increments(so3.relative_rotvecs(R), fps, smooth)
        R = so3.integrate(steps, R[0])
    if target is None:
        return R
    return resample_seconds(R, fps, target, keep_end)


def prepare_clip(clip, target_fps=COMPARE_FPS, smooth=SMOOTH_SECONDS, keep_end=False):
    """A clip prepared for comparison (``prepare_rotations``; by default on the comparison lattice, the remainder
    of less than one step dropped), with its root path interpolated linearly at the same times and ``fps`` set
    to the new rate; ``meta["prepared"]`` records (target_fps, smooth)."""
    fps = check_fps(clip.fps)
    target = fps if target_fps is None else check_fps(target_fps, "target frame rate")
    if (not smooth or smooth <= 0) and target == fps:
        return clip
    R = prepare_rotations(clip.rotations, fps, target, smooth, keep_end)
    root = clip.root_translation
    if root is not None and R.shape[0] != clip.frames:
        x = np.arange(clip.frames) / fps
        if keep_end or R.shape[0] < 2:
            xn = np.linspace(0.0, x[-1], R.shape[0])
        else:
            xn = np.minimum(np.arange(R.shape[0]) / target, x[-1])
        root = np.stack([np.interp(xn, x, root[:, i]) for i in range(3)], axis=1)
    meta = dict(clip.meta, prepared=(target, float(smooth or 0.0)))
    return replace(clip, rotations=R, root_translation=root, fps=target, meta=meta)


def decimate_clip(clip, step):
    """Every ``step``-th frame of a clip (from the first), at ``fps / step``: the same motion at a lower rate
    (what the mixed-rate evaluation and the decimation tests compare)."""
    step = int(step)
    if step < 1:
        raise ShapeSigError(f"decimation step must be 1 or more, got {step}")
    if step == 1:
        return clip
    root = None if clip.root_translation is None else clip.root_translation[::step]
    return replace(clip, rotations=clip.rotations[::step], root_translation=root, fps=clip.fps / step,
                   meta=dict(clip.meta, decimated=step))


def retime(clip, fps):
    """The same motion keyed at ``fps``: rotations along the SO(3)^d geodesics between frames, the root path
    linearly, the duration kept (the last sample on the last frame; ``resample_seconds`` with ``keep_end``), the
    first frame number kept. What is written onto an armature plays at its true speed in a scene of that rate;
    ``meta["source_fps"]`` records the rate it had. The clip itself when the rates agree (1e-9)."""
    target = check_fps(fps, "scene frame rate")
    if abs(float(clip.fps) - target) <= 1e-9 * target or clip.frames < 2:
        return clip
    R = resample_seconds(clip.rotations, check_fps(clip.fps), target, keep_end=True)
    root = clip.root_translation
    if root is not None:
        x, xn = np.linspace(0.0, 1.0, clip.frames), np.linspace(0.0, 1.0, R.shape[0])
        root = np.stack([np.interp(xn, x, root[:, i]) for i in range(3)], axis=1)
    meta = dict(clip.meta, source_fps=float(clip.meta.get("source_fps", clip.fps)))
    return replace(clip, rotations=R, root_translation=root, fps=target, meta=meta)
