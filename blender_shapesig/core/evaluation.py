"""Evaluation of distances on labelled clip sets: pairwise matrices (in parallel), leave-one-out
1-nearest-neighbour accuracy, confusion tables, multidimensional scaling and dendrograms (issue 8).

This reproduces the experiments of the reference (secs. 6.4, 9.2, 9.3) and a few variants.

Metric names (``check_metric``): the names of ``metrics.parse_metric`` (``l2``, ``elastic``,
``group3``, ``concat3``, ``linear3``, ``sim2``, ``sim3``, ...) and

* ``elastic_numpy``: d_S* computed with the plain numpy DP (the timing baseline);
* ``linearN_tensor``, ``simN_tensor``: sigma_L^N / sim^N on the expanded (tensor-space) log-signature
  instead of its Lyndon coordinates;
* ``simN_levelnorm`` (and ``simN_levelnorm_tensor``): every level of the log-signature is scaled to
  unit length before the normalized difference (each level weighs the same);
* ``BASE+elasticK`` (e.g. ``sim3+elastic5``): two-stage search, only for the 1-NN evaluation: the K
  nearest clips by ``BASE`` are re-ranked by d_S*.

Signature measures compute every clip's (log-)signature once and then take cheap norms; d_P* uses
each clip's SRVT once; d_S* uses ``elastic.elastic_distance_matrix``; ``group`` and ``concat`` need
the signature of a concatenated path per pair and run pairwise in worker processes.

Figures use matplotlib with the Agg backend (imported only when a figure is drawn). No bpy.
"""

import csv
import json
import math
import os
import re
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .errors import ShapeSigError

__all__ = [
    "DEFAULT_METRICS", "EXTRA_METRICS", "IndexEntry", "MetricSpec", "check_metric", "parse_metric_spec",
    "read_index", "unique_names", "labels_from_csv", "prepare_curves", "distance_matrix",
    "clip_distance_matrix", "loo_1nn", "two_stage_1nn", "mean_average_precision", "silhouette", "confusion_table", "format_confusion",
    "classical_mds", "smacof", "mds", "procrustes_error", "linkage_matrix", "write_matrix",
    "plot_mds", "plot_dendrogram", "evaluate", "lyndon_level_sizes",
]

DEFAULT_METRICS = ("l2", "elastic", "group3", "concat3", "linear3", "sim2", "sim3")
EXTRA_METRICS = (
    "elastic_numpy", "linear3_tensor", "sim3_tensor", "sim3_levelnorm", "sim3_levelnorm_tensor",
    "sim3+elastic3", "sim3+elastic5",
)

_SPEC_RE = re.compile(
    r"(?P<base>l2|elastic|group|concat|linear|sim)(?P<level>\d*)"
    r"(?P<opts>(?:_(?:numpy|tensor|levelnorm))*)"
    r"(?:\+elastic(?P<k>\d+))?"
)


@dataclass(frozen=True)
class MetricSpec:
    """A parsed metric name (see the module docstring)."""

    name: str
    base: str
    level: Optional[int] = None
    tensor: bool = False
    levelnorm: bool = False
    numpy_dp: bool = False
    rerank: int = 0

    @property
    def first_stage(self) -> "MetricSpec":
        """The shortlist metric of a two-stage spec (the spec itself otherwise)."""
        if not self.rerank:
            return self
        return parse_metric_spec(self.name.split("+", 1)[0])


def parse_metric_spec(name, level=None) -> MetricSpec:
    """Parse a metric name; ``level`` (when given) overrides the level in the name."""
    text = str(name).strip().lower()
    m = _SPEC_RE.fullmatch(text)
    if not m:
        raise ShapeSigError(
            f"unknown metric {name!r}: use l2, elastic, group, concat, linear or sim (with a level, "
            f"e.g. sim3), optionally _tensor / _levelnorm / _numpy or +elasticK"
        )
    base = m.group("base")
    opts = set(filter(None, m.group("opts").split("_")))
    digits = m.group("level")
    k = int(m.group("k")) if m.group("k") else 0
    if base in ("l2", "elastic"):
        if digits:
            raise ShapeSigError(f"metric {base!r} takes no level")
        if opts - ({"numpy"} if base == "elastic" else set()):
            raise ShapeSigError(f"metric {name!r}: option not available for {base}")
        lvl = None
    else:
        lvl = level if level is not None else (int(digits) if digits else 3)
        lvl = int(lvl)
        if not 1 <= lvl <= 8:
            raise ShapeSigError(f"signature level must be between 1 and 8, got {lvl}")
        if "numpy" in opts:
            raise ShapeSigError(f"metric {name!r}: _numpy only applies to elastic")
        if "tensor" in opts and base not in ("linear", "sim"):
            raise ShapeSigError(f"metric {name!r}: _tensor only applies to linear and sim")
        if "levelnorm" in opts and base != "sim":
            raise ShapeSigError(f"metric {name!r}: _levelnorm only applies to sim")
    if k and base == "elastic":
        raise ShapeSigError(f"metric {name!r}: the first stage cannot be elastic")
    canon = base + ("" if lvl is None else str(lvl))
    canon += "".join(f"_{o}" for o in ("numpy", "levelnorm", "tensor") if o in opts)
    if k:
        canon += f"+elastic{k}"
    return MetricSpec(
        name=canon, base=base, level=lvl, tensor="tensor" in opts, levelnorm="levelnorm" in opts,
        numpy_dp="numpy" in opts, rerank=k,
    )


