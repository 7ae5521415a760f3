"""Local search: clips compared by what animators call "the same motion" (issue 29): pose and motion, by windows.

Per clip (``features``): the positions of a few key points (head, shoulders, elbows, wrists, knees, ankles) of a
canonical body posed like the clip (``core.rigs.body``: the rig's segment directions by forward kinematics on the
canonical joints of the comparison space; an adult's proportions in leg lengths), relative to the pelvis in the body's
own horizontal frame (the facing of the hips and shoulders removed frame by frame), so rigs, body sizes, units and
directions do not matter; plus the hips' path in that turning frame and the turned angle (the motion
channels), all at ``RATE`` samples per second. **First stage** (``index_entry``, ``first_stage``): the clip's
sliding windows (``WINDOWS``: 0.5 and 1 s, hop a quarter window), each described by its mean pose (the basepoint)
and the level-2 log-signature of its path (level 1 = displacement, level 2 = Levy areas, brought to degree one by a
signed square root), normalized to unit length part by part (eq. 9.1 of the thesis, window by window; a still
window's motion parts, below a floor, get a stillness coordinate that puts them on the unit sphere too), projected by a
fixed, data-independent random matrix to ``DIM`` numbers and stored as float16; two clips are at the symmetric mean of
their windows' nearest-window distances (a Chamfer distance): crops, start phase and the number of cycles do not
matter. **Second stage** (``rerank``): the shortlist again by dynamic time warping of the key points' positions
(Sakoe-Chiba band, open ends; ``local_dtw``: compiled when numba is loaded, else by numpy anti-diagonals);
``combine`` scores the shortlist by both stages, and the same take in another file ranks first
(``take.twin_first``); ``shortlist_scores`` does both, ``search`` runs it all. Pure numpy (numba optional); no
bpy. Measured in experiments/local_search/RESULTS.md.
"""

import math
from typing import Dict, List, Mapping, Sequence

import numpy as np

from ...clip.clip import Clip
from ...rigs.body import POINTS, SEGMENTS, body_positions, rig_positions
from . import action as local_action, description as local_description, dtw as local_dtw, take
from .dtw import dtw
from .entry import LocalEntry
# the first stage lives in ``stage_one``; its names stay importable from here
from .stage_one import (PREFILTER, PREFILTER_SHARE, _chunks, _coarse_norms, _sq_dist, _take,  # noqa: F401
                        coarse_distances, coarse_windows, first_stage, gather_rows, nearest, stack)


__all__ = ["RATE", "WINDOWS", "HOP", "DIM", "SHORTLIST", "MAX_WINDOWS", "MAX_SEQUENCE", "MIX", "ACTION_WEIGHT", "FREE",
           "BAND",
           "POINTS", "SEGMENTS", "Settings", "DEFAULT", "settings_key", "rig_positions", "body_positions", "features",
           "window_vectors", "whole_path", "index_entry", "entry_from_features", "entry_bytes", "stack", "nearest",
           "PREFILTER", "PREFILTER_SHARE", "coarse_windows", "coarse_distances", "gather_rows", "first_stage", "dtw",
           "rerank", "path_distances", "combine", "shortlisted", "shortlist_scores", "search"]

