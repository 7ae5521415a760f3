"""Planted feet in blends: ``lock_feet(blend, sources) -> (Clip, report)`` takes the sources' foot contacts (heel and
ball, ``contacts.find_contacts``) carried through the warp into the blend's frames (``contacts.blend_contacts``),
keeps those points planted and solves each leg with an analytic two-bone IK (``_ik_leg``; lowering the root where a
leg cannot reach, feet and toes kept above the floor of the rig's own sources); ``source_drifts`` and
``rotation_steps`` measure its criteria. Positions through ``core.clip.skeleton``. See docs/blending.md, "Planted
feet".
"""

from dataclasses import replace

import numpy as np
from scipy.ndimage import minimum_filter1d, uniform_filter1d

from ..geometry import so3
from ..geometry.curves import geodesic_interpolate, uniform_times
from ..errors import ShapeSigError
from ..clip.skeleton import (
    aligned_rotations, forward_kinematics, from_aligned, rest_of, root_heads, root_translation_from_heads,
    unit_meters, up_vector,
)
from .contacts import (
    POINTS, _runs, _weights, blend_contacts, feet_positions, find_contacts, intervals, legs_of, source_times,
    stance_drift,
)

__all__ = ["FEET_MODES", "lock_feet", "source_drifts", "rotation_steps", "RAMP", "SOFT_REACH", "FADE_REACH",
           "MAX_LOWER", "FLOOR_TOLERANCE", "MAX_PITCH"]

FEET_MODES = ("lock", "none")
RAMP = 0.1              # s: the IK correction fades in/out over this time outside each contact
MAX_LOWER = 0.08        # the root goes down at most this fraction of the leg (beyond, the foot lets go)
SOFT_REACH = 0.97       # a leg stretched beyond this fraction (and beyond its blended stretch) straightens softly
FADE_REACH = 1.0        # a lock asking more of the leg than this fraction (and than its blended stretch) fades out
FADE_SPAN = 0.08        # ... over this fraction of the leg
FLOOR_TOLERANCE = 0.005  # m: a foot point or toe tip may dip this far below the lowest of the rig's own sources
MAX_PITCH = np.radians(60.0)  # a foot or toe flexes at most this much to stay above the floor
MIN_ACROSS = 0.4         # ... and only if its rest direction is at least ~24 degrees off the vertical


# ------------------------------------------------------------------------------------------------ planting

def _ease(x):
    """Smoothstep of ``x`` clipped to [0, 1]: 0 and 1 with zero slope at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _ramped(mask, fps):
    """[(a, b, weight)] per run a..b of ``mask``: the weight (frames,) is 1 on the run and eases to 0 over RAMP
    seconds outside it (smoothstep, so the correction starts and ends without a kink)."""
    n = len(mask)
    ramp = max(RAMP * fps, 1.0)
    frames = np.arange(n)
    out = []
    for a, b in _runs(mask):
        dist = np.maximum(np.maximum(a - frames, frames - b), 0)
        out.append((a, b, _ease(1.0 - dist / ramp)))
    return out


def _ankle_offsets(mask_of, pos, fps, slide):
    """(offset (frames, 3), weight (frames,)): how far the ankle must move, from the heel's and the ball's pins
    (step 3). On a contact run a..b a point's goal is its pin (mean blended position over the run) plus
    ``slide(point, a, b)``, the sources' weighted slide there; its offset is goal - position (the foot's orientation
    is kept, so the ball's offset moves the ankle as much). Outside the run the offset at its end fades out over
    RAMP seconds (``_ramped``). Where two runs' ramps overlap their offsets are averaged with their weights (a
    continuous target: switching from one run's offset to the next would throw the leg), and so are the two
    points'."""
    n = len(pos["heel"])
    frames = np.arange(n)
    weights, offsets = {}, {}
    for point in POINTS:
        total, acc = np.zeros(n), np.zeros((n, 3))
        for a, b, w in _ramped(mask_of[point], fps):
            inside = pos[point][a:b + 1]
            off = inside.mean(axis=0) + slide(point, a, b) - inside
            acc += w[:, None] * off[np.clip(frames, a, b) - a]
            total += w
        offsets[point] = acc / np.maximum(total, 1e-12)[:, None]
        weights[point] = np.minimum(total, 1.0)
    wb, wh = weights["ball"], weights["heel"]
    total = wh + wb
    offset = (wh[:, None] * offsets["heel"] + wb[:, None] * offsets["ball"]) / np.maximum(total, 1e-12)[:, None]
    return offset, np.minimum(total, 1.0)