def check_metric(name, level=None) -> str:
    """Validate a metric name; returns its canonical form (e.g. 'SIM3' -> 'sim3')."""
    return parse_metric_spec(name, level).name


# ---------------------------------------------------------------------------------------------
# Index files


@dataclass(frozen=True)
class IndexEntry:
    file: str
    label: str
    skeleton: str = ""
    start: Optional[int] = None
    end: Optional[int] = None


def _opt_int(value, where):
    value = (value or "").strip()
    if not value:
        return None
    try:
        return int(float(value))
    except ValueError:
        raise ShapeSigError(f"{where}: {value!r} is not a frame number") from None


def read_index(path):
    """Read an index CSV with columns file,label[,skeleton][,start][,end] (header required)."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as exc:
        raise ShapeSigError(f"cannot read index {path}: {exc.strerror or exc}") from None
    if not rows:
        raise ShapeSigError(f"{path}: no clips listed")
    missing = {"file", "label"} - set(rows[0].keys())
    if missing:
        raise ShapeSigError(f"{path}: missing column(s) {', '.join(sorted(missing))} (need file,label)")
    entries = []
    for i, row in enumerate(rows, start=2):
        f = (row.get("file") or "").strip()
        if not f or f.startswith("#"):
            continue
        label = (row.get("label") or "").strip()
        if not label:
            raise ShapeSigError(f"{path}:{i}: empty label")
        entries.append(
            IndexEntry(
                file=f,
                label=label,
                skeleton=(row.get("skeleton") or "").strip(),
                start=_opt_int(row.get("start"), f"{path}:{i}"),
                end=_opt_int(row.get("end"), f"{path}:{i}"),
            )
        )
    if not entries:
        raise ShapeSigError(f"{path}: no clips listed")
    return entries


def unique_names(names):
    """Make names unique by appending #2, #3 to repeats."""
    seen = {}
    out = []
    for n in names:
        if n in seen:
            seen[n] += 1
            out.append(f"{n}#{seen[n]}")
        else:
            seen[n] = 1
            out.append(n)
    return out


def labels_from_csv(path, names):
    """Labels for clip names from an index CSV (matched on the file stem); 'unknown' when absent."""
    by_stem = {}
    for e in read_index(path):
        by_stem[os.path.splitext(os.path.basename(e.file))[0]] = e.label
    return [by_stem.get(n.split("#")[0], by_stem.get(os.path.splitext(n)[0], "unknown")) for n in names]


# ---------------------------------------------------------------------------------------------
# Pairwise matrices


def prepare_curves(clips):
    """The clips' curves on the bones shared by all of them (bones still in every clip dropped)."""
    from .clip import restrict_to_shared

    restricted = restrict_to_shared(*clips)
    return [c.rotations for c in restricted], restricted[0].bones


_WORKER_CURVES = None


def _init_worker(curves):
    global _WORKER_CURVES
    _WORKER_CURVES = curves


def _feature_job(args):
    kind, level, idx = args
    return idx, _feature(_WORKER_CURVES[idx], kind, level)


def lyndon_level_sizes(dim, level):
    """Number of Lyndon words of each length 1..level over ``dim`` letters (Witt's formula)."""
    from . import tensor

    return tensor.lyndon_level_sizes(dim, level)


def _level_blocks(vec, dim, level, tensor):
    sizes = [dim**k for k in range(1, level + 1)] if tensor else lyndon_level_sizes(dim, level)
    if sum(sizes) != vec.shape[-1]:
        raise ShapeSigError(
            f"log-signature has {vec.shape[-1]} coordinates, expected {sum(sizes)} for dimension {dim}, level {level}"
        )
    return np.split(vec, np.cumsum(sizes)[:-1])


