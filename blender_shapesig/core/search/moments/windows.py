"""Moments: rank (clip, window) pairs against a query, not whole clips, every occurrence in a take. Windows are
scored by the local search's pose and motion (``moment_sequence``: key points relative to the hips, the hips'
velocity and turn rate) against the query by a DTW with a free window (``local_dtw.subsequence_dtw``, every end
at once); clips those features cannot read (no legs), and every clip for such a query, by sim^n from prefix
signatures (Chen's identity, one product per window) on the comparison time base. A take's windows pass a
non-maximum suppression (``_distinct``), and the best moments are refined by the elastic DP with a free window
(``core.elastic.subsequence``); results carry ``start`` / ``end`` in the clip's own frame numbers. See
docs/search.md, "Moments".
"""

import time
from dataclasses import replace

import numpy as np

from ...geometry import so3
from ...signatures import tensor
from ...clip.clip import Clip, restrict_to_shared
from ...errors import CurveError, ShapeSigError
from ...elastic import DEFAULT_DEPTH
from ...clip.prepare import SIGNATURE_SMOOTH_SECONDS, SMOOTH_SECONDS, prepare_clip
from ...rigs import coverage_report, moving_count
from ...signatures.signatures import normalized_difference
from ...io.sources import LibraryItem, as_items
from ...progress import wants_cancel
from ..local import features as local
from ..local.dtw import subsequence_dtw
from ..rows import FEW_SHARED, RankList, RankResult, coverage_rule

__all__ = ["WINDOW_LEVEL", "SCALES", "STRIDE", "REFINE", "MOMENT_STEP", "MOMENT_VELOCITY", "prefix_signatures",
           "window_log_signatures", "clip_windows", "moment_sequence", "position_windows", "rank_windows",
           "query_clip", "retimed_excerpt"]

WINDOW_LEVEL = 2
SCALES = (0.67, 0.8, 1.0, 1.25, 1.5)
STRIDE = 0.1       # window starts every STRIDE x the query's duration
REFINE = 10        # moments refined by the free-window DP when no rerank is asked
MOMENT_STEP = 2    # the pose and motion windows compare every 2nd sample of the local features (15 per second)
MOMENT_VELOCITY = 0.5  # weight of the hips' velocity and turn rate (leg lengths, radians per second) beside the pose
MOMENT_SPEEDS = (0.5, 2.0)  # a moment lasts between these multiples of the query's duration
POSE_METRIC, ROTATION_METRIC = "pose windows", f"sim{WINDOW_LEVEL} windows"  # the measure of a moment's distance
PAD = 0.5          # each refined window is padded by PAD x its length on both sides


def _increments(R):
    """The development's increments (frames-1, 3 joints)."""
    inc = so3.relative_rotvecs(R)
    return inc.reshape(inc.shape[0], -1)


def prefix_signatures(dx, positions, level=WINDOW_LEVEL):
    """Prefix signatures P_p = S(x)_{0,p} (tensors, levels 0..level) of the path with increments ``dx`` at the
    increasing frame ``positions`` (0 <= p <= len(dx)), each from the previous one by Chen's identity."""
    dim = dx.shape[1]
    out, prev, cur = [], 0, tensor.one(dim, level)
    for p in positions:
        if p > prev:
            cur = tensor.mul(cur, tensor.signature_from_increments(dx[prev:p], level), level)
            prev = p
        out.append(cur)
    return out


def window_log_signatures(prefixes, pairs, dim, level=WINDOW_LEVEL):
    """Flattened log-signatures (tensor coordinates) of the windows (a, b) between prefixes a and b:
    log(P_a^{-1} ⊗ P_b)."""
    inverse = {}
    out = []
    for a, b in pairs:
        if a not in inverse:
            inverse[a] = tensor.antipode(prefixes[a], dim)
        out.append(tensor.flatten(tensor.log(tensor.mul(inverse[a], prefixes[b], level))))
    return out


def _log_signature(dx, level):
    return tensor.flatten(tensor.log(tensor.signature_from_increments(dx, level)))


def clip_windows(query_frames, frames, scales=SCALES, stride=STRIDE):
    """Windows (start, end) in comparison frames of a clip of ``frames`` for a query of ``query_frames``
    (inclusive ends), and the grid of prefix positions they start and end on."""
    n = frames - 1
    step = max(1, int(round(stride * (query_frames - 1))))
    lengths = sorted({max(1, int(round(s * (query_frames - 1)))) for s in scales})
    wins = set()
    for length in lengths:
        if length >= n:
            wins.add((0, n))
            continue
        starts = list(range(0, n - length + 1, step))
        if starts[-1] != n - length:
            starts.append(n - length)  # the last window ends on the clip's last frame
        wins.update((s, s + length) for s in starts)
    wins = sorted(wins)
    grid = sorted({p for w in wins for p in w})
    return wins, grid


