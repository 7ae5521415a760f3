"""What happens in a clip, in nine numbers of leg lengths (issue 41), a term of the local search's final score: how
fast the body travels and in which direction relative to its facing (forward, sideways), once from the pelvis' path
and once from the ground under the lower foot as the body sees it (which moves also in a clip that plays in place),
how far the pelvis rises and falls, how high the lower foot gets (airborne phases) and how fast the pelvis moves up
or down. From the local features alone (``local.features``: the key points relative to the pelvis in the body's frame,
the pelvis' path in the turning frame), so every rig and rate is described alike. Speeds enter as the distance
covered in ``action.TIME`` (0.25 s) and the extremes as the ``PERCENTILE``-th percentile over the clip, so that a
short action is described by what happens in it, not by the standing frames around it, and a glitch of a frame does
not count. Derivation and measurements: docs/evaluation.md ("Short actions: what happens in a clip").
"""

import numpy as np

from ...rigs.body import POINTS
from .action import TIME, action_channels

_ANKLES = [POINTS.index("ankle.L"), POINTS.index("ankle.R")]

__all__ = ["PARTS", "PERCENTILE", "WEIGHT", "ground_velocity", "describe", "description_distances"]

PARTS = ("speed", "forward", "sideways", "ground_speed", "ground_forward", "ground_sideways", "rise", "clearance",
         "vertical")
PERCENTILE = 85.0  # the extremes of a clip (its rise, its highest lower foot, its fastest vertical motion)
WEIGHT = 2.0  # the description's distance in the shortlist's final score (``local.shortlist_scores``)


def _travel(forward, side):
    """(3,) the median horizontal speed, the mean forward and the absolute mean sideways velocity, times ``TIME``."""
    return TIME * np.array([np.median(np.hypot(forward, side)), np.mean(forward), abs(np.mean(side))])


def ground_velocity(feat) -> np.ndarray:
    """(T, 2) how the ground under the lower foot moves as the body sees it: minus the lower ankle's horizontal
    velocity relative to the pelvis in the body's frame (leg lengths per second; the body's x, y). A foot on the
    ground is still in the world, so this is the body's travel over the ground, also for a clip without root motion."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3)[:, _ANKLES]
    v = np.gradient(pose, axis=0) * float(feat["rate"]) if len(pose) > 1 else np.zeros_like(pose)
    lower = np.argmin(pose[..., 2], axis=1)
    return -v[np.arange(len(pose)), lower, :2]


def describe(feat) -> np.ndarray:
    """(9,) float32, ``PARTS``: the pelvis' travel (``_travel`` of its velocity in the body's frame), the ground's
    (``_travel`` of minus ``ground_velocity``), the pelvis' height range between the percentiles 100 - P and P, the
    P-th percentile of the lower ankle's height above the clip's ground (``action_channels``: its median), the P-th
    percentile of the pelvis' vertical speed times ``TIME`` (P = ``PERCENTILE``). The body's forward is -y."""
    c = action_channels(feat)
    g = ground_velocity(feat)
    low, pelvis = c[:, 3:5].min(axis=1), c[:, 5]
    p, q = PERCENTILE, 100.0 - PERCENTILE
    return np.concatenate([_travel(-c[:, 1], c[:, 0]), _travel(-g[:, 1], g[:, 0]),
                           [np.percentile(pelvis, p) - np.percentile(pelvis, q), np.percentile(low, p),
                            TIME * np.percentile(np.abs(c[:, 2]), p)]]).astype(np.float32)


def description_distances(query, candidates) -> np.ndarray:
    """(len(candidates),) the root mean square of the differences of the entries' descriptions (leg lengths); zeros
    when the query or any candidate has none (an entry of an older recipe)."""
    if query.describe is None or any(c.describe is None for c in candidates):
        return np.zeros(len(candidates))
    q = np.asarray(query.describe, np.float64)
    D = np.array([np.asarray(c.describe, np.float64) for c in candidates]).reshape(len(candidates), -1)
    return np.sqrt(((D - q) ** 2).mean(axis=1))
