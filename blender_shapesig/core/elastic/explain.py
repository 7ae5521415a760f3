"""Why two clips differ: the elastic energy of an optimal path (pinned or with a free window) split exactly into
(query interval x joint) pieces (``subsequence.path_costs``). ``explain_path`` / ``explain_clips`` give ``joints``
(each bone's share of d_S*^2, summing to 1), ``groups`` (the same over the canonical joint groups of
``core.rigs``) and ``cost_over_time`` (the energy on each interval of the query on the comparison time base).
A pair the DP cannot take at the comparison rate (a long take against a short query, two very long takes) is
resampled to a size it can (``fit_intervals``) and the explanation says so in one line (``resampled``).
See docs/search.md, "Moments".
"""

from dataclasses import replace

import numpy as np

from ..clip.clip import Clip, restrict_to_shared
from .elastic import dp_problem, elastic_align
from ..errors import CurveError
from . import DEFAULT_DEPTH
from ..clip.prepare import COMPARE_FPS, SMOOTH_SECONDS, prepare_clip, prepare_rotations
from ..rigs import BODY, LIMBS
from .subsequence import path_costs

__all__ = ["joint_group", "explain_path", "explain_clips", "top_joints", "fit_intervals", "EXPLAIN_MAX_BYTES"]

# DP memory of one explanation (16 bytes per grid node): 512 MiB, a few seconds; two 5-minute takes at the
# comparison rate need 2.6 GiB and are resampled to fit (``fit_intervals``)
EXPLAIN_MAX_BYTES = 2**29
ARM = LIMBS[:4]  # clavicle, upper_arm, forearm, hand; the rest of core.rigs.LIMBS is the leg


def joint_group(bone):
    """The canonical group of a bone named like ``core.rigs.JOINTS`` (e.g. 'forearm.L' -> 'left arm'), else None."""
    if bone in BODY:
        return "spine and head"
    base, _, side = bone.rpartition(".")
    if side in ("L", "R") and base in LIMBS:
        limb = "arm" if base in ARM else "leg"
        return f"{'left' if side == 'L' else 'right'} {limb}"
    return None


def _shares(values, names):
    total = float(np.sum(values))
    if total <= 0.0:
        return {n: 1.0 / len(names) for n in names}
    return {n: float(v) / total for n, v in zip(names, values)}


def explain_path(R0, R1, nodes, bones, *, same_spacing, fps=COMPARE_FPS):
    """The explanation of one DP path (see the module docstring): a dict with ``joints`` ({bone: share}),
    ``groups`` ({group: share}, only when some bones are canonical joints), ``cost_over_time`` (energy per query
    interval), ``fps`` and ``energy``. ``R0``, ``R1``, ``nodes``, ``same_spacing`` as for ``path_costs``."""
    costs = np.maximum(path_costs(R0, R1, nodes, same_spacing=same_spacing), 0.0)  # rounding only
    bones = list(bones)
    if len(bones) != costs.shape[1]:
        raise CurveError(f"{len(bones)} bone names for {costs.shape[1]} joints")
    per_joint = costs.sum(axis=0)
    out = {"joints": _shares(per_joint, bones), "cost_over_time": [float(x) for x in costs.sum(axis=1)],
           "fps": float(fps), "energy": float(per_joint.sum())}
    groups = {}
    for b, v in zip(bones, per_joint):
        g = joint_group(b)
        if g is not None:
            groups[g] = groups.get(g, 0.0) + float(v)
    if groups:
        groups["other"] = float(per_joint.sum()) - sum(groups.values())
        if groups["other"] <= 1e-12 * max(float(per_joint.sum()), 1.0):
            del groups["other"]
        out["groups"] = _shares(list(groups.values()), list(groups))
    return out


