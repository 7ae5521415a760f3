"""Planted feet in generated frames (``plant_gap``): where a foot's heel is down (within CONTACT_HEIGHT of the
lowest it is over the known frames on both sides and the gap) during the gap, it is held where it came down — on
the last known frame's spot when it was down there, and easing onto the target's spot when it is down there — by
the two-bone leg IK of ``feet`` (the foot keeps its rotation); the corrections fade in and out over RAMP and are
zero at both seams. With ``steps``, a heel that would slide over the floor to a target spot more than STEP away
(still at the last known frame and down at the target, or coming down inside the gap that far from it) steps
instead: held, then swung over the gap's middle (lifted up to STEP_LIFT) onto the target's spot; one leg, and only
when the swing can last MIN_SWING. See docs/transitions.md, "Planted feet".
"""

import numpy as np

from ..clip.skeleton import forward_kinematics, rest_of, unit_meters, up_vector
from ..errors import ShapeSigError

__all__ = ["plant_gap", "CONTACT_HEIGHT"]

CONTACT_HEIGHT = 0.025 # m above the heel's lowest
RAMP = 0.1             # s
STEP = 0.05            # m: heels down at both seams further apart than this step instead of sliding
STEP_LIFT = 0.08       # m: the highest a stepping heel is lifted (at most a quarter of the step's length)
SWING_MARGIN = 0.15    # share of the gap at each end where a stepping foot is still held
MIN_SWING = 0.2        # s: no step swings faster (a sprinter's swing); a shorter gap eases the heel over
UPRIGHT = 0.45         # a leg is standing from this height of the hip above the heel (times the leg) + 0.15


def _smooth(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _steps(legs, heads, up, unit, fps, first, last):
    """{side: (start, end, lift)} for the leg whose heel is down at the target on a spot more than STEP from where
    it is at the last known frame and from where it comes down (down and still at both seams, or coming down inside
    the gap that far away; of two such legs the one with the longer way: the gap is too short for two steps): the
    frames (fractional) over which the foot swings from the last known spot to the target's, and its lift (the
    rig's units)."""
    from .feet import CONTACT_SPEED, _runs

    span = last + 2 - first  # from the last known frame to the target
    if (1.0 - 2.0 * SWING_MARGIN) * span / fps < MIN_SWING:
        return {}
    found = []
    for side, leg in legs.items():
        heel = heads[:, leg[2]]
        h = (heel @ up) * unit
        runs = [(a, b) for a, b in _runs(h < h.min() + CONTACT_HEIGHT) if a <= last + 1 <= b]
        if not runs:
            continue
        a = runs[0][0]
        start = heel[first - 1] if a < first else heel[a]
        move = heel[last + 1] - start
        move -= (move @ up) * up
        still = True
        if a < first and first >= 2:  # down at the last known frame: a heel still there (feet.CONTACT_SPEED), or
            v = heel[first - 1] - heel[first - 2]  # one the ease would carry faster than that, steps
            still = (np.linalg.norm(v - (v @ up) * up) * unit * fps <= CONTACT_SPEED
                     or np.linalg.norm(move) * unit * fps / (last + 2 - first) > CONTACT_SPEED)
        if still and np.linalg.norm(move) * unit > STEP:
            reach = heel[last + 1] - heel[first - 1]
            reach -= (reach @ up) * up
            lift = min(STEP_LIFT / unit, 0.25 * float(np.linalg.norm(reach)))
            found.append((float(np.linalg.norm(move)), side, lift))
    if not found:
        return {}
    margin = SWING_MARGIN * span
    _d, side, lift = max(found)
    return {side: (first - 1 + margin, last + 1 - margin, lift)}


def plant_gap(rig, X, root, first, last, steps=True):
    """X (frames, bones, 3, 3) aligned rotations, ``root`` (frames, 3) heads of a sequence on ``rig``'s skeleton
    whose frames ``first``..``last`` (inclusive) are generated (the others known); returns X with the legs of
    the generated frames solved so the planted heels stay put (module docstring). Unchanged without legs."""
    from .feet import _ik_leg, _runs, legs_of

    try:
        legs = legs_of(rig)
    except ShapeSigError:
        return X
    rest = rest_of(rig)
    heads, _tails, W = forward_kinematics(rig, rest, X, root)
    up = up_vector(rig)
    unit = unit_meters(rig, [(t, f) for t, _s, f in legs.values()])
    X = X.copy()
    n = len(X)
    ramp = max(RAMP * rig.fps, 1.0)
    frames = np.arange(n)
    steps = _steps(legs, heads, up, unit, rig.fps, first, last) if steps else {}
    for side, leg in legs.items():
        heel = heads[:, leg[2]]
        h = (heel @ up) * unit
        length = (np.linalg.norm(rest.heads[leg[1]] - rest.heads[leg[0]])
                  + np.linalg.norm(rest.heads[leg[2]] - rest.heads[leg[1]]))
        # only a leg standing on its foot (the hip at least UPRIGHT of the leg above the heel): not one lying,
        # kneeling or kicking, where holding the heel would throw the leg
        upright = _smooth(((heads[:, leg[0]] - heel) @ up / max(length, 1e-12) - UPRIGHT) / 0.15)
        down = h < h.min() + CONTACT_HEIGHT
        target = heel.copy()
        total = np.zeros(n)
        acc = np.zeros((n, 3))
        fade_in, fade_out = _smooth((frames - (first - 1)) / ramp), _smooth(((last + 1) - frames) / ramp)
        for a, b in _runs(down):
            lo, hi = max(a, first), min(b, last)
            if lo > hi:
                continue
            # held at the last known spot (a run crossing the first seam) or where it comes down; eased onto the
            # target's spot when the run crosses the last seam: no correction at either seam
            lift = 0.0
            if b > last and side in steps:  # down at the target far from where it was: a step, not a slide
                a = lo = first
                s0, s1, lift = steps[side]
            pin_a = heel[first - 1] if a < first or lift else heel[lo]
            pin_b = heel[last + 1] if b > last else pin_a
            if not lift:
                s0, s1 = (first - 1 if a < first else lo), (last + 1 if b > last else hi)
            s = np.clip((frames - s0) / max(s1 - s0, 1), 0.0, 1.0)
            pin = pin_a[None] + _smooth(s)[:, None] * (pin_b - pin_a)[None]
            off = pin - heel
            off -= np.outer(off @ up, up)  # held on the ground plane; the height stays the motion's
            off += np.outer(lift * np.sin(np.pi * s) ** 2, up)
            dist = np.maximum(np.maximum(lo - frames, frames - hi), 0)
            # a run crossing a seam has no offset there; one starting or ending inside the gap fades before it
            seam = (1.0 if a < first or lift else fade_in) * (1.0 if b > last else fade_out)
            w = _smooth(1.0 - dist / ramp) * seam * upright
            acc += w[:, None] * off[np.clip(frames, lo, hi)]
            total += w
        w = np.minimum(total, 1.0)
        w[:first] = 0.0
        w[last + 1:] = 0.0
        if not w.any():
            continue
        target = heel + acc / np.maximum(total, 1e-12)[:, None] * w[:, None]
        k = np.flatnonzero(w > 0)
        Xk, Wk, Hk = X[k], W[k], heads[k]
        _ik_leg(Xk, Wk, Hk, rest, leg, target[k])
        X[k] = Xk
    return X