RATE = 30.0  # samples per second of the features
WINDOWS = (0.5, 1.0)  # seconds per window, two scales (clips shorter than a window have one window of that scale)
HOP = 0.25  # between windows, a fraction of the window
DIM = 96  # numbers per window in the index
SHORTLIST = 25  # clips the second stage re-ranks (the first stage's nearest; plus, for a striking query, the clips
# nearest by the arms: ``shortlisted``)
# the index's size: at most this many windows per scale (a longer hop beyond 20 s) and samples of the second stage's
# sequence (a lower rate beyond 13 s): <= 2 * 80 * 96 * 2 + 200 * 33 * 2 bytes = 43 KB per clip (39 columns, 46 KB,
# with the action part)
MAX_WINDOWS = 80
MAX_SEQUENCE = 200
# weight of the action part (``local_action``: travel, heights, reach, limb speeds; issue 41). Off by default: at 2
# it raises the rig set from 30 to 35 of 51, HDM05's mAP to 0.983 and cmu_large to 49/49, but one crop probe of
# cmu_mixed_format flips to the same take's other file at a tie (experiments/local_search/RESULTS.md)
ACTION_WEIGHT = 0.0
# weight of each window's stillness coordinate (``_stillness``): with it every window's motion parts lie on the unit
# sphere and a still window is sqrt(2) from a moving one, as two unrelated motions are; without it (0) a standing
# clip was nearer every short action than clips of its class (issue 41, docs/search.md "Short actions")
STILL = 1.0
MIX = 1.0  # weight of the first stage in the shortlist's final score (``combine``)
FREE = 0.15  # the second stage may leave out this fraction of either sequence at each end
BAND = 0.25  # Sakoe-Chiba band of the second stage, a fraction of the longer sequence (plus the length difference)


# changes when the features change for the same settings (e.g. the leg of a rig without a foot bone): stored
# entries made by an older recipe are then computed again, never used
RECIPE_VERSION = 4  # 4: the description's travel once (the ground's for a clip in place) and the arms' numbers


class Settings:
    """The recipe's constants in one object (experiments vary them; the defaults are the module's)."""

    def __init__(self, rate=RATE, windows=WINDOWS, hop=HOP, dim=DIM, pose_weight=1.0, motion_weight=1.0,
                 turn_weight=0.5, normalize="parts", seed=29, step=2, sequence="pose", velocity_weight=0.0,
                 scale_weight=1.0, global_weight=0.0, max_windows=MAX_WINDOWS, max_sequence=MAX_SEQUENCE,
                 action_weight=ACTION_WEIGHT, active=0.0, still=STILL, travel=0.0, height=0.0, describe=True):
        self.rate, self.windows, self.hop, self.dim = float(rate), tuple(windows), float(hop), dim
        self.pose_weight, self.motion_weight, self.turn_weight = pose_weight, motion_weight, turn_weight
        self.normalize, self.seed, self.step = normalize, seed, step
        self.sequence, self.velocity_weight, self.scale_weight = sequence, velocity_weight, scale_weight
        self.global_weight, self.max_windows, self.max_sequence = global_weight, max_windows, max_sequence
        # issue 41 (``local_action``): the action part's weight, the share of the largest window energy kept; the
        # options ``travel`` (the pelvis' path in a window as a part of its own, unit length) and ``height`` (the
        # second stage's key points at the pelvis' height about its median) are off: experiments/local_search/RESULTS.md
        self.action_weight, self.active = float(action_weight), float(active)
        self.still, self.travel, self.height = float(still), float(travel), float(height)
        # the entries carry what happens in the clip (``local_description``), a term of the shortlist's score
        self.describe = bool(describe)

    def key(self):
        extra = (self.action_weight, self.active) if (self.action_weight or self.active) else ()
        extra += ("still", self.still) if self.still else ()
        extra += ("travel", self.travel) if self.travel else ()
        extra += ("height", self.height) if self.height else ()
        extra += ("describe", local_description.PERCENTILE) if self.describe else ()
        return (RECIPE_VERSION, self.rate, self.windows, self.hop, self.dim, self.pose_weight, self.motion_weight, self.turn_weight,
                self.normalize, self.seed, self.step, self.sequence, self.velocity_weight, self.scale_weight,
                self.global_weight, self.max_windows, self.max_sequence) + extra


DEFAULT = Settings()


_KEYS = {}


def settings_key(settings: Settings = DEFAULT) -> str:
    """The settings as text: part of a stored entry's key (``SignatureCache.local.put``; remembered by value: a
    click asks once per library item)."""
    k = settings.key()
    text = _KEYS.get(k)
    if text is None:
        text = _KEYS[k] = repr(k)
    return text


# ------------------------------------------------------------------------------------------------- features