def _smooth_max(x, fps):
    """A smooth envelope above ``x`` >= 0 (root lowering): a running max over 2 RAMP, then a moving average."""
    k = max(1, int(round(RAMP * fps))) * 2 + 1
    from scipy.ndimage import maximum_filter1d

    return uniform_filter1d(maximum_filter1d(x, k, mode="nearest"), k, mode="nearest")


def _soft_reach(dist, free, length):
    """The hip-ankle distance the leg takes for a target at ``dist``: ``dist`` up to ``soft`` = the larger of
    SOFT_REACH of the leg's ``length`` and the blended leg's own ``free`` extension, beyond it approaching
    ``length`` exponentially (a leg straightens smoothly instead of snapping straight; the foot falls short)."""
    soft = np.minimum(np.maximum(SOFT_REACH * length, free), length)
    room = np.maximum(length - soft, 1e-12)
    return np.where(dist <= soft, dist, soft + room * (1.0 - np.exp(-np.maximum(dist - soft, 0.0) / room)))


def _solve_leg(hip, knee, target, l1, l2, forward, free):
    """The new knee (frames, 3): in the plane of hip, target and the blended knee, |knee - hip| = l1,
    |target - knee| = l2 (``_soft_reach``; ``free``: the blended leg's hip-ankle vector). A straight blended leg
    has no plane: the knee then bends towards ``forward`` (the foot's direction): the pole (the blended knee's
    offset from the hip-target line) is lifted to at least 2% of l1 ahead of the line where the ankle is moved by 2%
    of l1 or more, in proportion below (a leg bent forward more, or not moved, keeps its plane exactly)."""
    d = target - hip
    dist = np.linalg.norm(d, axis=1, keepdims=True)
    dn = d / np.maximum(dist, 1e-12)

    def across(v):
        return v - np.sum(v * dn, axis=1, keepdims=True) * dn

    bent = across(knee - hip)
    ahead = across(forward)
    ahead /= np.maximum(np.linalg.norm(ahead, axis=1, keepdims=True), 1e-12)
    # a knee bends forward: the pole keeps at least 2% of l1 ahead of the hip-target line (max(): continuous, and
    # never zero, so the knee cannot flip through the line from one frame to the next)
    lift = np.maximum(0.02 * l1 - np.sum(bent * ahead, axis=1, keepdims=True), 0.0)
    # only where the ankle is moved (fully from 2% of l1 on): an uncorrected leg keeps its blended knee
    moved = np.linalg.norm(target - (hip + free), axis=1, keepdims=True)
    pole = bent + lift * np.clip(moved / (0.02 * l1), 0.0, 1.0) * ahead
    pn = np.linalg.norm(pole, axis=1, keepdims=True)
    pole = pole / np.maximum(pn, 1e-12)
    dist = _soft_reach(dist, np.linalg.norm(free, axis=1, keepdims=True), l1 + l2)
    dist = np.clip(dist, abs(l1 - l2) + 1e-9, l1 + l2)
    a = (l1 * l1 - l2 * l2 + dist * dist) / (2.0 * dist)
    h = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    return hip + a * dn + h * pole