def moment_sequence(clip: Clip) -> np.ndarray:
    """(samples, channels) what a moment compares, at ``local.RATE / MOMENT_STEP`` samples per second: the key points
    relative to the hips in the body's frame (``local.features``' pose, leg lengths) and ``MOMENT_VELOCITY`` times the
    hips' velocity in that turning frame and the turn rate (airborne phases, direction of travel, speed).
    ShapeSigError when the clip has no legs for the local features."""
    f = local.features(clip)
    motion = f["motion"]
    vel = np.gradient(motion, axis=0) * float(f["rate"]) if len(motion) > 1 else np.zeros_like(motion)
    return np.column_stack([f["pose"], MOMENT_VELOCITY * vel])[::MOMENT_STEP]


def position_windows(query_seq, seq):
    """Every window of a clip's ``moment_sequence`` against the query's, best first: [(score, start, end)] in
    30-per-second samples (inclusive), one per end sample (its best start, ``subsequence_dtw``); the score is the
    root mean square distance along the path (its squared cost over the two lengths). Windows lasting less than
    ``MOMENT_SPEEDS[0]`` or more than ``MOMENT_SPEEDS[1]`` times the query are left out (a whole clip shorter than
    that keeps its best window)."""
    D, S = subsequence_dtw(query_seq, seq)
    ends = np.arange(len(seq))
    length = ends - S
    score = np.sqrt(np.maximum(D, 0.0) / (len(query_seq) + length + 1))
    n = len(query_seq) - 1
    fits = (length >= np.floor(MOMENT_SPEEDS[0] * n)) & (length <= np.ceil(MOMENT_SPEEDS[1] * n))
    order = [j for j in np.argsort(score, kind="stable") if fits[j]] or [int(np.argmin(score))]
    return [(float(score[j]), int(S[j]) * MOMENT_STEP, int(j) * MOMENT_STEP) for j in order]


def _to_clip_frame(clip: Clip, frames_compared, f):
    return int(clip.frame_start + round(f * (clip.frames - 1) / max(frames_compared - 1, 1)))


class _Query:
    """The query on the comparison time base, per set of shared bones (prepared once each)."""

    def __init__(self, clip, level):
        self.clip, self.level, self._cache = clip, level, {}
        self.seq = self._sequence(clip)

    @staticmethod
    def _sequence(clip):
        try:
            return moment_sequence(clip)
        except ShapeSigError:
            return None

    def sequence(self, clip):
        """The clip's ``moment_sequence`` when the query has one, else None (both compared by rotations)."""
        return None if self.seq is None else self._sequence(clip)

    def pair(self, clip):
        a, b = restrict_to_shared(self.clip, clip)
        if a.bones not in self._cache:
            sig = prepare_clip(a, smooth=SIGNATURE_SMOOTH_SECONDS)
            self._cache[a.bones] = (sig, _log_signature(_increments(sig.rotations), self.level))
        return a, b, self._cache[a.bones]


def _best_windows(query, clip, level, scales, stride):
    """(sorted [(sim, start, end)] in comparison frames, the clip on the signature time base)."""
    q, b, (qsig, qlog) = query.pair(clip)
    bsig = prepare_clip(b, smooth=SIGNATURE_SMOOTH_SECONDS)
    dx = _increments(bsig.rotations)
    wins, grid = clip_windows(qsig.frames, bsig.frames, scales, stride)
    where = {p: i for i, p in enumerate(grid)}
    prefixes = prefix_signatures(dx, grid, level)
    logs = window_log_signatures(prefixes, [(where[s], where[e]) for s, e in wins], dx.shape[1], level)
    scored = sorted((normalized_difference(qlog, w), s, e) for w, (s, e) in zip(logs, wins))
    return scored, bsig


def _overlap(s, e, a, b):
    """Whether two windows are one occurrence: either holds the other's centre."""
    return s <= (a + b) / 2 <= e or a <= (s + e) / 2 <= b


def _distinct(scored, count=None):
    """Non-maximum suppression: the best windows (all, or the best ``count``) none of which holds another's
    centre."""
    out = []
    for d, s, e in scored:
        if all(not _overlap(s, e, a, b) for _, a, b in out):
            out.append((d, s, e))
            if len(out) == count:
                break
    return out