def _resample(x, fps, rate):
    """Linear interpolation of (frames, ...) at ``rate`` samples per second (the same span in seconds)."""
    F = x.shape[0]
    if F < 2 or abs(fps - rate) < 1e-9:
        return x
    n = int(math.floor((F - 1) * rate / fps + 1e-9)) + 1
    s = np.arange(n) * (fps / rate)
    i = np.minimum(np.floor(s).astype(int), F - 2)
    w = (s - i).reshape((-1,) + (1,) * (x.ndim - 1))
    return x[i] * (1 - w) + x[i + 1] * w


def _facing(side):
    """(frames,) the body's yaw: the angle of its horizontal right-to-left direction (hips and shoulders),
    unwrapped (the facing is a quarter turn from it; only differences and the frame matter)."""
    return np.unwrap(np.arctan2(side[:, 1], side[:, 0]))


def features(clip: Clip, settings: Settings = DEFAULT) -> Dict[str, np.ndarray]:
    """The clip's channels at ``settings.rate``: ``pose`` (T, 3 * points) the key points relative to the hips in the
    body's horizontal frame (leg lengths), ``motion`` (T, 4) the hips' path integrated in that turning frame and
    the turned angle (radians, from the first sample)."""
    hips, P, side = body_positions(clip)
    hips = _resample(hips, clip.fps, settings.rate)
    P = _resample(P, clip.fps, settings.rate)
    yaw = _facing(_resample(side, clip.fps, settings.rate))
    c, s = np.cos(yaw), np.sin(yaw)
    rel = P - hips[:, None]
    local = np.stack([c[:, None] * rel[..., 0] + s[:, None] * rel[..., 1],
                      -s[:, None] * rel[..., 0] + c[:, None] * rel[..., 1], rel[..., 2]], axis=-1)
    dh = np.diff(hips, axis=0)
    cm, sm = c[:-1], s[:-1]
    dl = np.stack([cm * dh[:, 0] + sm * dh[:, 1], -sm * dh[:, 0] + cm * dh[:, 1], dh[:, 2]], axis=1)
    path = np.vstack([np.zeros((1, 3)), np.cumsum(dl, axis=0)])
    motion = np.column_stack([path, yaw - yaw[0]])
    return {"pose": local.reshape(len(local), -1), "motion": motion, "rate": np.float64(settings.rate)}


# ------------------------------------------------------------------------------------------------- windows

def _windows(T, rate, window, hop, most=None):
    """Start indices and the length (samples) of the sliding windows of T samples; one window if shorter; at most
    ``most`` windows (a longer hop in long clips)."""
    w = max(2, int(round(window * rate)))
    step = max(1, int(round(hop * rate)))
    if T <= w:
        return np.array([0]), T
    if most and (T - w) // step + 1 > most:
        step = int(math.ceil((T - w) / (most - 1)))
    starts = np.arange(0, T - w + 1, step)
    if starts[-1] != T - w:
        starts = np.append(starts, T - w)
    return starts, w


def _levy_areas(X, starts, w):
    """(windows, d(d-1)/2): the Levy areas (level 2 of the log-signature, Lyndon basis [i, j], i < j) of each
    window X[s:s+w] (``w`` samples), by prefix sums: A_ij = 1/2 sum_k (Y_i dX_j - Y_j dX_i), Y = X - X[s]."""
    d = X.shape[1]
    dX = np.diff(X, axis=0)
    M = np.einsum("ki,kj->kij", X[:-1], dX)  # X_k (x) dX_k
    cM = np.concatenate([np.zeros((1, d, d)), np.cumsum(M, axis=0)])
    cD = np.concatenate([np.zeros((1, d)), np.cumsum(dX, axis=0)])
    e = starts + w - 1
    S = cM[e] - cM[starts] - np.einsum("wi,wj->wij", X[starts], cD[e] - cD[starts])
    A = 0.5 * (S - np.swapaxes(S, 1, 2))
    iu = np.triu_indices(d, 1)
    return A[:, iu[0], iu[1]]


