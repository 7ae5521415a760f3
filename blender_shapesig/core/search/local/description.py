"""What happens in a clip, in eight numbers of leg lengths (issue 41), two terms of the local search's final score:
how fast the body travels and in which direction relative to its facing (forward, sideways: from the pelvis' path,
or, for a clip that plays in place, from the ground under the lower foot as the body sees it), how far the pelvis
rises and falls, how high the lower foot gets (airborne phases), how fast the pelvis moves up or down; and what the
arms do: how fast a hand goes forward at shoulder height (a strike) and how near the face the hands are held (a
guard), compared only as much as the query strikes. From the local features alone (``local.features``: the key
points relative to the pelvis in the body's frame, the pelvis' path in the turning frame), so every rig and rate is
described alike. Speeds enter as the distance covered in ``action.TIME`` (0.25 s) and the extremes as the
``PERCENTILE``-th percentile over the clip, so that a short action is described by what happens in it, not by the
standing frames around it, and a glitch of a frame does not count. Derivation and measurements: docs/evaluation.md
("Short actions: what happens in a clip").
"""

import numpy as np

from ...rigs.body import POINTS
from .action import TIME, action_channels

_ANKLES = [POINTS.index("ankle.L"), POINTS.index("ankle.R")]
_SHOULDERS = [POINTS.index("shoulder.L"), POINTS.index("shoulder.R")]
_WRISTS = [POINTS.index("wrist.L"), POINTS.index("wrist.R")]
_HEAD = POINTS.index("head")

__all__ = ["PARTS", "BODY", "PERCENTILE", "WEIGHT", "IN_PLACE", "SHOULDER_BAND", "ARM_WEIGHT", "STRIKE_GATE", "UNION",
           "ground_velocity", "travel_velocity", "describe", "description_of", "described_rows",
           "description_distances", "arm_distances", "description_scores", "strikes", "striking_nearest"]

PARTS = ("speed", "forward", "sideways", "rise", "clearance", "vertical", "strike", "guard")
BODY = 6  # the first BODY parts are the body's (``description_distances``), the others the arms' (``arm_distances``)
PERCENTILE = 85.0  # the extremes of a clip (its rise, its highest lower foot, its fastest vertical motion, strike)
WEIGHT = 2.0  # the body's description distance in the shortlist's final score (``local.shortlist_scores``)
IN_PLACE = 0.5  # a clip whose pelvis moves less than this share of the ground's median speed plays in place
SHOULDER_BAND = 0.25  # leg lengths: a hand this near its shoulder's height is "at shoulder height"
ARM_WEIGHT = 5.0  # the arms' distance in the final score for a query that strikes at least STRIKE_GATE ...
STRIKE_GATE = 0.4  # ... and in proportion below it (a query that does not strike does not compare the arms)
UNION = 3  # for a striking query, this many clips nearest by the arms join the shortlist (``striking_nearest``)


def ground_velocity(feat) -> np.ndarray:
    """(T, 2) how the ground under the lower foot moves as the body sees it: minus the lower ankle's horizontal
    velocity relative to the pelvis in the body's frame (leg lengths per second; the body's x, y). A foot on the
    ground is still in the world, so this is the body's travel over the ground, also for a clip without root motion."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3)[:, _ANKLES]
    v = np.gradient(pose, axis=0) * float(feat["rate"]) if len(pose) > 1 else np.zeros_like(pose)
    lower = np.argmin(pose[..., 2], axis=1)
    return -v[np.arange(len(pose)), lower, :2]


def travel_velocity(feat, channels=None) -> np.ndarray:
    """(T, 2) the body's horizontal velocity in its own frame (leg lengths per second; x, y, forward -y): the
    pelvis' (``action_channels``), or the ground's (``ground_velocity``) when the pelvis moves less than ``IN_PLACE``
    times as fast (medians): a walk exported in place travels as its feet say, one with root motion as its pelvis
    goes (also through airborne phases and slides, where the feet say nothing)."""
    c = action_channels(feat) if channels is None else channels
    pelvis, ground = c[:, :2], ground_velocity(feat)
    if len(c) and np.median(np.hypot(*pelvis.T)) < IN_PLACE * np.median(np.hypot(*ground.T)):
        return ground
    return pelvis


def _arms(feat):
    """(strike, guard): the ``PERCENTILE``-th percentile over frames of the faster hand's forward speed relative to
    its shoulder while within ``SHOULDER_BAND`` of the shoulder's height (0 when neither is), times ``TIME``; the
    median over frames of the nearer hand's distance to the head."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3)
    if not len(pose):
        return 0.0, 0.0
    hand = pose[:, _WRISTS] - pose[:, _SHOULDERS]
    forward = np.gradient(-hand[..., 1], axis=0) * float(feat["rate"]) if len(pose) > 1 else hand[..., 1] * 0.0
    at = np.abs(hand[..., 2]) < SHOULDER_BAND
    strike = TIME * np.percentile(np.where(at, forward, 0.0).max(axis=1), PERCENTILE)
    guard = np.median(np.linalg.norm(pose[:, _WRISTS] - pose[:, None, _HEAD], axis=2).min(axis=1))
    return float(strike), float(guard)