def fit_intervals(n0, n1, depth=DEFAULT_DEPTH, max_bytes=EXPLAIN_MAX_BYTES):
    """Interval counts (m0, m1) for two curves of ``n0`` and ``n1`` intervals that one pinned DP can take
    (``elastic.dp_problem``), (n0, n1) when it can already: while the frame ratio needs too large a step table,
    the shorter curve is sampled more densely (the same piecewise-geodesic curve on [0, 1]); while the grid needs
    more than ``max_bytes``, both more sparsely by the same factor."""
    m = [int(n0), int(n1)]
    for _ in range(200):
        problem = dp_problem(m[0], m[1], depth, max_bytes)
        if problem is None:
            return m[0], m[1]
        if problem == "steps":
            s = 0 if m[0] <= m[1] else 1
            if m[1 - s] <= depth * m[s]:  # the table is too large at this depth whatever the ratio
                raise CurveError(f"a timing freedom (depth) of {depth} is too large for the alignment; lower it")
            m[s] = max(m[s] + 1, int(np.ceil(m[s] * 1.25)))
        else:
            m = [max(1, int(v * 0.9)) for v in m]
    raise CurveError(f"no resampling of {n0} x {n1} intervals fits the alignment")  # not reached for real sizes


def _resampled(c, intervals):
    """The prepared clip ``c`` (on the comparison lattice) at ``intervals`` intervals over its duration: low-passed
    first when sparser (a Gaussian of half the new step), geodesic interpolation when denser."""
    if intervals == c.frames - 1:
        return c
    duration = (c.frames - 1) / c.fps
    rate = intervals / duration
    smooth = 0.5 / rate if rate < c.fps else 0.0
    R = prepare_rotations(c.rotations, c.fps, rate, smooth=smooth, keep_end=True)
    if R.shape[0] != intervals + 1:  # keep_end rounds duration * rate; the rate is chosen to make it exact
        raise CurveError(f"resampling {c.name!r} gave {R.shape[0]} samples, not {intervals + 1}")
    return replace(c, rotations=R, root_translation=None, fps=rate)


def _resampled_line(pairs):
    """One line for the box: which clips were compared at another rate than the comparison rate."""
    parts = [f"{c.name} at {c.fps:.3g}" for c in pairs]
    return (f"Resampled to fit the alignment: {' and '.join(parts)} samples per second "
            f"(normally {COMPARE_FPS:g})")


def explain_clips(query: Clip, clip: Clip, window=None, depth=DEFAULT_DEPTH):
    """``explain_path`` for two clips on their shared bones, on the comparison time base (the SRVT low-pass of
    ``core.clip.prepare``): the pinned elastic alignment of the query with ``clip``, or with its frames
    ``window = (start, end)`` (the clip's own numbers, inclusive) for a moment; adds ``warp``, the alignment's
    matching times [[t_query, t_clip], ...] from (0, 0) to (1, 1) (t_clip of the window for a moment). A pair
    the DP cannot take at the comparison rate is resampled (``fit_intervals``): then ``resampled`` is one line
    saying so (and ``fps`` is the query's rate used), else it is absent."""
    if window is not None:
        clip = clip.crop(int(window[0]), int(window[1]))
    a, b = restrict_to_shared(query, clip)
    a, b = prepare_clip(a, smooth=SMOOTH_SECONDS), prepare_clip(b, smooth=SMOOTH_SECONDS)
    for c in (a, b):
        if c.frames < 2:
            raise CurveError(f"clip {c.name!r} is too short to explain a distance")
    m0, m1 = fit_intervals(a.frames - 1, b.frames - 1, depth, EXPLAIN_MAX_BYTES)
    changed = (m0 != a.frames - 1, m1 != b.frames - 1)
    a, b = _resampled(a, m0), _resampled(b, m1)
    warp, _, info = elastic_align(a.rotations, b.rotations, depth=depth, return_info=True)
    out = explain_path(a.rotations, b.rotations, info["nodes"], a.bones, same_spacing=False, fps=a.fps)
    out["warp"] = [[float(t0), float(t1)] for t0, t1 in warp]  # matching times (query, clip or window), 0..1
    if any(changed):
        out["resampled"] = _resampled_line([c for c, ch in zip((a, b), changed) if ch])
    return out


def top_joints(explanation, count=5, key="joints"):
    """The ``count`` largest shares of an explanation as [(name, share)], largest first."""
    items = sorted((explanation or {}).get(key, {}).items(), key=lambda kv: (-kv[1], kv[0]))
    return items[:count]