def _unit_rows(x, floor):
    n = np.linalg.norm(x, axis=1, keepdims=True)
    return x / np.maximum(n, floor)


def _stillness(*parts):
    """(windows, len(parts)): per normalized motion part (length <= 1), sqrt(1 - length^2): 0 for a moving window,
    1 for a still one, so that [part, stillness] lies on the unit sphere."""
    return np.column_stack([np.sqrt(np.maximum(0.0, 1.0 - (p * p).sum(axis=1))) for p in parts])


_PROJECTIONS = {}


def _projection(n_in, dim, seed):
    key = (n_in, dim, seed)
    if key not in _PROJECTIONS:
        rng = np.random.default_rng(seed)
        _PROJECTIONS[key] = (rng.standard_normal((n_in, dim)) / math.sqrt(dim)).astype(np.float32)
    return _PROJECTIONS[key]


def window_vectors(feat: Mapping[str, np.ndarray], settings: Settings = DEFAULT) -> np.ndarray:
    """(windows, n) the unprojected window descriptors of every scale (``settings.windows`` seconds, hop
    ``settings.hop`` of each): [mean pose, level 1, signed-sqrt level 2] of the path [pose, motion], each part
    normalized (``settings.normalize``: "parts" = unit length with a floor, eq. 9.1 per window; "none" = raw, leg
    lengths) and weighted, plus a one-hot of the scale (windows of other lengths are not each other's nearest)."""
    pose, motion = feat["pose"], feat["motion"].copy()
    motion[:, 3] *= settings.turn_weight
    X = np.column_stack([pose, motion])
    cP = np.concatenate([np.zeros((1, pose.shape[1])), np.cumsum(pose, axis=0)])
    act = local_action.action_channels(feat) if settings.action_weight else None
    out = []
    for k, window in enumerate(settings.windows):
        starts, w = _windows(len(X), float(feat["rate"]), window, settings.hop * window, settings.max_windows)
        base = (cP[starts + w] - cP[starts]) / w
        lvl1 = X[starts + w - 1] - X[starts]
        lvl2 = _levy_areas(X, starts, w)
        lvl2 = np.sign(lvl2) * np.sqrt(np.abs(lvl2))
        if settings.normalize == "parts":
            # a still window has no direction: below the floor (leg lengths) its motion parts keep their size
            base = _unit_rows(base, 1e-6)
            lvl1 = _unit_rows(lvl1, 0.25)
            lvl2 = _unit_rows(lvl2, 0.25)
        scale = np.zeros((len(starts), len(settings.windows)))
        scale[:, k] = settings.scale_weight
        parts = [settings.pose_weight * base, settings.motion_weight * lvl1, settings.motion_weight * lvl2, scale]
        if settings.still:
            parts.append(settings.still * settings.motion_weight * _stillness(lvl1, lvl2))
        if settings.travel:
            trav = _unit_rows(motion[starts + w - 1] - motion[starts], 0.25)
            parts += [settings.travel * trav, settings.travel * settings.still * _stillness(trav)]
        if act is not None:
            parts.append(settings.action_weight * local_action.window_action(act, starts, w))
        V = np.column_stack(parts)
        if settings.active:
            V = V[local_action.active_rows(local_action.window_energy(feat, starts, w), settings.active)]
        out.append(V)
    return np.concatenate(out)


def index_entry(clip: Clip, settings: Settings = DEFAULT) -> LocalEntry:
    """The compact arrays the search keeps per clip (a ``LocalEntry`` named as the clip): ``windows`` (N, DIM)
    float16 (projected window descriptors), ``sequence`` (T', 3 * points) float16 (the pose every
    ``settings.step``-th sample, for the second stage), ``path`` (10,), ``describe`` and the whole take
    (``take.take_entry``: ``take``, ``take_mask``, ``seconds``)."""
    entry = entry_from_features(features(clip, settings), settings)
    got = take.take_entry(clip)
    entry.name, entry.take, entry.take_mask, entry.seconds = clip.name, got.take, got.take_mask, got.seconds
    return entry


