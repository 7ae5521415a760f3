"""The elastic check of a near-duplicate candidate pair (``dedupe``'s second stage): the two clips rebuilt from the
index entries' increments on the bones both have (``pair_curves``), on the comparison time base with the elastic
low-pass (``prepared_pair``), their d_S* and the scale-free relative distance (``elastic_check``), and the time map of
one onto the other for the report (``time_map``). See docs/search.md, "Library report (dedupe)".
"""

from typing import List, Tuple

import numpy as np

from ..clip.clip import Clip
from ..clip.prepare import prepare_clip
from ..distances import clip_distance
from ..elastic import DEFAULT_DEPTH
from ..errors import ShapeSigError
from ..geometry import so3
from ..metric_names import time_base_smoothing
from .signature.entry import IndexEntry, curve_from_increments, pair_increments

__all__ = ["pair_curves", "srvt_energy", "prepared_pair", "time_map", "elastic_check", "check_pairs"]


def pair_curves(a: IndexEntry, b: IndexEntry) -> Tuple[Clip, Clip]:
    """Two clips rebuilt from the entries' increments on the bones both have (in ``a``'s order; bones still in
    both dropped), each at its own frame rate."""
    in_b = set(b.bones)
    shared = [x for x in a.bones if x in in_b]
    if not shared:
        raise ShapeSigError(f"clips {a.name!r} and {b.name!r} share no bones")
    ia, ib = pair_increments(a, b, shared)
    moving = {a.bones[j] for j in a.moving} | {b.bones[j] for j in b.moving}
    kept = [x for x in shared if x in moving] or shared  # pair_increments' columns (all when nothing moves)
    return (Clip(a.name, kept, curve_from_increments(ia), fps=a.fps),
            Clip(b.name, kept, curve_from_increments(ib), fps=b.fps))


def srvt_energy(R) -> float:
    """|q|^2 of a curve's SRVT (per-joint norm): sum over joints of the integral of |eta|, i.e. the total angle
    its joints turn through (independent of the parametrization)."""
    return float(np.linalg.norm(so3.relative_rotvecs(R), axis=-1).sum())


def prepared_pair(a: IndexEntry, b: IndexEntry) -> Tuple[Clip, Clip]:
    """``pair_curves`` on the comparison time base with the elastic low-pass (what ``elastic_check`` compares).
    ShapeSigError when the two share no bones."""
    smooth = time_base_smoothing("elastic")
    ca, cb = pair_curves(a, b)
    return prepare_clip(ca, smooth=smooth), prepare_clip(cb, smooth=smooth)


def time_map(a: IndexEntry, b: IndexEntry, depth=DEFAULT_DEPTH) -> Tuple[np.ndarray, np.ndarray]:
    """``(ta, tb)``: the optimal alignment of ``b`` onto ``a`` (``elastic.elastic_align`` of the prepared pair)
    as matching times in seconds of each clip (the diagonal for a copy, a curve for a re-timed one)."""
    from ..elastic.elastic import elastic_align

    pa, pb = prepared_pair(a, b)
    warp, _ = elastic_align(pa.rotations, pb.rotations, depth=depth)
    return warp[:, 0] * (pa.frames - 1) / pa.fps, warp[:, 1] * (pb.frames - 1) / pb.fps


def elastic_check(a: IndexEntry, b: IndexEntry, depth=DEFAULT_DEPTH) -> Tuple[float, float]:
    """``(d, r)``: d_S* of two entries (increments loaded) on the comparison time base (``prepare.prepare_clip``
    with the elastic low-pass, then ``metrics.clip_distance``) and the *relative* distance
    r = d / sqrt(|q_a|^2 + |q_b|^2) (``srvt_energy`` of the prepared curves). r is scale-free (0 for a copy,
    about 1 for unrelated motions; d_S* itself grows with how much the clips move), so one threshold fits
    short runs and long takes. (inf, inf) when the two share no moving bone.

    Identical prepared curves (an exact copy under another name) give (0, 0) without the DP: the DP sums
    |q_a|^2 + |q_b|^2 - 2 <q_a, q_b> along the path, and that cancellation leaves a rounding residue of
    about sqrt(eps) |q| (1e-8 relative, 30 fps lattice) instead of 0, so ``--threshold 0`` would keep nothing."""
    try:
        pa, pb = prepared_pair(a, b)
    except ShapeSigError:
        return float("inf"), float("inf")
    if pa.rotations.shape == pb.rotations.shape and np.array_equal(pa.rotations, pb.rotations):
        return 0.0, 0.0  # the same curve: d_S* = 0 exactly (the DP's energy form leaves ~sqrt(eps |q|^2))
    d = float(clip_distance(pa, pb, "elastic", depth=depth, time_base=False))
    energy = srvt_energy(pa.rotations) + srvt_energy(pb.rotations)
    return d, (d / np.sqrt(energy) if energy > 0 else (0.0 if d == 0 else float("inf")))


def check_pairs(pairs, depth=DEFAULT_DEPTH) -> List[Tuple[float, float]]:
    """``elastic_check`` of each ``(a, b)`` pair of entries: one task of the parallel check."""
    return [elastic_check(a, b, depth) for a, b in pairs]
