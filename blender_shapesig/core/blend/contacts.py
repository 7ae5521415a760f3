"""Foot contacts of clips and blends, step 1 and 2 of planted feet (``feet.lock_feet``): the legs through the
canonical joints of ``core.rigs`` (``legs_of``), the heel and ball positions (``feet_positions``, through
``core.clip.skeleton``), the frames where each point is low and slow (``find_contacts``), each blended frame's time
in its sources (``source_times``) and the sources' contacts carried into the blend's frames (``blend_contacts``);
``intervals`` and ``stance_drift`` measure contact runs. See docs/blending.md, "Planted feet".
"""

import numpy as np
from scipy.ndimage import minimum_filter1d, uniform_filter1d

from ..errors import ShapeSigError
from ..rigs import resolve_map
from ..clip.skeleton import forward_kinematics, unit_meters, up_vector

__all__ = ["legs_of", "feet_positions", "find_contacts", "source_times", "blend_contacts", "intervals",
           "stance_drift", "POINTS", "CONTACT_HEIGHT", "CONTACT_SPEED", "MIN_CONTACT", "MIN_GAP"]

POINTS = ("heel", "ball")
CONTACT_HEIGHT = 0.02   # m above the point's floor
CONTACT_SPEED = 0.8     # m/s
FLOOR_WINDOW = 1.2      # s: the floor under a point is its lowest height within this window (uneven ground)
SPEED_WINDOW = 0.05     # s: positions are averaged over this window before the speed is taken
MIN_CONTACT = 0.04      # s: shorter contacts are dropped
MIN_GAP = 0.05          # s: shorter gaps between contacts are filled


# ------------------------------------------------------------------------------------------------ legs

def legs_of(clip, mapping=None):
    """``{side: (thigh, shin, foot)}`` bone indices of the clip's legs (sides "L", "R") through the canonical joints
    (``mapping`` {bone: joint}, default ``rigs.resolve_map`` "auto": CMU ASF, Daz BVH, Mixamo, Rigify, ...);
    ShapeSigError without any leg."""
    mapping = (resolve_map("auto", clip) if mapping is None else mapping) or {}
    by_joint = {j: b for b, j in mapping.items()}
    legs = {}
    for side in ("L", "R"):
        names = [by_joint.get(f"{j}.{side}") for j in ("thigh", "shin", "foot")]
        if all(n is not None for n in names):
            legs[side] = tuple(clip.bones.index(n) for n in names)
    if not legs:
        raise ShapeSigError(f"clip {clip.name!r}: no leg (thigh, shin, foot) found through the bone map")
    return legs


def feet_positions(clip, legs=None, fk=None):
    """``{side: {"heel": (frames, 3), "ball": (frames, 3)}}``: the foot bone's head and tail
    (``forward_kinematics``)."""
    legs = legs_of(clip) if legs is None else legs
    heads, tails, _W = forward_kinematics(clip) if fk is None else fk
    return {s: {"heel": heads[:, f], "ball": tails[:, f]} for s, (_t, _s, f) in legs.items()}


# ------------------------------------------------------------------------------------------------ contacts

def _runs(mask):
    """[(start, end)] inclusive index runs where ``mask`` is True."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def _clean(mask, fps):
    """Gaps shorter than MIN_GAP filled, then runs shorter than MIN_CONTACT dropped."""
    mask = np.asarray(mask, bool).copy()
    gap, short = MIN_GAP * fps, MIN_CONTACT * fps
    for a, b in _runs(~mask):
        if a > 0 and b < len(mask) - 1 and b - a + 1 < gap:
            mask[a:b + 1] = True
    for a, b in _runs(mask):
        if b - a + 1 < short:
            mask[a:b + 1] = False
    return mask


def intervals(mask, fps, start=0):
    """Contact runs of a boolean mask as ``[{"frames": [first, last], "seconds": [t0, t1]}]`` (frames offset by
    ``start``, seconds from the first frame)."""
    return [{"frames": [int(a + start), int(b + start)],
             "seconds": [round(float(a) / fps, 4), round(float(b) / fps, 4)]}
            for a, b in _runs(mask)]


def _low_slow(p, unit, up, fps, height=CONTACT_HEIGHT):
    """(low, slow) masks of a point's positions p (frames, 3) in units of ``unit`` metres (step 1)."""
    h = (p @ up) * unit
    floor = minimum_filter1d(h, max(1, int(round(FLOOR_WINDOW * fps))) | 1, mode="nearest")
    smooth = uniform_filter1d(p, max(1, int(round(SPEED_WINDOW * fps))) | 1, axis=0, mode="nearest")
    v = np.linalg.norm(np.gradient(smooth, axis=0), axis=1) * unit * fps
    return h < floor + height, v < CONTACT_SPEED


