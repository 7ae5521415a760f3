"""Distance matrices of many clips by metric name (the grammar of ``metrics``): every measure is computed once per
clip where the maths allows (SRVTs, signatures, log-signatures) and then per pair, the tensor products of
rho^n and sigma_*^n in forked worker processes. ``progress(done, total)`` (``core.progress``) counts pairs; a
cancel raises ``errors.Cancelled``. Pure numpy, no plotting. See docs/dev/metrics.md.
"""

import contextlib
import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from .elastic import elastic
from .signatures import signatures, tensor
from .clip.clip import restrict_to_shared
from .geometry import curves as curves_mod
from .geometry.curves import srvt, srvt_l2_squared, uniform_times, use_srvt_norm
from .errors import ShapeSigError
from .progress import Counter
from .elastic import DEFAULT_DEPTH
from .metric_names import MetricSpec, parse_metric_spec, time_base_smoothing

__all__ = [
    "prepare_curves", "distance_matrix", "clip_distance_matrix", "level_blocks", "log_signature_feature",
    "signature_features", "feature_matrix", "srvt_matrix", "elastic_matrix", "tensor_pair_matrix",
    "cross_distance_matrix",
]


def prepare_curves(clips, smooth=None):
    """``(curves, bones)``: the clips' curves on the bones shared by all of them (bones still in every
    clip dropped); with ``smooth`` (seconds, may be 0), each restricted clip is then put on the comparison time
    base by ``prepare.prepare_clip(clip, smooth=smooth)``."""
    restricted = restrict_to_shared(*clips)
    if smooth is not None:
        from .clip.prepare import prepare_clip

        restricted = [prepare_clip(c, smooth=smooth) for c in restricted]
    return [c.rotations for c in restricted], restricted[0].bones


# ----------------------------------------------------------------------------------------- worker pools

_SHARED = None  # what forked workers read: the curves or the per-clip signatures


def _call_shared(job):
    fn, args = job
    return fn(_SHARED, *args)


def _shared_map(fn, jobs, shared, workers):
    """``[fn(shared, *args) for args in jobs]``, in ``workers`` forked processes when there is more than
    one job and more than one worker (children inherit ``shared``); results arrive in order. Closing the
    generator early (a cancel) drops the jobs not started."""
    global _SHARED
    jobs = list(jobs)
    _SHARED = shared
    try:
        if workers and workers > 1 and len(jobs) > 1:
            ex = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"))
            try:
                yield from ex.map(_call_shared, [(fn, args) for args in jobs])
            finally:
                ex.shutdown(wait=True, cancel_futures=True)
        else:
            for args in jobs:
                yield fn(shared, *args)
    finally:
        _SHARED = None


# ----------------------------------------------------------------------------------------- features

def level_blocks(vec, dim, level, basis="lyndon"):
    """Split a flat log-signature into its levels 1..level (Witt's sizes for Lyndon coordinates, d^k for
    the tensor form)."""
    if basis == "tensor":
        sizes = [dim ** k for k in range(1, level + 1)]
    else:
        sizes = tensor.lyndon_level_sizes(dim, level)
    vec = np.asarray(vec, dtype=np.float64).reshape(-1)
    if sum(sizes) != vec.shape[-1]:
        raise ShapeSigError(f"log-signature has {vec.shape[-1]} coordinates, expected {sum(sizes)} for "
                            f"dimension {dim}, level {level}")
    return np.split(vec, np.cumsum(sizes)[:-1])


def log_signature_feature(R, level, basis="lyndon", levelnorm=False):
    """One curve's log-signature (``signatures.log_signature``); with ``levelnorm`` every level is scaled to
    unit length (a level with norm <= ``signatures.ZERO_NORM`` has no direction and becomes zero) and the
    whole divided by sqrt(level), so each level weighs the same and a moving curve has norm 1."""
    ls = np.asarray(signatures.log_signature(R, level, basis=basis), dtype=np.float64).reshape(-1)
    if not levelnorm:
        return ls
    blocks = []
    for b in level_blocks(ls, 3 * np.asarray(R).shape[1], level, basis):
        n = float(np.linalg.norm(b))
        blocks.append(b / n if n > signatures.ZERO_NORM else np.zeros_like(b))
    return np.concatenate(blocks) / math.sqrt(level)