def _sequence(feat, settings):
    """The second stage's sequence: the pose (``settings.sequence`` "centered": minus its mean over the clip) and,
    with ``velocity_weight``, the motion channels' rates (leg lengths and radians per second)."""
    seq = feat["pose"]
    if settings.sequence == "centered":
        seq = seq - seq.mean(axis=0)
    if settings.action_weight and settings.sequence != "pose_only":
        seq = np.column_stack([seq, settings.action_weight * local_action.sequence_channels(feat)])
    if settings.height and settings.sequence == "pose":  # every key point at the pelvis' height about its median
        pz = feat["motion"][:, 2]
        seq = seq.reshape(len(seq), -1, 3).copy()
        seq[..., 2] += settings.height * (pz - np.median(pz))[:, None]
        seq = seq.reshape(len(seq), -1)
    if settings.velocity_weight:
        vel = np.gradient(feat["motion"], axis=0) * float(feat["rate"]) if len(seq) > 1 else feat["motion"] * 0
        seq = np.column_stack([seq, settings.velocity_weight * vel])
    return seq[::max(settings.step, int(math.ceil(len(seq) / settings.max_sequence)))]


def whole_path(feat) -> np.ndarray:
    """(10,) the whole clip's level-2 log-signature of its motion channels (the pelvis' path in the turning frame
    and the turned angle; level 2 by signed square root): where, how far and how the take turns."""
    X = feat["motion"]
    lvl2 = _levy_areas(X, np.array([0]), len(X))[0]
    return np.concatenate([X[-1] - X[0], np.sign(lvl2) * np.sqrt(np.abs(lvl2))])


def entry_from_features(feat, settings: Settings = DEFAULT):
    """``index_entry`` from ``features``. The projection is multiplied in float64 so that the float16 entry does not
    depend on how many BLAS threads ran the product (a cluster's worker and this process store the same bytes)."""
    V = window_vectors(feat, settings)
    if settings.dim:
        V = V @ _projection(V.shape[1], settings.dim, settings.seed).astype(np.float64)
    return LocalEntry(windows=V.astype(np.float16), sequence=_sequence(feat, settings).astype(np.float16),
                      path=whole_path(feat).astype(np.float32),
                      describe=local_description.describe(feat) if settings.describe else None)


def entry_bytes(entry: LocalEntry) -> int:
    return entry.nbytes()


# ------------------------------------------------------------------------------------------------- stage two

def _band(n, m, band=BAND):
    return int(math.ceil(band * max(n, m))) + 1


def rerank(query, candidates: Sequence, band: float = BAND, free: float = FREE) -> np.ndarray:
    """(len(candidates),) DTW distances of the query's pose sequence to each candidate's, divided by the square
    root of the sum of the two lengths (clips of other durations stay comparable); up to ``free`` of either
    sequence's length may be left out at each end (crops)."""
    a = np.ascontiguousarray(query.sequence, dtype=np.float64)
    bs = [np.ascontiguousarray(c.sequence, dtype=np.float64) for c in candidates]
    if not bs:
        return np.empty(0)
    if not local_dtw.kernel_ready() and len(bs) > 1:  # numpy: the shortlist at once
        fa = min(int(free * len(a)), len(a) - 1)
        out = local_dtw._dtw_many(a, bs, [max(_band(len(a), len(b), band), 1) for b in bs], [fa] * len(bs),
                        [max(0, min(int(free * len(b)), len(b) - 1)) for b in bs])
    else:
        out = np.array([dtw(a, b, _band(len(a), len(b), band), int(free * len(a)), int(free * len(b))) for b in bs])
    return out / np.sqrt(len(a) + np.array([len(b) for b in bs], float))