def find_contacts(clip, legs=None, fk=None):
    """``{side: {"heel": mask, "ball": mask}}``: frames where each point of each foot is low and slow (module
    docstring, step 1)."""
    legs = legs_of(clip) if legs is None else legs
    pos = feet_positions(clip, legs, fk)
    unit = unit_meters(clip, [(t, f) for t, _s, f in legs.values()])
    up = up_vector(clip)
    out = {}
    for side, points in pos.items():
        out[side] = {}
        for name, p in points.items():
            low, slow = _low_slow(p, unit, up, clip.fps)
            out[side][name] = _clean(low & slow, clip.fps)
    return out


def source_times(blend, sources):
    """Per source, the time (s, from its first frame) of every blended frame: ``meta["source_times"]``, else for
    two sources ``u D0`` and ``phi(u) D1`` from ``meta["time_map"]`` and ``meta["warp"]``."""
    given = blend.meta.get("source_times")
    if given is not None:
        return [np.asarray(t, dtype=np.float64) for t in given]
    u, warp = blend.meta.get("time_map"), blend.meta.get("warp")
    if u is None or warp is None or len(sources) != 2:
        raise ShapeSigError(f"blend {blend.name!r}: no meta source_times (nor time_map and warp of two clips)")
    u = np.asarray(u, dtype=np.float64)
    warp = np.asarray(warp, dtype=np.float64)
    phi = np.clip(np.interp(u, warp[:, 0], warp[:, 1]), 0.0, 1.0)
    a, b = sources
    return [u * (a.frames - 1) / a.fps, phi * (b.frames - 1) / b.fps]


def _weights(blend, count):
    given = blend.meta.get("weights")
    if given is not None:
        w = np.asarray(given, dtype=np.float64)
    elif count == 2:
        x = float(blend.meta.get("weight", 0.0))
        w = np.array([1.0 - x, x])
    else:
        raise ShapeSigError(f"blend {blend.name!r}: no meta weights for {count} sources")
    return w / w.sum()


def blend_contacts(blend, sources, contacts, times, pos=None, unit=1.0):
    """``{side: {point: mask over the blend's frames}}``: the sources' contacts (``find_contacts`` per source, on
    sides present in all of them) carried through their times and weighted (step 2). With the blend's feet
    positions ``pos`` (``feet_positions``, in units of ``unit`` metres), a weighted tie counts only where the
    blended point is low (within twice CONTACT_HEIGHT of its floor)."""
    w = _weights(blend, len(sources))
    up = up_vector(blend)
    out = {}
    for side in set.intersection(*(set(c) for c in contacts)):
        out[side] = {}
        for point in POINTS:
            score = np.zeros(blend.frames)
            for wi, src, c, t in zip(w, sources, contacts, times):
                score += wi * np.interp(t * src.fps, np.arange(src.frames), c[side][point].astype(float))
            mask = score > 0.5 + 1e-9
            if pos is not None:
                tie = score >= 0.5 - 1e-9
                mask |= tie & _low_slow(pos[side][point], unit, up, blend.fps, 2.0 * CONTACT_HEIGHT)[0]
            out[side][point] = _clean(mask, blend.fps)
    return out


def stance_drift(positions, mask):
    """Per contact run of ``mask``: the largest distance between two positions of the point (its slide)."""
    out = []
    for a, b in _runs(mask):
        p = positions[a:b + 1]
        out.append(float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1))))
    return out
