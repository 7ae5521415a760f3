"""Pictures of a distance matrix: multidimensional scaling (classical and SMACOF), Procrustes comparison
of point sets, hierarchical-clustering linkage (as in the thesis' Figs 6.2, 6.3, 9.3-9.5, 9.7)."""

import numpy as np

from .scores import check_square

__all__ = ["classical_mds", "smacof", "mds", "procrustes_error", "linkage_matrix"]


def classical_mds(D, dim=2):
    """Torgerson's classical scaling: points whose Euclidean distances best match D (eigen-decomposition
    of the double-centred squared distances). Returns ``(n, dim)`` coordinates."""
    D = check_square(D)
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


def _point_distances(X):
    diff = X[:, None, :] - X[None, :, :]
    return np.sqrt(np.sum(diff * diff, axis=-1))


def _stress(D, X):
    iu = np.triu_indices(len(D), 1)
    return float(np.sum((D[iu] - _point_distances(X)[iu]) ** 2))


def smacof(D, dim=2, init=None, max_iter=500, eps=1e-10):
    """Metric MDS by SMACOF (Guttman transform iterations, unit weights) from ``init`` (classical
    scaling by default). Returns ``(X, stress)`` with stress = sum over pairs of (D - |xi - xj|)^2."""
    D = check_square(D)
    n = D.shape[0]
    X = classical_mds(D, dim) if init is None else np.array(init, dtype=np.float64)
    if n < 2:
        return X, 0.0
    stress = _stress(D, X)
    for _ in range(max_iter):
        E = _point_distances(X)
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

    D = check_square(D)
    D = (D + D.T) / 2
    np.fill_diagonal(D, 0.0)
    return linkage(squareform(np.nan_to_num(D, nan=np.nanmax(D) if np.isfinite(D).any() else 0.0)), method=method)