def _unit(v):
    n = float(np.linalg.norm(v))
    return v / n if n > 0 else v


def _feature(R, kind, level):
    """One clip's feature vector: kind 'logsig', 'logsig_tensor', 'levelnorm', 'levelnorm_tensor', 'srvt'."""
    from . import signatures

    if kind == "srvt":
        from .curves import srvt

        return srvt(R)
    tensor = kind.endswith("_tensor")
    ls = np.asarray(
        signatures.log_signature(R, level, basis="tensor") if tensor else signatures.log_signature(R, level),
        dtype=np.float64,
    ).reshape(-1)
    if kind.startswith("levelnorm"):
        dim = 3 * np.asarray(R).shape[1]
        blocks = [_unit(b) for b in _level_blocks(ls, dim, level, tensor)]
        ls = np.concatenate(blocks) / math.sqrt(level)
    return ls


def _sig_feature(R, level):
    """(S, S^-1) of the development of R as truncated tensors (levels 0..level)."""
    from . import tensor
    from .signatures import development_increments

    dx = development_increments(R)
    s = tensor.signature_from_increments(dx, level)
    return s, tensor.antipode(s, dx.shape[1])


def _half_group_norm(t):
    """max_i (i! |t_i|)^(1/i) over levels 1..n (one term of the Lyons-Victoir norm, eq. 8.2)."""
    return max((math.factorial(i) * float(np.linalg.norm(t[i]))) ** (1.0 / i) for i in range(1, len(t)))


def _tensor_pair(fx, fy, kind, level, dim):
    """rho^n ('group') or sigma_*^n ('concat') from precomputed (S, S^-1) of both paths."""
    from . import tensor

    (sx, ix), (sy, iy) = fx, fy
    if kind == "group":
        # S(y)^-1 (x) S(x) and its inverse S(x)^-1 (x) S(y) (eqs. 8.1-8.3, both terms of eq. 8.2).
        return _half_group_norm(tensor.mul(iy, sx, level)) + _half_group_norm(tensor.mul(ix, sy, level))
    # sigma_*: |log S(x * reversed y)| + |log S(y * reversed x)| in Lyndon coordinates (eq. 8.5).
    a = tensor.lyndon_coordinates(tensor.log(tensor.mul(sx, iy, level)), dim)
    b = tensor.lyndon_coordinates(tensor.log(tensor.mul(sy, ix, level)), dim)
    return float(np.linalg.norm(a) + np.linalg.norm(b))


_WORKER_FEATS = None


def _tensor_pair_job(args):
    kind, level, dim, pairs = args
    F = _WORKER_FEATS
    return [(i, j, _tensor_pair(F[i], F[j], kind, level, dim)) for i, j in pairs]


def _sig_feature_job(args):
    level, idx = args
    return idx, _sig_feature(_WORKER_CURVES[idx], level)


def _tensor_pair_matrix(curves, kind, level, workers, progress):
    """group / concat matrix: every clip's signature once, then tensor products per pair."""
    import multiprocessing

    global _WORKER_FEATS
    n = len(curves)
    dim = 3 * curves[0].shape[1]
    if kind == "concat":
        from . import tensor

        tensor.lyndon_projection(dim, level)  # build the projection once, before forking
    feats = [None] * n
    parallel = workers and workers > 1 and n > 2
    if parallel:
        with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=(curves,)) as ex:
            for idx, f in ex.map(_sig_feature_job, [(level, i) for i in range(n)]):
                feats[idx] = f
    else:
        feats = [_sig_feature(R, level) for R in curves]
    D = np.zeros((n, n))
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    chunk = max(1, len(pairs) // (8 * max(1, workers or 1)))
    jobs = [(kind, level, dim, pairs[k:k + chunk]) for k in range(0, len(pairs), chunk)]
    _WORKER_FEATS = feats
    try:
        if parallel and len(pairs) > 1:
            ctx = multiprocessing.get_context("fork")  # children inherit the features, no pickling
            with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as ex:
                for res in ex.map(_tensor_pair_job, jobs):
                    for i, j, d in res:
                        D[i, j] = D[j, i] = d
                    if progress:
                        progress(len(res))
        else:
            for job in jobs:
                res = _tensor_pair_job(job)
                for i, j, d in res:
                    D[i, j] = D[j, i] = d
                if progress:
                    progress(len(res))
    finally:
        _WORKER_FEATS = None
    return D


def _pairwise_euclidean(F):
    F = np.asarray(F, dtype=np.float64)
    sq = np.sum(F * F, axis=1)
    G = F @ F.T
    D2 = np.maximum(sq[:, None] + sq[None, :] - 2.0 * G, 0.0)
    D = np.sqrt(D2)
    # Exact differences for accuracy on near-duplicates (cheap for tens of clips).
    n = len(F)
    for i in range(n):
        D[i, i + 1:] = np.linalg.norm(F[i + 1:] - F[i], axis=1)
        D[i + 1:, i] = D[i, i + 1:]
    np.fill_diagonal(D, 0.0)
    return D


def _features(curves, kind, level, workers, progress):
    n = len(curves)
    feats = [None] * n
    if workers and workers > 1 and n > 2:
        with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=(curves,)) as ex:
            for idx, f in ex.map(_feature_job, [(kind, level, i) for i in range(n)]):
                feats[idx] = f
                if progress:
                    progress(n - 1 - idx)
    else:
        for i, R in enumerate(curves):
            feats[i] = _feature(R, kind, level)
            if progress:
                progress(n - 1 - i)
    return feats


