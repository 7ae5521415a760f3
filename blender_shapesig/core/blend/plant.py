"""Planted feet in generated frames (``plant_gap``): where a foot's heel is down (within CONTACT_HEIGHT of the
lowest it is over the known frames on both sides and the gap) during the gap, it is held where it came down — on
the last known frame's spot when it was down there, and easing onto the target's spot when it is down there — and
no lower than the known frames where it is down (the floor), by the two-bone leg IK of ``feet``; the foot keeps
its rotation. With ``steps`` (the geodesic's frames), a foot whose heel and ball are down and still at the last
known frame and stay down is turned about the held heel so the ball stays too, and a foot the gap drags over the
floor (its heel or ball moving more than STEP on the ground while down) steps instead: its heel held on the last
known spot, swung over the gap's middle (lifted up to STEP_LIFT) onto the target's spot; one leg, and only when
the swing can last MIN_SWING. The corrections fade in and out over RAMP and are zero at both seams. See
docs/transitions.md, "Planted feet"."""

import numpy as np

from ..clip.skeleton import forward_kinematics, rest_of, unit_meters, up_vector
from ..errors import ShapeSigError
from ..geometry import so3

__all__ = ["plant_gap", "CONTACT_HEIGHT"]

CONTACT_HEIGHT = 0.025 # m above the heel's lowest
RAMP = 0.1             # s
STEP = 0.05            # m: a foot dragged further than this over the floor steps instead
STEP_LIFT = 0.08       # m: the highest a stepping heel is lifted (at most a quarter of the step's length)
SWING_MARGIN = 0.15    # share of the gap at each end where a stepping foot is still held
MIN_SWING = 0.2        # s: no step swings faster (a sprinter's swing); a shorter gap eases the heel over
STILL_BALL = 0.2       # m/s: a ball slower than this at the last known frame is planted (not rolling or pivoting)
UPRIGHT = 0.45         # a leg is standing from this height of the hip above the heel (times the leg) + 0.15


