"""Scores of a distance matrix against labels: leave-one-out 1-NN (plain and two-stage), mean average
precision, silhouette width, confusion tables."""

import numpy as np

from ..core.errors import ShapeSigError

__all__ = ["check_square", "loo_1nn", "two_stage_1nn", "mean_average_precision", "silhouette",
           "class_order", "confusion_table", "format_confusion"]


def check_square(D):
    """D as a float array; ShapeSigError unless it is square."""
    D = np.asarray(D, dtype=np.float64)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ShapeSigError(f"expected a square distance matrix, got shape {D.shape}")
    return D


def _others(D):
    """D with NaN (never nearest) and the diagonal (a clip is not its own neighbour) set to infinity."""
    work = np.where(np.isnan(D), np.inf, D)
    np.fill_diagonal(work, np.inf)
    return work


def _accuracy(predicted, labels):
    return sum(p == t for p, t in zip(predicted, labels)) / len(labels)


def loo_1nn(D, labels):
    """Leave-one-out 1-nearest-neighbour classification.

    Returns ``(accuracy, predicted, neighbours)``: each clip gets the label of its nearest other clip
    (ties: the lowest index); NaN distances are never nearest.
    """
    D = check_square(D)
    labels = list(labels)
    n = len(labels)
    if D.shape[0] != n:
        raise ShapeSigError(f"{n} labels for a {D.shape[0]}x{D.shape[0]} matrix")
    if n < 2:
        raise ShapeSigError("leave-one-out needs at least two clips")
    neighbours = np.argmin(_others(D), axis=1)
    predicted = [labels[j] for j in neighbours]
    return _accuracy(predicted, labels), predicted, neighbours.tolist()


def two_stage_1nn(D_first, labels, k, second):
    """1-NN where each query's k nearest by ``D_first`` are re-ranked by ``second(i, j)``.

    ``second`` is a callable (or a full matrix) giving the re-rank distance. Returns
    ``(accuracy, predicted, neighbours, pairs)`` with ``pairs`` the set of (i, j), i < j, evaluated.
    """
    D = check_square(D_first)
    labels = list(labels)
    n = len(labels)
    if k < 1:
        raise ShapeSigError("the re-rank depth k must be 1 or more")
    if not callable(second):
        M = np.asarray(second, dtype=np.float64)
        second = lambda i, j: float(M[i, j])  # noqa: E731
    work = _others(D)
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
    return _accuracy(predicted, labels), predicted, neighbours, set(cache)


def mean_average_precision(D, labels):
    """Leave-one-out retrieval quality: every clip queries all others ranked by D (ties: lower index
    first); AP = mean of the precision at the rank of each same-label clip; the mean over the clips
    that have at least one same-label clip. 1.0 when every clip's own class comes first."""
    D = check_square(D)
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


def class_order(labels):
    """The distinct labels in order of first appearance."""
    classes = []
    for c in labels:
        if c not in classes:
            classes.append(c)
    return classes


def silhouette(D, labels):
    """Mean silhouette width of the labelling under D: s_i = (b - a) / max(a, b), a the mean distance
    to the own class, b the smallest mean distance to another class; 0 for a clip alone in its class."""
    D = check_square(D)
    labels = list(labels)
    classes = class_order(labels)
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
        classes = class_order(true + predicted)
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