def _elastic_matrix(curves, depth, workers, numpy_dp, progress):
    from . import elastic

    fn = getattr(elastic, "elastic_distance_matrix", None)
    kwargs = {"depth": depth, "workers": workers}
    if numpy_dp:
        kwargs["method"] = "numpy"
    if fn is not None:
        import inspect

        if progress and "progress" in inspect.signature(fn).parameters:
            kwargs["progress"] = progress
        D = np.asarray(fn(curves, **kwargs), dtype=np.float64)
        if progress and "progress" not in kwargs:
            progress(len(curves) * (len(curves) - 1) // 2)
        return D
    n = len(curves)
    D = np.zeros((n, n))
    extra = {"method": "numpy"} if numpy_dp else {}
    for i in range(n):
        for j in range(i + 1, n):
            D[i, j] = D[j, i] = elastic.elastic_distance(curves[i], curves[j], depth=depth, **extra)
            if progress:
                progress(1)
    return D


def _srvt_matrix(curves, progress):
    from .curves import srvt, srvt_l2_squared, uniform_times

    qs = [srvt(R) for R in curves]
    ts = [uniform_times(R.shape[0]) for R in curves]
    n = len(curves)
    D = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            D[i, j] = D[j, i] = math.sqrt(max(srvt_l2_squared(qs[i], ts[i], qs[j], ts[j]), 0.0))
            if progress:
                progress(1)
    return D


def distance_matrix(curves, metric, depth=9, workers=2, progress=None):
    """Symmetric matrix of distances between curves (same joints) by metric name.

    ``progress(n)`` is called with the number of pairs done. Two-stage names are refused here.
    """
    spec = metric if isinstance(metric, MetricSpec) else parse_metric_spec(metric)
    if spec.rerank:
        raise ShapeSigError(f"{spec.name} is a two-stage search, not a distance: use it in 'evaluate'")
    curves = [np.asarray(R, dtype=np.float64) for R in curves]
    if len(curves) < 1:
        return np.zeros((0, 0))
    if spec.base == "l2":
        return _srvt_matrix(curves, progress)
    if spec.base == "elastic":
        return _elastic_matrix(curves, depth, workers, spec.numpy_dp, progress)
    if spec.base in ("linear", "sim"):
        if spec.levelnorm:
            kind = "levelnorm_tensor" if spec.tensor else "levelnorm"
        else:
            kind = "logsig_tensor" if spec.tensor else "logsig"
        F = np.stack(_features(curves, kind, spec.level, workers, progress))
        if spec.base == "sim":
            norms = np.linalg.norm(F, axis=1, keepdims=True)
            F = np.where(norms > 0, F / np.where(norms > 0, norms, 1.0), F)
        return _pairwise_euclidean(F)
    return _tensor_pair_matrix(curves, spec.base, spec.level, workers, progress)


def clip_distance_matrix(clips, metric, depth=9, workers=2, progress=None):
    """``(D, seconds)``: the distance matrix of clips (on their shared moving bones) and its wall time."""
    curves, _ = prepare_curves(clips)
    t0 = time.perf_counter()
    D = distance_matrix(curves, metric, depth=depth, workers=workers, progress=progress)
    return D, time.perf_counter() - t0


# ---------------------------------------------------------------------------------------------
# Classification


def _check_square(D):
    D = np.asarray(D, dtype=np.float64)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ShapeSigError(f"expected a square distance matrix, got shape {D.shape}")
    return D


def loo_1nn(D, labels):
    """Leave-one-out 1-nearest-neighbour classification.

    Returns ``(accuracy, predicted, neighbours)``: each clip gets the label of its nearest other clip
    (ties: the lowest index); NaN distances are never nearest.
    """
    D = _check_square(D)
    labels = list(labels)
    n = len(labels)
    if D.shape[0] != n:
        raise ShapeSigError(f"{n} labels for a {D.shape[0]}x{D.shape[0]} matrix")
    if n < 2:
        raise ShapeSigError("leave-one-out needs at least two clips")
    work = np.where(np.isnan(D), np.inf, D).copy()
    np.fill_diagonal(work, np.inf)
    neighbours = np.argmin(work, axis=1)
    predicted = [labels[j] for j in neighbours]
    correct = sum(p == t for p, t in zip(predicted, labels))
    return correct / n, predicted, neighbours.tolist()


def two_stage_1nn(D_first, labels, k, second):
    """1-NN where each query's k nearest by ``D_first`` are re-ranked by ``second(i, j)``.

    ``second`` is a callable (or a full matrix) giving the re-rank distance. Returns
    ``(accuracy, predicted, neighbours, pairs)`` with ``pairs`` the set of (i, j), i < j, evaluated.
    """
    D = _check_square(D_first)
    labels = list(labels)
    n = len(labels)
    if k < 1:
        raise ShapeSigError("the re-rank depth k must be 1 or more")
    if not callable(second):
        M = np.asarray(second, dtype=np.float64)
        second = lambda i, j: float(M[i, j])  # noqa: E731
    work = np.where(np.isnan(D), np.inf, D).copy()
    np.fill_diagonal(work, np.inf)
    cache = {}
    neighbours = []
    for i in range(n):
        order = np.argsort(work[i], kind="stable")[: min(k, n - 1)]
        best, best_d = None, np.inf
        for j in order:
            key = (min(i, j), max(i, j))
            if key not in cache:
                cache[key] = second(*key)
            d = cache[key]
            if d < best_d:
                best, best_d = int(j), d
        neighbours.append(best if best is not None else int(order[0]))
    predicted = [labels[j] for j in neighbours]
    correct = sum(p == t for p, t in zip(predicted, labels))
    return correct / n, predicted, neighbours, set(cache)


def mean_average_precision(D, labels):
    """Leave-one-out retrieval quality: every clip queries all others ranked by D (ties: lower index
    first); AP = mean of the precision at the rank of each same-label clip; the mean over the clips
    that have at least one same-label clip. 1.0 when every clip's own class comes first."""
    D = _check_square(D)
    labels = list(labels)
    n = len(labels)
    aps = []
    for i in range(n):
        others = [j for j in range(n) if j != i]
        row = np.array([D[i, j] for j in others])
        row = np.where(np.isnan(row), np.inf, row)
        order = [others[k] for k in np.argsort(row, kind="stable")]
        rel = [labels[j] == labels[i] for j in order]
        if not any(rel):
            continue
        hits, precisions = 0, []
        for rank, r in enumerate(rel, start=1):
            if r:
                hits += 1
                precisions.append(hits / rank)
        aps.append(sum(precisions) / len(precisions))
    return float(np.mean(aps)) if aps else float("nan")


def silhouette(D, labels):
    """Mean silhouette width of the labelling under D: s_i = (b - a) / max(a, b), a the mean distance
    to the own class, b the smallest mean distance to another class; 0 for a clip alone in its class."""
    D = _check_square(D)
    labels = list(labels)
    classes = sorted(set(labels), key=labels.index)
    if len(classes) < 2:
        return float("nan")
    idx = {c: [i for i, l in enumerate(labels) if l == c] for c in classes}
    scores = []
    for i, l in enumerate(labels):
        own = [j for j in idx[l] if j != i]
        if not own:
            scores.append(0.0)
            continue
        a = float(np.mean(D[i, own]))
        b = min(float(np.mean(D[i, idx[c]])) for c in classes if c != l)
        top = max(a, b)
        scores.append(0.0 if top == 0 else (b - a) / top)
    return float(np.mean(scores))


def confusion_table(true, predicted, classes=None):
    """``(classes, table)`` with ``table[i][j]`` = number of clips of class i predicted as class j."""
    true = list(true)
    predicted = list(predicted)
    if len(true) != len(predicted):
        raise ShapeSigError("true and predicted labels differ in length")
    if classes is None:
        classes = []
        for c in true + predicted:
            if c not in classes:
                classes.append(c)
    index = {c: i for i, c in enumerate(classes)}
    table = np.zeros((len(classes), len(classes)), dtype=int)
    for t, p in zip(true, predicted):
        table[index[t], index[p]] += 1
    return list(classes), table


def format_confusion(classes, table):
    """A markdown table: rows are the true classes, columns the predicted ones."""
    head = "| true \\ predicted | " + " | ".join(classes) + " |"
    sep = "|---" * (len(classes) + 1) + "|"
    rows = [f"| {c} | " + " | ".join(str(int(v)) for v in table[i]) + " |" for i, c in enumerate(classes)]
    return "\n".join([head, sep] + rows)


# ---------------------------------------------------------------------------------------------
# Multidimensional scaling and clustering


def classical_mds(D, dim=2):
    """Torgerson's classical scaling: points whose Euclidean distances best match D (eigen-decomposition
    of the double-centred squared distances). Returns ``(n, dim)`` coordinates."""
    D = _check_square(D)
    n = D.shape[0]
    J = np.eye(n) - np.ones((n, n)) / n
    B = -0.5 * J @ (D * D) @ J
    w, V = np.linalg.eigh((B + B.T) / 2)
    order = np.argsort(w)[::-1][:dim]
    w = np.clip(w[order], 0.0, None)
    X = V[:, order] * np.sqrt(w)
    if X.shape[1] < dim:
        X = np.hstack([X, np.zeros((n, dim - X.shape[1]))])
    return X


def _stress(D, X):
    diff = X[:, None, :] - X[None, :, :]
    E = np.sqrt(np.sum(diff * diff, axis=-1))
    iu = np.triu_indices(len(D), 1)
    return float(np.sum((D[iu] - E[iu]) ** 2))


def smacof(D, dim=2, init=None, max_iter=500, eps=1e-10):
    """Metric MDS by SMACOF (Guttman transform iterations, unit weights) from ``init`` (classical
    scaling by default). Returns ``(X, stress)`` with stress = sum over pairs of (D - |xi - xj|)^2."""
    D = _check_square(D)
    n = D.shape[0]
    X = classical_mds(D, dim) if init is None else np.array(init, dtype=np.float64)
    if n < 2:
        return X, 0.0
    stress = _stress(D, X)
    for _ in range(max_iter):
        diff = X[:, None, :] - X[None, :, :]
        E = np.sqrt(np.sum(diff * diff, axis=-1))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(E > 0, D / E, 0.0)
        Bm = -ratio
        np.fill_diagonal(Bm, 0.0)
        np.fill_diagonal(Bm, -Bm.sum(axis=1))
        X = Bm @ X / n
        new = _stress(D, X)
        if stress - new <= eps * max(stress, 1e-300):
            stress = new
            break
        stress = new
    return X, stress


def mds(D, dim=2):
    """The MDS used in the figures: SMACOF from classical scaling. Returns ``(n, dim)`` coordinates."""
    return smacof(D, dim)[0]


def procrustes_error(X, Y):
    """RMS distance between point sets X and Y after the best rotation/reflection and translation."""
    X = np.asarray(X, dtype=np.float64) - np.mean(X, axis=0)
    Y = np.asarray(Y, dtype=np.float64) - np.mean(Y, axis=0)
    U, _, Vt = np.linalg.svd(X.T @ Y)
    Rm = U @ Vt
    return float(np.sqrt(np.mean(np.sum((X @ Rm - Y) ** 2, axis=1))))


def linkage_matrix(D, method="average"):
    """scipy's hierarchical-clustering linkage of a distance matrix (average linkage by default)."""
    from scipy.cluster.hierarchy import linkage
    from scipy.spatial.distance import squareform

    D = _check_square(D)
    D = (D + D.T) / 2
    np.fill_diagonal(D, 0.0)
    return linkage(squareform(np.nan_to_num(D, nan=np.nanmax(D) if np.isfinite(D).any() else 0.0)), method=method)


# ---------------------------------------------------------------------------------------------
# Output


def write_matrix(D, names, out_dir, stem="matrix"):
    """Write ``stem.csv`` (header row and first column = names) and ``stem.npy``; returns their paths."""
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, f"{stem}.csv")
    npy_path = os.path.join(out_dir, f"{stem}.npy")
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["clip"] + list(names))
        for n, row in zip(names, np.asarray(D)):
            w.writerow([n] + [repr(float(v)) for v in row])
    np.save(npy_path, np.asarray(D, dtype=np.float64))
    return {"csv": csv_path, "npy": npy_path}