def _smooth(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _drag(points, up, unit, first, last):
    """The longest way (rig units) a foot point moves on the ground while it stays down (within CONTACT_HEIGHT of
    its lowest over the sequence) from the last known frame to the target, and whether it is down at the last
    known frame."""
    from .contacts import _runs

    h = (points @ up) * unit
    down = h < h.min() + CONTACT_HEIGHT
    flat = points - np.outer(points @ up, up)
    longest = 0.0
    for a, b in _runs(down[first - 1:last + 2]):
        q = flat[first - 1 + a:first + b]
        longest = max(longest, float(np.max(np.linalg.norm(q[:, None] - q[None], axis=-1))))
    return longest, bool(down[first - 1])


def _steps(legs, heads, tails, up, unit, fps, first, last):
    """{side: (start, end, lift)} for the leg whose heel or ball the gap drags more than STEP over the ground
    (``_drag``; a foot down at the last known frame only when still there (contacts.CONTACT_SPEED) or dragged faster
    than that; of two such legs the one dragged further: the gap is too short for two steps): the frames
    (fractional) over which the heel swings from the last known spot to the target's, and its lift (rig units)."""
    from .contacts import CONTACT_SPEED

    span = last + 2 - first  # from the last known frame to the target
    if (1.0 - 2.0 * SWING_MARGIN) * span / fps < MIN_SWING:
        return {}
    found = []
    for side, leg in legs.items():
        heel = heads[:, leg[2]]
        drags = [_drag(p, up, unit, first, last) for p in (heel, tails[:, leg[2]])]
        way = max(d for d, _down in drags)
        if way * unit <= STEP:
            continue
        if any(down for _d, down in drags) and first >= 2:
            v = heel[first - 1] - heel[first - 2]
            if (np.linalg.norm(v - (v @ up) * up) * unit * fps > CONTACT_SPEED
                    and way * unit * fps / span <= CONTACT_SPEED):
                continue  # a foot already sliding at the last known frame, no faster in the gap: the motion's own
        reach = heel[last + 1] - heel[first - 1]
        reach -= (reach @ up) * up
        found.append((way, side, min(STEP_LIFT / unit, 0.25 * float(np.linalg.norm(reach)))))
    if not found:
        return {}
    margin = SWING_MARGIN * span
    _d, side, lift = max(found)
    return {side: (first - 1 + margin, last + 1 - margin, lift)}


def _step_target(heel, up, first, last, step, frames):
    """(target (frames, 3), weight (frames,)): the heel held on its last known spot, swung (smoothstep on the
    ground, lifted by ``lift`` sin^2) over ``step``'s frames onto the target's spot, held there."""
    s0, s1, lift = step
    s = np.clip((frames - s0) / max(s1 - s0, 1e-9), 0.0, 1.0)
    pin = heel[first - 1][None] + _smooth(s)[:, None] * (heel[last + 1] - heel[first - 1])[None]
    off = pin - heel
    off -= np.outer(off @ up, up)
    off += np.outer(lift * np.sin(np.pi * s) ** 2, up)
    w = ((frames >= first) & (frames <= last)).astype(np.float64)
    return heel + off, w


def _held(point, down, first, last, ramp, frames, up, floor=None, planted=False):
    """(offset sum (frames, 3), weight sum (frames,)) that hold ``point`` where it is ``down`` in the generated
    frames ``first``..``last``: on the last known frame's spot when its run crosses the first seam, else where it
    comes down; eased onto the target's spot when the run crosses the last seam; faded over ``ramp`` frames
    outside the run and before an end inside the gap, zero at both seams. With a ``floor`` (a height along ``up``),
    on the ground plane, and up to the floor where the motion would sink below it (a heel does not go into the
    floor the known frames stand on; it may rise: the leg can always bend); without, with its height too. With
    ``planted``, only a run that crosses the first seam (down at the last known frame)."""
    from .contacts import _runs

    n = len(point)
    total = np.zeros(n)
    acc = np.zeros((n, 3))
    fade_in, fade_out = _smooth((frames - (first - 1)) / ramp), _smooth(((last + 1) - frames) / ramp)
    for a, b in _runs(down):
        lo, hi = max(a, first), min(b, last)
        if lo > hi or (planted and a >= first):
            continue
        pin_a = point[first - 1] if a < first else point[lo]
        pin_b = point[last + 1] if b > last else pin_a
        s0, s1 = (first - 1 if a < first else lo), (last + 1 if b > last else hi)
        s = np.clip((frames - s0) / max(s1 - s0, 1), 0.0, 1.0)
        pin = pin_a[None] + _smooth(s)[:, None] * (pin_b - pin_a)[None]
        dist = np.maximum(np.maximum(lo - frames, frames - hi), 0)
        # a run crossing a seam has no offset there; one starting or ending inside the gap fades before it
        seam = (1.0 if a < first else fade_in) * (1.0 if b > last else fade_out)
        w = _smooth(1.0 - dist / ramp) * seam
        off = pin - point
        if floor is not None:
            off += np.outer(np.maximum(floor - point @ up, 0.0) - off @ up, up)
        acc += w[:, None] * off[np.clip(frames, lo, hi)]
        total += w
    return acc, total


def _ball_turn(heel, ball, heel_target, heel_down, upright, up, unit, fps, first, last, ramp, frames):
    """(frames, 3) rotation vectors: the turn of the foot about its heel that keeps its ball where it was at the
    last known frame (``_held``, its height too) while the ball stays down (within CONTACT_HEIGHT of its lowest)
    from there, and the heel too (``heel_down``; times the leg's ``upright`` weight): a foot planted flat does not
    swing or roll its ball over the floor as it turns or flattens towards the target's pose. Nothing for a ball
    already moving at the last known frame (faster than STILL_BALL: the foot rolls or pivots on its own). Zero at
    both seams."""
    if first < 2 or np.linalg.norm(ball[first - 1] - ball[first - 2]) * unit * fps > STILL_BALL:
        return np.zeros((len(ball), 3))
    _acc, planted = _held(heel, heel_down, first, last, ramp, frames, up, planted=True)
    h = (ball @ up) * unit
    acc, total = _held(ball, h < h.min() + CONTACT_HEIGHT, first, last, ramp, frames, up, planted=True)
    w = np.minimum(total, 1.0) * np.minimum(planted, 1.0) * upright
    w[:first] = 0.0
    w[last + 1:] = 0.0
    want = ball + acc / np.maximum(total, 1e-12)[:, None] - heel_target
    return w[:, None] * so3.log(so3.align(ball - heel, want))


def plant_gap(rig, X, root, first, last, steps=True):
    """X (frames, bones, 3, 3) aligned rotations, ``root`` (frames, 3) heads of a sequence on ``rig``'s skeleton
    whose frames ``first``..``last`` (inclusive) are generated (the others known); returns X with the legs of
    the generated frames solved so the planted heels stay put, the feet turned about them so planted balls stay
    put too (module docstring). Unchanged without legs."""
    from .contacts import legs_of
    from .feet import _ik_leg

    try:
        legs = legs_of(rig)
    except ShapeSigError:
        return X
    rest = rest_of(rig)
    heads, tails, W = forward_kinematics(rig, rest, X, root)
    up = up_vector(rig)
    unit = unit_meters(rig, [(t, f) for t, _s, f in legs.values()])
    X = X.copy()
    ramp = max(RAMP * rig.fps, 1.0)
    frames = np.arange(len(X))
    roll = steps  # the geodesic's feet are held flat; a bridge's roll as its library's do
    steps = _steps(legs, heads, tails, up, unit, rig.fps, first, last) if steps else {}
    for side, leg in legs.items():
        heel = heads[:, leg[2]]
        h = (heel @ up) * unit
        length = (np.linalg.norm(rest.heads[leg[1]] - rest.heads[leg[0]])
                  + np.linalg.norm(rest.heads[leg[2]] - rest.heads[leg[1]]))
        # only a leg standing on its foot (the hip at least UPRIGHT of the leg above the heel): not one lying,
        # kneeling or kicking, where holding the heel would throw the leg
        upright = _smooth(((heads[:, leg[0]] - heel) @ up / max(length, 1e-12) - UPRIGHT) / 0.15)
        down = h < h.min() + CONTACT_HEIGHT
        if side in steps:  # down at the target far from where it was: a step, not a slide
            pinned, w = _step_target(heel, up, first, last, steps[side], frames)
            acc, total = (pinned - heel) * (w * upright)[:, None], w * upright
        else:  # held on the ground plane, and no lower than the known frames where it is down (the floor)
            known = down & ((frames < first) | (frames > last))
            floor = float((heel[known] @ up).min()) if known.any() else -np.inf
            acc, total = _held(heel, down, first, last, ramp, frames, up, floor=floor)
            acc, total = acc * upright[:, None], total * upright
        w = np.minimum(total, 1.0)
        w[:first] = 0.0
        w[last + 1:] = 0.0
        target = heel + acc / np.maximum(total, 1e-12)[:, None] * w[:, None]
        turn = np.zeros((len(X), 3))
        if side not in steps and roll:
            turn = _ball_turn(heel, tails[:, leg[2]], target, down, upright, up, unit, rig.fps, first, last, ramp,
                              frames)
        k = np.flatnonzero((w > 0) | np.any(turn != 0.0, axis=1))
        if not len(k):
            continue
        Xk, Wk, Hk = X[k], W[k], heads[k]
        _ik_leg(Xk, Wk, Hk, rest, leg, target[k], turn=so3.exp(turn[k]))
        X[k] = Xk
    return X