def _refine(query, clip, windows, depth, prepared=None, pad=PAD):
    """((elastic, start, end, nodes) in comparison frames of the best free-window match around ``windows`` (each
    padded by ``pad`` of its length), or None; the query and the clip on the DP's time base). ``prepared``: those
    two, when already computed."""
    from ...elastic.subsequence import subsequence_align  # numba is imported only when a refinement needs the DP

    if prepared is None:
        a, b, _ = query.pair(clip)
        prepared = prepare_clip(a, smooth=SMOOTH_SECONDS), prepare_clip(b, smooth=SMOOTH_SECONDS)
    qa, cb = prepared
    best = None
    for _, s, e in windows:
        more = int(np.ceil(pad * (e - s)))
        lo, hi = max(0, s - more), min(cb.frames - 1, e + more)
        if hi - lo < 1:
            continue
        try:
            m = subsequence_align(qa.rotations, cb.rotations[lo:hi + 1], depth=depth)
        except CurveError:
            continue
        if best is None or m.distance < best[0]:
            best = (m.distance, m.start + lo, m.end + lo, m.nodes + np.array([0, lo]))
    return best, qa, cb


def _moments(query, item, clip, level, scales, stride, allow_partial, warnings, skipped):
    """The clip's moments: every window the non-maximum suppression keeps (``_distinct``: none holds a better
    one's centre), best first, each as (RankResult, (clip, its window, compared frames)); [] when skipped."""
    if clip.frames < 2:  # a pose (e.g. a pose-library action) holds no motion, so no moment
        skipped.append(clip.name)
        warnings.append(f"{clip.name}: {clip.frames} frame, too short for a moment; skipped")
        return []
    got = coverage_report(query.clip, clip)
    shared, cov = got["bones"], got["coverage"]
    low = coverage_rule(clip.name, got, allow_partial, warnings, skipped)
    if low is None:
        return []
    seq, by_rotations = query.sequence(clip), False
    try:
        if seq is not None:
            scored = position_windows(query.seq, seq)
            compared = (len(seq) - 1) * MOMENT_STEP + 1
        else:
            scored, bsig = _best_windows(query, clip, level, scales, stride)
            compared, by_rotations = bsig.frames, query.seq is not None
    except CurveError as exc:
        skipped.append(clip.name)
        warnings.append(f"{clip.name}: {exc}; skipped")
        return []
    if by_rotations:
        warnings.append(f"{clip.name}: no legs for the pose and motion of a moment; compared by joint rotations and "
                        f"listed after the others")
    # partial as in rank_clips: few of the query's moving joints compared (a clip moving one bone covers itself)
    partial = cov < FEW_SHARED or shared < FEW_SHARED * moving_count(query.clip) or low or by_rotations
    out = []
    for d, s, e in _distinct(scored):
        r = RankResult(name=clip.name, distance=float(d), frames=clip.frames, key=item.key,
                       source=clip.source or item.source, shared=shared, coverage=cov, partial=partial,
                       unmapped=tuple(got["unmapped"]),
                       start=_to_clip_frame(clip, compared, s), end=_to_clip_frame(clip, compared, e),
                       metric=POSE_METRIC if seq is not None else ROTATION_METRIC, item=item)
        out.append((r, (clip, (d, s, e), compared)))
    return out


def _refine_head(q, head, depth, explain):
    """The free-window DP on each moment of ``head`` (the query and each clip prepared once), which sets its
    ``elastic`` (and ``explain``). Moments found by pose and motion keep their window and order (the DP stays inside
    the window); moments found by rotations take the DP's window around theirs, come first by their elastic
    distance, and one landing on a better one of the same clip (``_overlap``) is dropped."""
    prepared, kept = {}, []
    for r, (clip, window, compared) in head:
        if id(clip) not in prepared:
            a, b, _ = q.pair(clip)
            prepared[id(clip)] = (prepare_clip(a, smooth=SMOOTH_SECONDS), prepare_clip(b, smooth=SMOOTH_SECONDS))
        posed = r.metric == POSE_METRIC
        best, qa, cb = _refine(q, clip, [window], depth, prepared[id(clip)], pad=0.0 if posed else PAD)
        if best is not None:
            r.elastic = float(best[0])
            if not posed:
                r.start, r.end = _to_clip_frame(clip, compared, best[1]), _to_clip_frame(clip, compared, best[2])
            if explain:
                from ...elastic.explain import explain_path

                r.explain = explain_path(qa.rotations, cb.rotations, best[3], qa.bones, same_spacing=True, fps=qa.fps)
        kept.append((r, clip))
    if q.seq is not None:
        return [r for r, _ in kept]
    kept.sort(key=lambda rc: (rc[0].partial, np.inf if rc[0].elastic is None else rc[0].elastic,
                              rc[0].distance, rc[0].name))
    out = []
    for r, clip in kept:
        if all(c is not clip or not _overlap(r.start, r.end, o.start, o.end) for o, c in out):
            out.append((r, clip))
    return [r for r, _ in out]