class _Source:
    """One source's feet: points per side, root heading, contacts, and its times in the blend."""

    def __init__(self, clip, times):
        self.clip, self.legs = clip, legs_of(clip)
        self.rest = rest = rest_of(clip)
        fk = forward_kinematics(clip, rest)
        self.pos = feet_positions(clip, self.legs, fk)
        self.tails = fk[1]
        self.contacts = find_contacts(clip, self.legs, fk)
        self.unit = unit_meters(clip, [(t, f) for t, _s, f in self.legs.values()])
        self.up = up_vector(clip)
        root = rest.root if rest.root is not None else 0
        # its (fractional) frame at every blended frame
        self.frame = np.clip(np.asarray(times) * clip.fps, 0, clip.frames - 1)
        self.yaw = np.unwrap(so3.heading(fk[2][:, root], self.up))

    def at(self, values):
        """``values`` (frames, ...) of this source at its time of every blended frame (linear)."""
        x = np.arange(self.clip.frames)
        flat = values.reshape(len(values), -1)
        return np.stack([np.interp(self.frame, x, flat[:, i]) for i in range(flat.shape[1])], axis=1)

    def slide(self, side, point, a, b, unit_to, up_to, yaw_to):
        """This source's slide of a point over blended frames a..b: its positions during the one contact of its own
        that overlaps its frames there the most (held at that contact's ends outside it, ``_held``) minus their
        mean, turned into the blend's heading (``yaw_to``, mean over a..b) and units; zero when none overlaps."""
        frame = self.frame[a:b + 1]
        p = _held(self.pos[side][point], self.contacts[side][point], frame)
        if p is None:
            return np.zeros((b - a + 1, 3))
        yaw = self.at(self.yaw)[a:b + 1, 0]
        r = (p - p.mean(axis=0)) * (self.unit / unit_to)
        delta = np.angle(np.mean(np.exp(1j * (yaw_to - yaw))))
        return so3.turn(r, up_to, delta)


def _held(p, mask, frame):
    """Positions p (frames, 3) at the fractional ``frame`` values, each clamped to the contact run of ``mask`` that
    overlaps ``frame``'s span the most (a source whose foot is lifted while the blend's is planted adds no slide
    there; one run only, so the positions never jump from one footprint to the next); None if no run overlaps."""
    lo, hi = float(frame.min()), float(frame.max())
    best, most = None, -1.0
    for s, e in _runs(mask):
        overlap = min(hi, e) - max(lo, s)
        if overlap >= 0 and overlap > most:
            best, most = (s, e), overlap
    if best is None:
        return None
    f = np.clip(frame, *best)
    x = np.arange(len(p))
    return np.stack([np.interp(f, x, p[:, i]) for i in range(p.shape[1])], axis=1)


def source_drifts(clip):
    """The stance drifts (metres) of every contact run of every foot point of a clip on its own contacts
    (``find_contacts``): the sources' side of the planted-feet criterion (benchmarks and tests)."""
    legs = legs_of(clip)
    fk = forward_kinematics(clip)
    contacts = find_contacts(clip, legs, fk)
    pos = feet_positions(clip, legs, fk)
    unit = unit_meters(clip, [(t, f) for t, _s, f in legs.values()])
    return [d * unit for side in contacts for p in POINTS for d in stance_drift(pos[side][p], contacts[side][p])]


def rotation_steps(blend, sources):
    """(blend, sources): the largest per-frame rotation angle (degrees) of any bone in the blend, and in the faster
    of the sources, each sampled at its times in the blend (``source_times``: time-aligned; any rig). The no-pops
    criterion: blend <= sources + 5."""
    def largest(R):
        return float(np.degrees(np.linalg.norm(so3.relative_rotvecs(R), axis=-1).max()))

    src = 0.0
    for clip, t in zip(sources, source_times(blend, sources)):
        x = np.clip(np.asarray(t) * clip.fps / max(clip.frames - 1, 1), 0.0, 1.0)
        src = max(src, largest(geodesic_interpolate(clip.rotations, uniform_times(clip.frames), x)))
    return largest(blend.rotations), src


def _working_clip(blend, sources):
    """The blend with its rig's skeleton meta (the first source's, unless the blend carries one)."""
    if not sources:
        raise ShapeSigError("lock_feet: no source clips")
    rig = sources[0]
    if blend.bones != rig.bones and "rest_heads" not in blend.meta:
        raise ShapeSigError(f"blend {blend.name!r} is not on the rig of {rig.name!r} (other bones)")
    keep = ("rest_heads", "rest_tails", "parents", "rest_rotations", "unit_meters", "rotation_space")
    meta = dict(blend.meta)
    for k in keep:
        if k not in meta and k in rig.meta:
            meta[k] = rig.meta[k]
    # positions are in the rig's world-aligned axes: the world's up is the rig's (a blend's meta up_axis is the
    # root translation's up, in the root's parent space: another frame for a pose-space blend)
    meta.pop("up_axis", None)
    if "up_axis" in rig.meta:
        meta["up_axis"] = rig.meta["up_axis"]
    return replace(blend, meta=meta)