_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:orange", "tab:purple", "tab:brown", "tab:pink",
            "tab:gray", "tab:olive", "tab:cyan")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _class_styles(labels):
    classes = []
    for c in labels:
        if c not in classes:
            classes.append(c)
    return {c: (_COLOURS[i % len(_COLOURS)], _MARKERS[i % len(_MARKERS)]) for i, c in enumerate(classes)}


def plot_mds(D, names, labels, path, title="MDS", annotate=True, coords=None):
    """Scatter plot of the 2-D metric MDS of D, coloured by label; returns ``path``."""
    plt = _pyplot()
    X = mds(D, 2) if coords is None else coords
    labels = list(labels) if labels is not None else ["clip"] * len(names)
    styles = _class_styles(labels)
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for c, (col, mark) in styles.items():
        idx = [i for i, l in enumerate(labels) if l == c]
        ax.scatter(X[idx, 0], X[idx, 1], c=col, marker=mark, label=c, s=36, edgecolors="k", linewidths=0.4)
    if annotate and len(names) <= 60:
        for i, n in enumerate(names):
            ax.annotate(n, (X[i, 0], X[i, 1]), fontsize=6, xytext=(3, 3), textcoords="offset points", alpha=0.75)
    ax.set_title(title)
    ax.set_aspect("equal", adjustable="datalim")
    if len(styles) > 1:
        ax.legend(fontsize=8, loc="best")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_dendrogram(D, names, labels, path, title="Dendrogram", method="average"):
    """Dendrogram (scipy, average linkage) with leaf labels coloured by class; returns ``path``."""
    plt = _pyplot()
    from scipy.cluster.hierarchy import dendrogram

    Z = linkage_matrix(D, method)
    labels = list(labels) if labels is not None else None
    leaf_names = [f"{n} ({l})" for n, l in zip(names, labels)] if labels else list(names)
    fig, ax = plt.subplots(figsize=(max(6.4, 0.28 * len(names) + 2), 4.8))
    dendrogram(Z, labels=leaf_names, ax=ax, leaf_rotation=90, leaf_font_size=7, color_threshold=0,
               above_threshold_color="0.35")
    if labels:
        styles = _class_styles(labels)
        by_name = dict(zip(leaf_names, labels))
        for tick in ax.get_xticklabels():
            tick.set_color(styles[by_name[tick.get_text()]][0])
    ax.set_title(title)
    ax.set_ylabel("distance")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ---------------------------------------------------------------------------------------------
