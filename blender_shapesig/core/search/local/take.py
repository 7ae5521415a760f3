"""The same take in another file: the whole take's level-2 log-signature of the development of its comparison-space
curve on every canonical joint (``take_entry``, stored beside the local entry), compared on the joints both clips
have (``take_distances``: the package's ``linear2``, still joints kept). It sees motion only, so a converter's
constant bone offsets do not change it, and the whole take, so another take of the same motion differs. One rule
uses it (``twin_first``): a shortlisted clip of the query's length whose take is much nearer than the shortlist's
typical take ranks first, unless the first is longer than the query and holds the query's windows better (it may
be the clip the query was cut from). Measurements: docs/model.md, "The same take in another file first"."""

import math

import numpy as np

from ...clip.clip import Clip
from ...clip.prepare import SIGNATURE_SMOOTH_SECONDS, prepare_clip
from ...rigs import JOINTS
from ...signatures import signatures as sg
from .entry import Take

__all__ = ["JOINTS", "CHANNELS", "DIM", "TWIN_RATIO", "SAME_LENGTH", "take_entry", "take_distances", "twin_first"]

CHANNELS = 3 * len(JOINTS)
_IU = np.triu_indices(CHANNELS, 1)  # the Lyndon words [i, j], i < j, of level 2 in iisignature's order
DIM = CHANNELS + len(_IU[0])
# the rule's two constants: the twin's take distance at most this share of the shortlist's median ...
TWIN_RATIO = 0.5
# ... and "the same length": durations within 8 % (converters trim a few frames at either end; a 10 % cut is not)
SAME_LENGTH = math.log(1.08)


def take_entry(clip: Clip) -> Take:
    """``take`` (DIM,) float32: level 1 then level 2 (Lyndon basis) of the log-signature of the development of the
    comparison-space clip at the comparison rate, joint j in channels 3j..3j+2 of ``JOINTS`` (zeros where the rig
    has no such joint); ``take_mask`` (len(JOINTS),) uint8: the joints it has; ``seconds``: its span."""
    c = prepare_clip(clip, smooth=SIGNATURE_SMOOTH_SECONDS)
    keep = [i for i, b in enumerate(c.bones) if b in JOINTS]
    have = np.array([JOINTS.index(c.bones[i]) for i in keep], dtype=int)
    dx = np.zeros((max(c.frames - 1, 1), CHANNELS))
    if c.frames > 1 and keep:
        dx[:, (3 * have[:, None] + np.arange(3)).ravel()] = sg.development_increments(c.rotations, keep)
    mask = np.zeros(len(JOINTS), np.uint8)
    mask[have] = 1
    take = sg.increments_log_signature(dx, 2).astype(np.float32)
    return Take(take, mask, np.float32((clip.frames - 1) / clip.fps))


def _kept(mask_a, mask_b):
    ch = np.repeat(np.asarray(mask_a, bool) & np.asarray(mask_b, bool), 3)
    return np.concatenate([ch, ch[_IU[0]] & ch[_IU[1]]])


def take_distances(query, candidates) -> np.ndarray:
    """(len(candidates),) Euclidean distances of the takes on the channels of the joints both have."""
    q = np.asarray(query.take, np.float64)
    out = np.empty(len(candidates))
    for i, c in enumerate(candidates):
        keep = _kept(query.take_mask, c.take_mask)
        d = q[keep] - np.asarray(c.take, np.float64)[keep]
        out[i] = math.sqrt(float(d @ d))
    return out


def twin_first(query, candidates, score, held=None) -> np.ndarray:
    """The shortlist's scores with the query's twin (if any) made the lowest: among the candidates whose duration
    is the query's (``SAME_LENGTH``), the nearest take moves first when its take distance is below ``TWIN_RATIO``
    times the shortlist's median, unless the current first is longer than the query and holds the query's windows
    at least as well (it may be the clip the query was cut from): ``held(clips)`` gives how well each of the clips
    holds the query (``local.held_distances``; without it, a longer first always stays). The twin's new score is the
    first's times (its distance / the gate), so the order and the shown scores agree. Entries without a take, or a
    first that is the query's exact copy (score 0): unchanged."""
    score = np.asarray(score, float)
    if len(candidates) < 2 or query.take is None or any(c.take is None for c in candidates):
        return score
    first = int(np.argmin(score))
    if not score[first] > 0:
        return score
    lengths = np.log(np.maximum([float(c.seconds) for c in candidates], 1e-9) / max(float(query.seconds), 1e-9))
    same = np.flatnonzero(np.abs(lengths) <= SAME_LENGTH)
    if not len(same):
        return score
    g = take_distances(query, candidates)
    gate = TWIN_RATIO * _median(g)
    e = int(same[np.argmin(g[same])])
    if e == first or not g[e] < gate:
        return score
    if lengths[first] > SAME_LENGTH:
        if held is None:
            return score
        h_twin, h_first = held([candidates[e], candidates[first]])
        if not h_twin < h_first:
            return score
    out = score.copy()
    out[e] = score[first] * g[e] / gate
    return out


def _median(v) -> float:
    """``np.median`` of a 1-D array, the same value without importing ``numpy.ma`` (5 ms of a command's start)."""
    s = np.sort(np.asarray(v, float).ravel())
    if not len(s) or np.isnan(s[-1]):
        return float("nan")
    return float((s[(len(s) - 1) // 2] + s[len(s) // 2]) / 2)