def _reach_fade(hip, desired, current, length, fps):
    """(frames,) the weight of a leg's correction: 1 while the target is within the larger of FADE_REACH of the
    leg's ``length`` and the blended leg's own hip-ankle distance, easing to 0 as the target's distance nears
    ``length`` (a foot the leg cannot reach lets go instead of throwing the leg straight), then eased in time: a
    running minimum over RAMP, smoothed over RAMP, so the lock fades over a few frames before and after."""
    reach = np.linalg.norm(desired - hip, axis=1)
    start = np.maximum(FADE_REACH * length, np.linalg.norm(current - hip, axis=1))
    fade = 1.0 - _ease((reach - start) / (FADE_SPAN * length))
    k = max(1, int(round(RAMP * fps))) | 1
    return uniform_filter1d(minimum_filter1d(fade, k, mode="nearest"), k, mode="nearest")


def _lower_root(hips, desired, current, lengths, up):
    """(frames,) how far the root must go down (along ``up``) so every leg reaches its target: never asking a leg to
    stretch beyond SOFT_REACH of its length or beyond what it already is in the blend."""
    need = np.zeros(len(next(iter(hips.values()))))
    for side, hip in hips.items():
        d = desired[side] - hip
        reach = np.maximum(SOFT_REACH * lengths[side], np.linalg.norm(current[side] - hip, axis=1))
        du = d @ up
        disc = du * du - np.sum(d * d, axis=1) + reach * reach
        delta = np.where(disc >= 0, -du - np.sqrt(np.maximum(disc, 0.0)), -du)
        far = np.linalg.norm(d, axis=1) > reach
        need = np.maximum(need, np.where(far, np.maximum(delta, 0.0), 0.0))
    return need


def lock_feet(blend, sources):
    """(the blend with planted feet, report): the module docstring's steps 1-4. ``report``: ``contacts`` (per source
    and for the blend, per side and point, intervals in frames and seconds), ``feet`` (per side and point, the
    slide of each contact in metres before and after), ``root_lowered`` (m, largest), ``unit_meters``."""
    sources = list(sources)
    work = _working_clip(blend, sources)
    times = source_times(work, sources)
    if len(times) != len(sources):
        raise ShapeSigError(f"blend {blend.name!r}: {len(times)} source times for {len(sources)} sources")
    srcs = [_Source(c, t) for c, t in zip(sources, times)]
    if any(not np.allclose(s.up, up_vector(work)) for s in srcs):
        raise ShapeSigError(f"blend {blend.name!r}: its sources are in other axes "
                            f"(read every clip in the same space)")
    weights = _weights(work, len(sources))
    legs = legs_of(work)
    rest = rest_of(work)
    X = aligned_rotations(work).copy()
    root = root_heads(work, rest)
    heads, tails, W = forward_kinematics(work, rest, X, root)
    unit = unit_meters(work, [(t, f) for t, _s, f in legs.values()])
    up = up_vector(work)
    yaw = np.unwrap(so3.heading(W[:, rest.root if rest.root is not None else 0], up))
    pos = feet_positions(work, legs, (heads, tails, W))
    contacts = blend_contacts(work, sources, [s.contacts for s in srcs], times, pos, unit)

    desired, lengths, hips = {}, {}, {}
    for side in [x for x in sorted(contacts) if x in legs]:
        thigh, shin, foot = legs[side]

        def slide(point, a, b, side=side):
            yaw_to = np.angle(np.mean(np.exp(1j * yaw[a:b + 1])))
            return sum(w * s.slide(side, point, a, b, unit, up, yaw_to) for w, s in zip(weights, srcs) if w > 0)

        offset, alpha = _ankle_offsets(contacts[side], pos[side], work.fps, slide)
        desired[side] = pos[side]["heel"] + alpha[:, None] * offset
        lengths[side] = (np.linalg.norm(rest.heads[shin] - rest.heads[thigh])
                         + np.linalg.norm(rest.heads[foot] - rest.heads[shin]))
        hips[side] = heads[:, thigh]
    lowered = np.zeros(work.frames)
    if desired and root is not None:
        need = _lower_root(hips, desired, {s: pos[s]["heel"] for s in desired}, lengths, up)
        need = np.minimum(need, MAX_LOWER * min(lengths.values()))
        if need.max() > 0:
            lowered = np.maximum(_smooth_max(need, work.fps), need)
            root = root - np.outer(lowered, up)
            heads = heads - np.outer(lowered, up)[:, None]
    floors = _floors(work, srcs, rest, legs, up)
    for side in legs:
        target = pos[side]["heel"] - np.outer(lowered, up)
        if side in desired:
            fade = _reach_fade(heads[:, legs[side][0]], desired[side], target, lengths[side], work.fps)
            target = target + fade[:, None] * (desired[side] - target)
        floor = floors.get(side)
        if floor is not None:
            target = target + np.outer(np.maximum(floor["heel"] - target @ up, 0.0), up)
        if side in desired or floor is not None:
            _ik_leg(X, W, heads, rest, legs[side], target, up, floor, work.fps)
    rotations = from_aligned(work, X)
    rt = work.root_translation if root is None else root_translation_from_heads(work, rest, root)
    out = replace(blend, rotations=rotations, root_translation=rt)
    after = feet_positions(replace(work, rotations=rotations, root_translation=rt), legs)
    report = _report(work, srcs, contacts, pos, after, unit, lowered)
    out.meta = dict(blend.meta, feet="lock")
    return out, report