def describe(feat) -> np.ndarray:
    """(8,) float32, ``PARTS``: the body's travel (``travel_velocity``: its median speed, mean forward and absolute
    mean sideways velocity, times ``TIME``), the pelvis' height range between the percentiles 100 - P and P, the P-th
    percentile of the lower ankle's height above the clip's ground (``action_channels``: its median), the P-th
    percentile of the pelvis' vertical speed times ``TIME`` (P = ``PERCENTILE``), and the arms' strike and guard
    (``_arms``). The body's forward is -y."""
    c = action_channels(feat)
    v = travel_velocity(feat, c)
    forward, side = -v[:, 1], v[:, 0]
    low, pelvis = c[:, 3:5].min(axis=1), c[:, 5]
    p, q = PERCENTILE, 100.0 - PERCENTILE
    return np.array([TIME * np.median(np.hypot(forward, side)), TIME * np.mean(forward), TIME * abs(np.mean(side)),
                     np.percentile(pelvis, p) - np.percentile(pelvis, q), np.percentile(low, p),
                     TIME * np.percentile(np.abs(c[:, 2]), p), *_arms(feat)], np.float32)


def description_of(entry):
    """(PARTS,) float64 the entry's description, or None: none stored, or an older recipe's number of parts."""
    d = entry.describe
    return None if d is None or len(d) != len(PARTS) else np.asarray(d, np.float64)


def described_rows(entries) -> np.ndarray:
    """(len(entries), PARTS) float64 the entries' descriptions, a NaN row for an entry without one
    (``description_of``): the library's for ``striking_nearest``."""
    none = np.full(len(PARTS), np.nan)
    rows = [description_of(e) for e in entries]
    return np.array([none if r is None else r for r in rows]).reshape(len(entries), len(PARTS))


def _described(query, candidates):
    """(q, D) float64 of the query's and the candidates' descriptions, or None when one has none (``description_of``).
    """
    q, D = description_of(query), [description_of(c) for c in candidates]
    if q is None or any(d is None for d in D):
        return None
    return q, np.array(D).reshape(len(candidates), len(PARTS))


def description_distances(query, candidates) -> np.ndarray:
    """(len(candidates),) the root mean square of the differences of the entries' body parts (the first ``BODY``,
    leg lengths); zeros when the query or any candidate has no description (an entry of an older recipe)."""
    got = _described(query, candidates)
    if got is None:
        return np.zeros(len(candidates))
    q, D = got
    return np.sqrt(((D[:, :BODY] - q[:BODY]) ** 2).mean(axis=1))


def _gate(q) -> float:
    """How much a query's arms count: its strike over ``STRIKE_GATE``, at most 1."""
    return float(min(1.0, max(q[PARTS.index("strike")], 0.0) / STRIKE_GATE))


def strikes(query) -> bool:
    """Whether the query entry strikes (its arms count: ``arm_distances``, ``striking_nearest``)."""
    q = description_of(query)
    return q is not None and _gate(q) > 0.0


def arm_distances(query, candidates) -> np.ndarray:
    """(len(candidates),) the root mean square of the differences of the arms' parts (strike, guard), times
    ``_gate`` of the query: 0 for a query that does not strike (the guard alone is an actor's posture as much as an
    action's), and zeros without descriptions."""
    got = _described(query, candidates)
    if got is None:
        return np.zeros(len(candidates))
    q, D = got
    return _gate(q) * np.sqrt(((D[:, BODY:] - q[BODY:]) ** 2).mean(axis=1))


def description_scores(query, candidates) -> np.ndarray:
    """(len(candidates),) the description's terms of the shortlist's final score: ``WEIGHT`` times
    ``description_distances`` plus ``ARM_WEIGHT`` times ``arm_distances``."""
    return WEIGHT * description_distances(query, candidates) + ARM_WEIGHT * arm_distances(query, candidates)


def striking_nearest(query, described, n: int = UNION) -> np.ndarray:
    """The indices of the ``n`` rows of ``described`` ((N, PARTS) float, NaN rows: no description) nearest to the
    query by the arms' parts (ties by index), or none when the query does not strike or has no description: the
    clips that strike and guard as it does, for its shortlist (a punch's first stage ranks other rigs' punches far
    behind: docs/evaluation.md)."""
    if n <= 0 or not len(described) or not strikes(query):
        return np.zeros(0, np.int64)
    q = description_of(query)
    D = np.asarray(described, np.float64).reshape(len(described), len(PARTS))
    d = np.sqrt(((D[:, BODY:] - q[BODY:]) ** 2).mean(axis=1))
    d[~np.isfinite(d)] = np.inf
    order = np.argsort(d, kind="stable")[:n]
    return order[np.isfinite(d[order])].astype(np.int64)