# The whole evaluation


def _safe(name):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def evaluate(entries, loader, metrics=DEFAULT_METRICS, out_dir="eval", depth=9, workers=2, figures=True,
             progress=None, log=None, repeat=1):
    """Evaluate metrics on labelled clips and write ``out_dir/summary.json`` (plus matrices, confusion
    tables and figures). ``loader(entry)`` returns the entry's Clip (uncropped); ``entry.start`` /
    ``entry.end`` crop it (inclusive frame numbers). Returns the summary dict.

    ``repeat``: compute every matrix that many times and report the shortest wall time (the machine
    may be shared; the matrices are identical).

    Two-stage metrics (``BASE+elasticK``) reuse the first stage's and the elastic matrix when those
    are in the same run; their time is the first stage's time plus the time of the elastic pairs they
    actually evaluate (measured pair by pair when elastic is not in the run).
    """
    specs = [parse_metric_spec(m) for m in metrics]
    os.makedirs(out_dir, exist_ok=True)
    say = log or (lambda msg: None)
    clips = []
    for e in entries:
        clip = loader(e)
        if e.start is not None or e.end is not None:
            clip = clip.crop(e.start, e.end)
        clips.append(clip)
    names = unique_names([os.path.splitext(os.path.basename(e.file))[0] for e in entries])
    labels = [e.label for e in entries]
    curves, bones = prepare_curves(clips)
    say(f"{len(curves)} clips, {len(bones)} moving shared bones, frames {min(len(c) for c in curves)}.."
        f"{max(len(c) for c in curves)}")

    matrices, seconds = {}, {}

    def compute(spec):
        if spec.name in matrices:
            return matrices[spec.name]
        npairs = len(curves) * (len(curves) - 1) // 2
        best = None
        for _ in range(max(1, int(repeat))):
            bar = _make_bar(progress, npairs, spec.name)
            t0 = time.perf_counter()
            try:
                D = distance_matrix(curves, spec, depth=depth, workers=workers, progress=bar.update)
            finally:
                bar.close()
            took = time.perf_counter() - t0
            best = took if best is None else min(best, took)
        seconds[spec.name] = best
        matrices[spec.name] = D
        say(f"{spec.name}: {seconds[spec.name]:.2f} s")
        return D

    summary = {"clips": len(curves), "metrics": {}, "names": names, "labels": labels,
               "bones": list(bones), "depth": depth, "workers": workers, "repeat": max(1, int(repeat))}
    classes = []
    for l in labels:
        if l not in classes:
            classes.append(l)
    reports = []
    for spec in specs:
        if spec.rerank:
            first = spec.first_stage
            D1 = compute(first)
            t_first = seconds[first.name]
            if "elastic" in matrices:
                E = matrices["elastic"]
                acc, pred, nb, pairs = two_stage_1nn(D1, labels, spec.rerank, E)
                per_pair = seconds["elastic"] / max(1, len(curves) * (len(curves) - 1) // 2)
                t_second = per_pair * len(pairs)
                timing = "estimated from the elastic matrix's time per pair"
            else:
                from .elastic import elastic_distance

                t0 = time.perf_counter()
                acc, pred, nb, pairs = two_stage_1nn(
                    D1, labels, spec.rerank, lambda i, j: elastic_distance(curves[i], curves[j], depth=depth)
                )
                t_second = time.perf_counter() - t0
                timing = "measured"
            secs = t_first + t_second
            row = {"accuracy": acc, "seconds": secs, "first_stage_seconds": t_first,
                   "elastic_pairs": len(pairs), "rerank_seconds": t_second, "rerank_timing": timing}
        else:
            D = compute(spec)
            acc, pred, nb = loo_1nn(D, labels)
            secs = seconds[spec.name]
            row = {"accuracy": acc, "seconds": secs, "map": mean_average_precision(D, labels),
                   "silhouette": silhouette(D, labels)}
            paths = write_matrix(D, names, os.path.join(out_dir, "matrices"), stem=_safe(spec.name))
            row["matrix"] = os.path.relpath(paths["csv"], out_dir)
            if figures and len(curves) >= 3:
                fig_dir = os.path.join(out_dir, "figures")
                os.makedirs(fig_dir, exist_ok=True)
                row["figures"] = [
                    os.path.relpath(plot_mds(D, names, labels, os.path.join(fig_dir, f"mds_{_safe(spec.name)}.png"),
                                             title=f"MDS, {spec.name} (1-NN {acc:.0%})"), out_dir),
                    os.path.relpath(plot_dendrogram(D, names, labels,
                                                    os.path.join(fig_dir, f"dendrogram_{_safe(spec.name)}.png"),
                                                    title=f"Dendrogram, {spec.name}"), out_dir),
                ]
        _, table = confusion_table(labels, pred, classes)
        row["correct"] = int(round(acc * len(labels)))
        row["confusion"] = {"classes": classes, "table": table.tolist()}
        row["mistakes"] = [
            {"clip": names[i], "label": labels[i], "nearest": names[nb[i]], "predicted": pred[i]}
            for i in range(len(labels)) if pred[i] != labels[i]
        ]
        summary["metrics"][spec.name] = row
        reports.append(f"## {spec.name}\n\n1-NN accuracy {acc:.3f} ({row['correct']}/{len(labels)}), "
                       f"{secs:.2f} s\n\n{format_confusion(classes, table)}\n")
    with open(os.path.join(out_dir, "summary.json"), "w", encoding="utf-8") as fh:
        json.dump(summary, fh, indent=1)
    lines = ["# Evaluation summary", "", f"{len(curves)} clips, classes: {', '.join(classes)}", "",
             "| metric | 1-NN accuracy | mAP | silhouette | seconds |", "|---|---|---|---|---|"]
    for name, row in summary["metrics"].items():
        extra = " | ".join(f"{row[k]:.3f}" if k in row else "" for k in ("map", "silhouette"))
        lines.append(f"| {name} | {row['accuracy']:.3f} ({row['correct']}/{len(labels)}) | {extra} | "
                     f"{row['seconds']:.2f} |")
    with open(os.path.join(out_dir, "report.md"), "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n\n" + "\n".join(reports))
    return summary


def _make_bar(progress, total, desc):
    if progress == "tqdm":
        try:
            import sys

            from tqdm import tqdm

            return tqdm(total=total, desc=desc, file=sys.stderr, leave=False, dynamic_ncols=True)
        except ImportError:  # pragma: no cover
            pass

    class _Bar:
        def update(self, n=1):
            if callable(progress):
                progress(n)

        def close(self):
            pass

    return _Bar()