def _floors(work, srcs, rest, legs, up):
    """``{side: {"heel": h, "ball": h, "toes": {bone: h}}}``: the lowest height (along ``up``, in the blend's
    units) of each foot point, and of the tail of each bone under the foot (toes), over the sources on the blend's
    own skeleton (the first source always is): a blend written onto that rig keeps its feet above them (a blend
    across rigs otherwise brings the other rig's lower ankle and foot pitch)."""
    same = [s for s in srcs if s.clip.bones == work.bones
            and np.allclose(s.rest.heads, rest.heads, atol=1e-6 * (1.0 + np.abs(rest.heads).max()))]
    tol = FLOOR_TOLERANCE / srcs[0].unit
    out = {}
    for side in set(legs).intersection(*(set(s.pos) for s in same)) if same else ():
        foot = legs[side][2]
        out[side] = {p: min(float((s.pos[side][p] @ up).min()) for s in same) - tol for p in POINTS}
        out[side]["toes"] = {int(c): min(float((s.tails[:, c] @ up).min()) for s in same) - tol
                             for c in np.flatnonzero(rest.ancestor == foot)}
    return out


def _pitch_to_floor(Wf, head, bone, up, floor, fps):
    """A bone's world rotations (frames, 3, 3) pitched up about its head, so its tail (``head + Wf bone``) stays
    no lower than ``floor`` along ``up`` (as far as it can): per frame the least flexing turn that lifts the tail to
    the floor, about the bone's own across-axis (rest direction x up, turned with the bone: it stays defined when
    the bone points down), eased over RAMP (``_smooth_max``) so the correction fades in and out without a step."""
    v = np.einsum("fij,j->fi", Wf, bone)
    want = floor - head @ up
    rise = v @ up
    if not (rise < want - 1e-9).any():
        return Wf
    across = np.cross(bone, up)
    if np.linalg.norm(across) < MIN_ACROSS * max(np.linalg.norm(bone), 1e-12):
        return Wf  # a bone (nearly) upright at rest: its tail is no toe (an importer's made-up tail), no pitch axis
    axis = np.einsum("fij,j->fi", Wf, across / np.linalg.norm(across))
    # the tail's height after a turn by t about the axis: c0 + A cos t + B sin t = c0 + R cos(t - phi)
    along = np.sum(axis * v, axis=1)
    c0 = along * (axis @ up)
    A = (v - along[:, None] * axis) @ up
    B = np.cross(axis, v) @ up
    R, phi = np.hypot(A, B), np.arctan2(B, A)
    # the first turn (flexing up, t >= 0) at which the tail reaches the floor; the highest it can go if it cannot
    x = np.arccos(np.clip((want - c0) / np.maximum(R, 1e-12), -1.0, 1.0))
    need = np.minimum(np.mod(phi - x, 2 * np.pi), np.mod(phi + x, 2 * np.pi))
    need = np.minimum(np.where(rise < want, need, 0.0), MAX_PITCH)
    need = np.maximum(_smooth_max(need, fps), need)
    return so3.exp(axis * need[:, None]) @ Wf