def _feature_job(curves, i, level, basis, levelnorm):
    return log_signature_feature(curves[i], level, basis, levelnorm)


def signature_features(curves, level, basis="lyndon", levelnorm=False, workers=1, progress=None):
    """``(n, k)`` array of every curve's ``log_signature_feature``. ``progress(done, total)`` counts pairs: clip i
    adds the n - 1 - i pairs it starts."""
    n = len(curves)
    feats = []
    jobs = [(i, level, basis, levelnorm) for i in range(n)]
    count = Counter(progress, n * (n - 1) // 2)
    with contextlib.closing(_shared_map(_feature_job, jobs, curves, workers)) as results:
        for i, f in enumerate(results):
            feats.append(f)
            count.add(n - 1 - i)
    return np.stack(feats)


def feature_matrix(F, normalized=False):
    """Pairwise distances of feature rows: Euclidean (sigma_L^n), or with ``normalized`` the normalized
    difference of eq. 9.1 (``signatures.normalized_difference``, sim^n)."""
    F = np.asarray(F, dtype=np.float64)
    n = len(F)
    D = np.zeros((n, n))
    for i in range(n):
        if normalized:
            row = [signatures.normalized_difference(F[i], F[j]) for j in range(i + 1, n)]
        else:
            row = np.linalg.norm(F[i + 1:] - F[i], axis=1)
        D[i, i + 1:] = row
        D[i + 1:, i] = row
    return D


# ----------------------------------------------------------------------------------------- matrices

def srvt_matrix(curves, progress=None):
    """d_P* of every pair (uniform grids): each SRVT once, then the L2 norm of the difference."""
    qs = [srvt(R) for R in curves]
    ts = [uniform_times(R.shape[0]) for R in curves]
    n = len(curves)
    D = np.zeros((n, n))
    count = Counter(progress, n * (n - 1) // 2)
    for i in range(n):
        for j in range(i + 1, n):
            D[i, j] = D[j, i] = math.sqrt(max(srvt_l2_squared(qs[i], ts[i], qs[j], ts[j]), 0.0))
            count.add()
    return D


def elastic_matrix(curves, depth=DEFAULT_DEPTH, workers=2, numpy_dp=False, progress=None):
    """d_S* of every pair: ``elastic.elastic_distance_matrix`` (``numpy_dp``: the plain numpy DP)."""
    return np.asarray(elastic.elastic_distance_matrix(curves, depth=depth, workers=max(1, int(workers or 1)),
                                                      method="numpy" if numpy_dp else "auto", progress=progress),
                      dtype=np.float64)


def _signature_job(curves, i, level):
    """The curve's signature as (tensor, inverse): each clip is inverted once, not once per pair."""
    return signatures.prepare_signature(signatures.signature(curves[i], level), 3 * curves[i].shape[1], level)


def _pair_job(sigs, pairs, base, level, dim):
    fn = (signatures.group_distance_from_signatures if base == "group"
          else signatures.concat_distance_from_signatures)
    return [(i, j, fn(sigs[i], sigs[j], dim, level)) for i, j in pairs]


def tensor_pair_matrix(curves, base, level, workers=2, progress=None):
    """rho^n (``base='group'``) or sigma_*^n (``'concat'``) of every pair: every curve's signature once,
    then tensor products per pair, in chunks spread over the workers."""
    if base not in ("group", "concat"):
        raise ShapeSigError(f"tensor_pair_matrix computes group or concat, not {base!r}")
    n = len(curves)
    dim = 3 * curves[0].shape[1]
    if base == "concat":
        tensor.lyndon_projection(dim, level)  # build the projection once, before forking
    sigs = list(_shared_map(_signature_job, [(i, level) for i in range(n)], curves, workers))
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    chunk = max(1, len(pairs) // (8 * max(1, workers or 1)))
    jobs = [(pairs[k:k + chunk], base, level, dim) for k in range(0, len(pairs), chunk)]
    D = np.zeros((n, n))
    count = Counter(progress, len(pairs))
    with contextlib.closing(_shared_map(_pair_job, jobs, sigs, workers)) as results:
        for res in results:
            for i, j, d in res:
                D[i, j] = D[j, i] = d
            count.add(len(res))
    return D


def distance_matrix(curves, metric, depth=DEFAULT_DEPTH, workers=2, progress=None):
    """Symmetric matrix of distances between curves (same joints) by metric name or MetricSpec.

    ``progress(done, total)`` counts the pairs done (a cancel raises Cancelled). Two-stage names are refused here.
    """
    spec = metric if isinstance(metric, MetricSpec) else parse_metric_spec(metric)
    if spec.rerank or spec.base == "local":
        raise ShapeSigError(f"{spec.name} is a two-stage search of clips, not a distance of curves: use it in "
                            f"'rank' or 'evaluate'")
    curves = [np.asarray(R, dtype=np.float64) for R in curves]
    if not curves:
        return np.zeros((0, 0))
    if spec.base in ("l2", "elastic"):
        with use_srvt_norm(spec.srvt_norm or curves_mod.DEFAULT_SRVT_NORM):
            if spec.base == "l2":
                return srvt_matrix(curves, progress)
            return elastic_matrix(curves, depth, workers, spec.numpy_dp, progress)
    if spec.base in ("linear", "sim"):
        F = signature_features(curves, spec.level, spec.basis, spec.levelnorm, workers, progress)
        return feature_matrix(F, normalized=spec.base == "sim")
    return tensor_pair_matrix(curves, spec.base, spec.level, workers, progress)


def cross_distance_matrix(curves_a, curves_b, metric, depth=DEFAULT_DEPTH, progress=None):
    """(len(a), len(b)) distances of every curve of ``curves_a`` to every curve of ``curves_b`` (same joints; e.g.
    crop probes against a set): the signature features once per curve for linear and sim, else pair by pair
    (``metrics.curve_distance``). Two-stage names and ``local`` are refused (``distance_matrix``'s rule)."""
    from .distances import curve_distance

    spec = metric if isinstance(metric, MetricSpec) else parse_metric_spec(metric)
    if spec.rerank or spec.base == "local":
        raise ShapeSigError(f"{spec.name} is a two-stage search of clips, not a distance of curves")
    A = [np.asarray(R, dtype=np.float64) for R in curves_a]
    B = [np.asarray(R, dtype=np.float64) for R in curves_b]
    D = np.zeros((len(A), len(B)))
    count = Counter(progress, len(A) * len(B))
    if spec.base in ("linear", "sim"):
        FA, FB = (np.stack([log_signature_feature(R, spec.level, spec.basis, spec.levelnorm) for R in X]) for X in (A, B))
        for i in range(len(A)):
            D[i] = ([signatures.normalized_difference(FA[i], f) for f in FB] if spec.base == "sim"
                    else np.linalg.norm(FB - FA[i], axis=1))
            count.add(len(B))
        return D
    with use_srvt_norm(spec.srvt_norm or curves_mod.DEFAULT_SRVT_NORM):
        for i in range(len(A)):
            for j in range(len(B)):
                D[i, j] = curve_distance(A[i], B[j], spec.base, spec.level, depth=depth)
            count.add(len(B))
    return D


def clip_distance_matrix(clips, metric, depth=DEFAULT_DEPTH, workers=2, progress=None, time_base=True):
    """``(D, seconds)``: the distance matrix of clips (on their shared moving bones, on the comparison time base
    of ``prepare.prepare_clip`` unless ``time_base`` is False) and its wall time."""
    spec = metric if isinstance(metric, MetricSpec) else parse_metric_spec(metric)
    curves, _ = prepare_curves(clips, time_base_smoothing(spec.base) if time_base else None)
    t0 = time.perf_counter()
    D = distance_matrix(curves, metric, depth=depth, workers=workers, progress=progress)
    return D, time.perf_counter() - t0