def rank_windows(query, library, level=WINDOW_LEVEL, rerank=None, top=None, *, depth=DEFAULT_DEPTH,
                 scales=SCALES, stride=STRIDE, explain=False, progress=None, exclude=(), allow_partial=True,
                 errors=None) -> RankList:
    """Rank the moments of ``library`` (Clips or LibraryItems) that look like ``query`` (a Clip), best first.

    Every clip contributes every window the non-maximum suppression keeps (none holds a better window's centre:
    each occurrence of the motion in a long take is a result), found by pose and motion (``position_windows``;
    stats ``"metric"``: ``POSE_METRIC``) or, for a query without legs, by signatures. The first ``rerank`` moments
    (default ``REFINE``; 0: none) get the free-window elastic DP (``_refine_head``), which sets their ``elastic``:
    inside their window, in their order, for moments by pose and motion; around it, moving the window and first
    by it, for moments by signatures (a refined moment landing on a better refined one of its clip is dropped).
    Stats ``"order_by"``: "local" (by pose and motion), "elastic" or "sim". ``explain``: refined results get ``explain`` (``core.elastic.explain.explain_path`` of
    their DP path). ``top``: keep the first ``top``. ``exclude``: item keys or names to leave out. Clips sharing
    few of the query's moving joints are ``partial`` and ranked after the others; with ``allow_partial=False``
    clips below ``rigs.MIN_COVERAGE`` are skipped with a warning. ``progress(done, total)``: over the library's
    items (``indexing.iter_entries``' contract; a cancel ranks the moments of the items read so far)."""
    query = query_clip(query)
    if query.frames < 2:
        raise ShapeSigError(f"the query {query.name!r} has {query.frames} frame; a moment needs at least two")
    t0 = time.perf_counter()
    rerank = REFINE if rerank is None else max(int(rerank), 0)
    items = [it for it in as_items(library) if it.key not in exclude and it.name not in exclude]
    q = _Query(query, int(level))
    warnings, skipped, found, compared = [], [], [], 0
    for i, item in enumerate(items):
        if wants_cancel(progress, i, len(items)):
            break
        try:
            clips = item.clips()
        except ShapeSigError as exc:
            if errors is None:
                raise
            errors.append(f"{item.name}: {exc}")
            continue
        for clip in clips:
            got = _moments(q, item, clip, int(level), scales, stride, allow_partial, warnings, skipped)
            compared += bool(got)
            found.extend(got)
    else:
        wants_cancel(progress, len(items), len(items))
    found.sort(key=lambda rc: (rc[0].partial, rc[0].distance, rc[0].name, rc[0].start))
    head = _refine_head(q, found[:rerank], depth, explain)
    results = head + [r for r, _ in found[rerank:]]
    if top is not None:
        results = results[:int(top)]
    stats = {"compared": compared, "library": len(items), "refined": sum(r.elastic is not None for r in head),
             "moments": len(found), "metric": ROTATION_METRIC if q.seq is None else POSE_METRIC,
             "order_by": "local" if q.seq is not None else ("elastic" if rerank else "sim"),
             "seconds": time.perf_counter() - t0}
    return RankList(results, warnings, skipped, stats)


def query_clip(query) -> Clip:
    """The query of ``rank_windows`` from a Clip or a LibraryItem holding one clip."""
    if isinstance(query, LibraryItem):
        clips = query.clips()
        if len(clips) != 1:
            raise ShapeSigError(f"query {query.name!r} holds {len(clips)} clips; choose one")
        return clips[0]
    if not isinstance(query, Clip):
        raise ShapeSigError(f"the query must be a Clip, got {type(query).__name__}")
    return query


def retimed_excerpt(clip: Clip, start, end, speed, name=None) -> Clip:
    """Frames ``start``..``end`` (the clip's own numbers) played ``speed`` times as fast, at the clip's frame rate
    (resampled along geodesics, eq. 5.8; the root path linearly): the test and benchmark query of a moment."""
    from ...geometry.curves import geodesic_interpolate

    part = clip.crop(start, end)
    n = max(2, int(round((part.frames - 1) / float(speed))) + 1)
    t = np.linspace(0.0, 1.0, n)
    R = geodesic_interpolate(part.rotations, None, t)
    root = part.root_translation
    if root is not None:
        x = np.linspace(0.0, 1.0, part.frames)
        root = np.stack([np.interp(t, x, root[:, i]) for i in range(3)], axis=1)
    return replace(part, name=name or f"{clip.name}[{start}:{end}]x{speed:g}", rotations=R, root_translation=root,
                   frame_start=1, meta=dict(part.meta, excerpt=(int(start), int(end), float(speed))))