def _ik_leg(X, W, heads, rest, leg, target, up=None, floor=None, fps=None, turn=None):
    """Two-bone IK in place on X (world-aligned local rotations): thigh and shin turned so that the ankle reaches
    ``target`` with the knee in the plane of the blended leg; the foot keeps its world rotation (turned by the
    world rotations ``turn`` (frames, 3, 3) about its head when given), pitched up where its tail, or a toe's,
    would go below its ``floor`` (``_floors``, along ``up``; ``_pitch_to_floor``)."""
    thigh, shin, foot = leg
    hip, knee, ankle = heads[:, thigh], heads[:, shin], heads[:, foot]
    l1 = np.linalg.norm(rest.heads[shin] - rest.heads[thigh])
    l2 = np.linalg.norm(rest.heads[foot] - rest.heads[shin])
    forward = W[:, foot] @ (rest.tails[foot] - rest.heads[foot])
    new_knee = _solve_leg(hip, knee, target, l1, l2, forward, ankle - hip)
    Rt = so3.align(knee - hip, new_knee - hip)
    Wt = Rt @ W[:, thigh]
    Rs = so3.align(np.einsum("fij,fj->fi", Rt, ankle - knee), target - new_knee)
    Ws = Rs @ Rt @ W[:, shin]
    parent = rest.ancestor[thigh]
    Wp = W[:, parent] if parent >= 0 else np.eye(3)[None]
    X[:, thigh] = np.swapaxes(Wp, -1, -2) @ Wt
    # bones between thigh and shin or shin and foot (twist bones) keep their local rotations: they turn along
    new_shin_parent = Rt @ W[:, rest.ancestor[shin]]
    new_foot_parent = Rs @ Rt @ W[:, rest.ancestor[foot]]
    X[:, shin] = np.swapaxes(new_shin_parent, -1, -2) @ Ws
    Wf = W[:, foot] if turn is None else turn @ W[:, foot]
    if floor is not None:
        reached = new_knee + np.einsum("fij,fj->fi", Rs @ Rt, ankle - knee)
        Wf = _pitch_to_floor(Wf, reached, rest.tails[foot] - rest.heads[foot], up, floor["ball"], fps)
        for toe, low in floor["toes"].items():
            head = reached + np.einsum("fij,j->fi", Wf, rest.heads[toe] - rest.heads[foot])
            Wt = _pitch_to_floor(Wf @ X[:, toe], head, rest.tails[toe] - rest.heads[toe], up, low, fps)
            X[:, toe] = np.swapaxes(Wf, -1, -2) @ Wt
    X[:, foot] = np.swapaxes(new_foot_parent, -1, -2) @ Wf


def _report(work, srcs, contacts, before, after, unit, lowered):
    """The JSON-able report of ``lock_feet``."""
    rows = []
    for s in srcs:
        for side, pts in sorted(s.contacts.items()):
            for point, mask in pts.items():
                rows.append({"clip": s.clip.name, "side": side, "point": point,
                             "intervals": intervals(mask, s.clip.fps, s.clip.frame_start)})
    feet = []
    for side, pts in sorted(contacts.items()):
        for point, mask in pts.items():
            rows.append({"clip": work.name, "side": side, "point": point,
                         "intervals": intervals(mask, work.fps, work.frame_start)})
            feet.append({"side": side, "point": point,
                         "drift_before": [round(d * unit, 4) for d in stance_drift(before[side][point], mask)],
                         "drift_after": [round(d * unit, 4) for d in stance_drift(after[side][point], mask)]})
    return {"contacts": rows, "feet": feet, "root_lowered": round(float(lowered.max()) * unit, 4),
            "unit_meters": unit}