def combine(d1, d2, mix=MIX, dg=None, global_weight=0.0) -> np.ndarray:
    """The shortlist's final score: d2 / mean(d2) + mix * d1 / mean(d1) (+ global_weight * dg / mean(dg), ``dg``
    the distances of the whole clips' paths); each term relative to the shortlist (finite values), so no unit
    matters; mix = 0: the second stage alone."""
    def rel(x):
        x = np.asarray(x, float)
        fin = x[np.isfinite(x)]
        return x / max(fin.mean() if len(fin) else 1.0, 1e-12)

    s = rel(d2)
    if mix:
        s = s + mix * rel(d1)
    if global_weight and dg is not None:
        s = s + global_weight * rel(dg)
    return s


def held_distances(query, candidates: Sequence) -> np.ndarray:
    """(len(candidates),) how well each candidate holds the query: the mean over the query's windows of the distance
    to the candidate's nearest window (the query's side of ``first_stage``; about 0 for the clip a crop was cut
    from)."""
    q = np.asarray(query.windows, np.float32)
    return np.array([float(np.sqrt(_sq_dist(q, np.asarray(c.windows, np.float32))).min(axis=1).mean())
                     for c in candidates])


def shortlisted(query, entries: Sequence, d1, n: int = SHORTLIST, described=None) -> np.ndarray:
    """The indices of the entries the second stage re-ranks: the ``n`` nearest by the first stage ``d1``
    (``nearest``), then, for a query that strikes, the ``description.UNION`` nearest by the arms among the entries
    with a finite ``d1`` (``description.striking_nearest``) that are not already among them. ``described``: the
    entries' ``description.described_rows`` when known (a library's, memoized with its stack), else read from them."""
    d1 = np.asarray(d1, float)
    head = nearest(d1, max(int(n), 1))
    if local_description.UNION <= 0 or not local_description.strikes(query):
        return head
    pool = np.flatnonzero(np.isfinite(d1))
    rows = (local_description.described_rows([entries[i] for i in pool]) if described is None
            else np.asarray(described, np.float64)[pool])
    extra = pool[local_description.striking_nearest(query, rows)]
    extra = extra[~np.isin(extra, head)]
    return np.concatenate([head, extra]).astype(np.int64) if len(extra) else head


def shortlist_scores(query, candidates: Sequence, d1, mix: float = MIX, dg=None, global_weight: float = 0.0):
    """(score, d2): the shortlist's final scores (``combine`` of the first stage's ``d1`` and the DTW ``d2``, plus
    the description's terms, ``description.description_scores``: how far apart what happens in the clips is, leg
    lengths, and for a striking query what the arms do; the query's twin first: ``take.twin_first``) and the DTW
    distances, for the candidates in the first stage's order."""
    d2 = rerank(query, candidates)
    score = combine(d1, d2, mix, dg, global_weight)
    score = score + local_description.description_scores(query, candidates)
    return take.twin_first(query, candidates, score, lambda picked: held_distances(query, picked)), d2


def path_distances(query, candidates) -> np.ndarray:
    q = np.asarray(query.path, float)
    return np.array([np.linalg.norm(np.asarray(c.path, float) - q) for c in candidates])


def search(query, entries: Sequence, shortlist: int = SHORTLIST, mix: float = MIX,
           settings: Settings = DEFAULT, library=None) -> List[int]:
    """The entries' indices, best first: all by ``first_stage`` (on ``library``, the entries' ``stack``, when
    given), the ``shortlisted`` re-ranked by ``shortlist_scores`` (and the whole paths when
    ``settings.global_weight``), the others after them in the first stage's order."""
    d1 = first_stage(query, entries if library is None else library)
    head = [int(i) for i in shortlisted(query, entries, d1, shortlist)]
    cands = [entries[i] for i in head]
    dg = path_distances(query, cands) if settings.global_weight else None
    score, _ = shortlist_scores(query, cands, d1[head], mix, dg, settings.global_weight)
    taken = set(head)
    return [head[i] for i in np.argsort(score, kind="stable")] + [int(i) for i in np.argsort(d1, kind="stable")
                                                                   if int(i) not in taken]
