"""Signatures, log-signatures and the signature measures of the reference (secs. 7-9): of the development of a curve
in SO(3)^d (the path in R^(3d) whose increments are log(R[k+1] R[k]^T)), ``signature``, ``log_signature`` (Lyndon
or tensor coordinates) and the measures ``group_distance`` (rho^n), ``concat_distance`` (sigma_*^n),
``linear_distance`` (sigma_L^n) and ``normalized_distance`` (sim^n, zero rule ``ZERO_NORM``). ``method`` is
``"numpy"`` (``tensor``) or ``"iisignature"`` (optional); ``"auto"`` takes numpy. See docs/signatures.md.
"""

import math

import numpy as np

from . import tensor
from ..geometry.curves import as_curve, relative_rotvecs
from ..geometry.so3 import still_joints
from ..errors import CurveError, ShapeSigError

try:  # optional: the extension must work without it
    import iisignature as _iisig
except Exception:  # pragma: no cover - depends on the environment
    _iisig = None

__all__ = [
    "signature", "log_signature", "group_distance", "concat_distance", "linear_distance",
    "normalized_distance",
    "HAVE_IISIGNATURE", "ZERO_NORM", "METHODS", "BASES",
    "development", "development_increments",
    "path_signature", "path_log_signature", "increments_log_signature", "path_group_distance",
    "path_concat_distance",
    "path_linear_distance", "path_normalized_distance",
    "signature_dim", "log_signature_dim", "normalized_difference", "group_norm",
    "group_distance_from_signatures", "concat_distance_from_signatures",
    "prepare", "resolve_method",
]

HAVE_IISIGNATURE = _iisig is not None
METHODS = ("auto", "iisignature", "numpy")
BASES = ("lyndon", "tensor")
# A log-signature whose Euclidean norm is at most this has no direction (eq. 9.1's zero case).
ZERO_NORM = 1e-12

# iisignature logsig method used for Lyndon coordinates, by level: 'A' (areas, levels <= 2) and
# above that 'S' (signature, then log, then projection), the fastest Lyndon methods measured at 93
# dimensions: at level 2 'A' 1.8 ms, 'S' 3.1 ms, 'C' 2.6 ms, 'O' 8.5 ms per call; at level 3 the
# BCH methods 'C' and 'O' did not finish preparing in 5 and 3 minutes, 'S' prepares in 10-20 s.
# See benchmarks/bench_signatures.py. 'X' gives the expanded (tensor) log-signature.
_PREPARED = {}


def _ii_method(level, basis):
    if basis == "tensor":
        return "X"
    return "A" if level <= 2 else "S"


# --- helpers -----------------------------------------------------------------------------------------

def _check_level(level):
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or level < 1:
        raise ShapeSigError(f"signature level must be a positive integer, got {level!r}")
    return int(level)


def _check_basis(basis):
    if basis not in BASES:
        raise ShapeSigError(f"unknown basis {basis!r}: choose one of {', '.join(BASES)}")
    return basis


def resolve_method(method="auto", dim=None, log=False):
    """The implementation to use: 'numpy' or 'iisignature'.

    'auto' is numpy (faster in every case measured, and always available). 'iisignature' raises
    ShapeSigError when the package is missing, or for a log-signature of a 1-dimensional path
    (iisignature's logsig needs dimension >= 2).
    """
    if method not in METHODS:
        raise ShapeSigError(f"unknown method {method!r}: choose one of {', '.join(METHODS)}")
    if method == "auto":
        return "numpy"
    if method == "iisignature":
        if _iisig is None:
            raise ShapeSigError("method='iisignature' needs the iisignature package, which is not installed")
        if log and dim is not None and dim < 2:
            raise ShapeSigError("iisignature's log-signature needs a path of dimension >= 2")
    return method


def prepare(dim, level, basis="lyndon"):
    """iisignature's prepared object for (dim, level) and the basis, made once and kept.

    Only the one method needed is prepared ('A' for Lyndon coordinates at levels <= 2, 'S' above,
    'X' for the tensor form); preparing all methods (iisignature's default) compiles BCH code and is
    much slower.
    """
    if _iisig is None:
        raise ShapeSigError("iisignature is not installed")
    methods = _ii_method(int(level), _check_basis(basis))
    key = (int(dim), int(level), methods)
    s = _PREPARED.get(key)
    if s is None:
        tensor.check_size(dim, level)
        s = _iisig.prepare(int(dim), int(level), methods)
        _PREPARED[key] = s
    return s


def signature_dim(dim, level):
    """Length of ``signature``'s output: d + d^2 + ... + d^n."""
    return tensor.tensor_size(int(dim), _check_level(level))


def log_signature_dim(dim, level, basis="lyndon"):
    """Length of ``log_signature``'s output for a path in R^dim (for a curve, dim = 3 * joints):
    Witt's formula for the Lyndon basis, d + ... + d^n for the tensor form."""
    level = _check_level(level)
    if _check_basis(basis) == "tensor":
        return tensor.tensor_size(int(dim), level)
    return tensor.log_signature_dim(int(dim), level)


def _as_path(path, name="path"):
    x = np.asarray(path, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < 1 or x.shape[1] < 1:
        raise ShapeSigError(f"{name}: expected points of shape (points, dim), got {np.shape(path)}")
    if not np.all(np.isfinite(x)):
        raise ShapeSigError(f"{name}: contains NaN or infinite values")
    return x


def _points(dx):
    """The path starting at 0 with increments dx."""
    out = np.zeros((dx.shape[0] + 1, dx.shape[1]))
    np.cumsum(dx, axis=0, out=out[1:])
    return out


def _reverse_increments(dx):
    return -dx[::-1]


# --- path level: signatures --------------------------------------------------------------------------

def _sig_tensor_numpy(dx, level):
    return tensor.signature_from_increments(dx, level)


def _sig_flat(dx, level, method):
    if method == "iisignature":
        tensor.check_size(dx.shape[1], level)
        return np.asarray(_iisig.sig(_points(dx), level), dtype=np.float64)
    return tensor.flatten(_sig_tensor_numpy(dx, level))


def _logsig_numpy_from_sig(sig_t, dim, basis):
    lt = tensor.log(sig_t)
    if basis == "tensor":
        return tensor.flatten(lt)
    return tensor.lyndon_coordinates(lt, dim)


def _logsig_flat(dx, level, method, basis):
    d = dx.shape[1]
    if method == "numpy" and basis == "lyndon" and level <= 3:
        return tensor.lyndon_log_signature(dx, level)  # the same coordinates, by matrix products
    if method == "iisignature":
        s = prepare(d, level, basis)
        return np.asarray(_iisig.logsig(_points(dx), s, _ii_method(level, basis)), dtype=np.float64)
    return _logsig_numpy_from_sig(_sig_tensor_numpy(dx, level), d, basis)


def path_signature(path, level, *, method="auto"):
    """Truncated signature (levels 1..level, iisignature layout) of the piecewise-linear path through
    the points ``path`` (points, dim)."""
    x = _as_path(path)
    level = _check_level(level)
    return _sig_flat(np.diff(x, axis=0), level, resolve_method(method, x.shape[1]))


def path_log_signature(path, level, *, basis="lyndon", method="auto"):
    """Log-signature of the piecewise-linear path through ``path`` (points, dim): Lyndon coordinates
    (iisignature.logsig's default basis and order) or the expanded tensor form (``basis="tensor"``)."""
    x = _as_path(path)
    level = _check_level(level)
    basis = _check_basis(basis)
    return _logsig_flat(np.diff(x, axis=0), level, resolve_method(method, x.shape[1], log=True), basis)


def increments_log_signature(dx, level, *, basis="lyndon", method="auto"):
    """``path_log_signature`` of the path starting at 0 with the increments ``dx`` (steps, dim), without
    forming its points (the index signs a clip's development from its increments)."""
    x = _as_path(dx, "increments")
    level = _check_level(level)
    basis = _check_basis(basis)
    return _logsig_flat(x, level, resolve_method(method, x.shape[1], log=True), basis)


# --- path level: measures ----------------------------------------------------------------------------

def _half_group_norm(t):
    """max_i (i! |t_i|)^(1/i) over levels 1..n of a truncated tensor (one term of eq. 8.2)."""
    norms = tensor.level_norms(t)
    return float(max((math.factorial(i) * v) ** (1.0 / i) for i, v in enumerate(norms, start=1)))


def group_norm(g, dim, level):
    """Lyons-Victoir norm ||g||_{G^n} of eq. 8.2 of a signature-like tensor ``g`` (flat, levels 1..n,
    level 0 = 1): both terms, the second with the inverse g^-1 from the series (1 + X)^-1."""
    t = tensor.unflatten(g, int(dim), _check_level(level))
    return _half_group_norm(t) + _half_group_norm(tensor.inverse(t))


def _group_distance_dx(dx, dy, level, method):
    """rho^n with both terms of eq. 8.2: |S(y)^-1 ⊗ S(x)| and |(S(y)^-1 ⊗ S(x))^-1| = |S(x)^-1 ⊗ S(y)|."""
    d = dx.shape[1]
    if method == "iisignature":
        # eq. 8.3: the signature of the concatenation reversed(y) * x, and of reversed(x) * y.
        g = _sig_flat(np.vstack([_reverse_increments(dy), dx]), level, method)
        h = _sig_flat(np.vstack([_reverse_increments(dx), dy]), level, method)
        return _half_group_norm(tensor.unflatten(g, d, level)) + _half_group_norm(tensor.unflatten(h, d, level))
    return _group_from_tensors(_sig_tensor_numpy(dx, level), _sig_tensor_numpy(dy, level), d, level)


def _group_from_tensors(sx, sy, d, level, ix=None, iy=None):
    """rho^n from signature tensors; ``ix``/``iy``: their inverses when already known (``prepare_signature``)."""
    ix = tensor.antipode(sx, d) if ix is None else ix
    iy = tensor.antipode(sy, d) if iy is None else iy
    g = tensor.mul(iy, sx, level)  # S(y)^-1 ⊗ S(x)
    h = tensor.mul(ix, sy, level)  # its inverse S(x)^-1 ⊗ S(y)
    return _half_group_norm(g) + _half_group_norm(h)


def _concat_from_tensors(sx, sy, d, level, basis, ix=None, iy=None):
    ix = tensor.antipode(sx, d) if ix is None else ix
    iy = tensor.antipode(sy, d) if iy is None else iy
    a = _logsig_numpy_from_sig(tensor.mul(sx, iy, level), d, basis)  # log S(x * rev y)
    b = _logsig_numpy_from_sig(tensor.mul(sy, ix, level), d, basis)  # log S(y * rev x)
    return float(np.linalg.norm(a) + np.linalg.norm(b))


def prepare_signature(s, dim, level):
    """A stored signature (``signature``'s output for a path in R^dim) as (tensor, inverse tensor): the form
    ``group_distance_from_signatures`` and ``concat_distance_from_signatures`` accept to skip the per-pair
    unflattening and inversion (a distance matrix prepares each clip once)."""
    t = tensor.unflatten(s, int(dim), _check_level(level))
    return t, tensor.antipode(t, int(dim))


def _sig_pair(sx, sy, dim, level):
    """(tx, ix, ty, iy, level): tensors and inverses of two stored or prepared signatures."""
    level = _check_level(level)
    tx, ix = sx if isinstance(sx, tuple) else (tensor.unflatten(sx, int(dim), level), None)
    ty, iy = sy if isinstance(sy, tuple) else (tensor.unflatten(sy, int(dim), level), None)
    return tx, ix, ty, iy, level


def group_distance_from_signatures(sx, sy, dim, level):
    """rho^n from two stored signatures (``signature``'s output for paths in R^dim, same level, or
    ``prepare_signature``'s pairs)."""
    tx, ix, ty, iy, level = _sig_pair(sx, sy, dim, level)
    return _group_from_tensors(tx, ty, int(dim), level, ix, iy)


def concat_distance_from_signatures(sx, sy, dim, level, *, basis="lyndon"):
    """sigma_*^n from two stored (or prepared) signatures: S(x * reversed y) = S(x) ⊗ S(y)^-1 (Chen)."""
    tx, ix, ty, iy, level = _sig_pair(sx, sy, dim, level)
    return _concat_from_tensors(tx, ty, int(dim), level, _check_basis(basis), ix, iy)


def _concat_distance_dx(dx, dy, level, method, basis):
    """sigma_*^n = |log S(x * reversed y)| + |log S(y * reversed x)| (eq. 8.5)."""
    d = dx.shape[1]
    if method == "iisignature":
        a = _logsig_flat(np.vstack([dx, _reverse_increments(dy)]), level, method, basis)
        b = _logsig_flat(np.vstack([dy, _reverse_increments(dx)]), level, method, basis)
        return float(np.linalg.norm(a) + np.linalg.norm(b))
    return _concat_from_tensors(_sig_tensor_numpy(dx, level), _sig_tensor_numpy(dy, level), d, level, basis)


def normalized_difference(a, b, zero_norm=ZERO_NORM):
    """sim = |a/|a| - b/|b|| for two precomputed log-signature vectors (eq. 9.1), in [0, 2].

    A vector with norm <= ``zero_norm`` is taken as the zero vector (it has no direction): two zero
    vectors give 0, one zero vector gives 1 (the distance from a unit vector to the origin).
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    b = np.asarray(b, dtype=np.float64).reshape(-1)
    if a.shape != b.shape:
        raise ShapeSigError(f"log-signatures of different lengths: {a.size} and {b.size}")
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    za, zb = not na > zero_norm, not nb > zero_norm
    if za or zb:
        return 0.0 if (za and zb) else 1.0  # |u - 0| = 1 for a unit vector u
    return float(np.linalg.norm(a / na - b / nb))


def _check_pair(x, y):
    if x.shape[1] != y.shape[1]:
        raise ShapeSigError(f"paths of different dimensions: {x.shape[1]} and {y.shape[1]}")


def path_group_distance(x, y, level, *, method="auto"):
    """rho^n(x, y) of eqs. 8.1-8.3 for paths given as points (points, dim)."""
    x, y = _as_path(x, "x"), _as_path(y, "y")
    _check_pair(x, y)
    level = _check_level(level)
    return _group_distance_dx(np.diff(x, axis=0), np.diff(y, axis=0), level, resolve_method(method, x.shape[1]))


def path_concat_distance(x, y, level, *, basis="lyndon", method="auto"):
    """sigma_*^n(x, y) of eq. 8.5 for paths given as points."""
    x, y = _as_path(x, "x"), _as_path(y, "y")
    _check_pair(x, y)
    level = _check_level(level)
    m = resolve_method(method, x.shape[1], log=True)
    return _concat_distance_dx(np.diff(x, axis=0), np.diff(y, axis=0), level, m, _check_basis(basis))


def path_linear_distance(x, y, level, *, basis="lyndon", method="auto"):
    """sigma_L^n(x, y) = |log S(x) - log S(y)| (eq. 8.6) for paths given as points."""
    a, b = _path_log_signatures(x, y, level, basis, method)
    return float(np.linalg.norm(a - b))


def path_normalized_distance(x, y, level, *, basis="lyndon", method="auto"):
    """sim^n(x, y) (eq. 9.1) for paths given as points; see ``normalized_difference`` for zero."""
    return normalized_difference(*_path_log_signatures(x, y, level, basis, method))


def _path_log_signatures(x, y, level, basis, method):
    """Both paths' log-signatures (points of the same dimension)."""
    x, y = _as_path(x, "x"), _as_path(y, "y")
    _check_pair(x, y)
    return (path_log_signature(x, level, basis=basis, method=method),
            path_log_signature(y, level, basis=basis, method=method))


# --- curve level -------------------------------------------------------------------------------------

def _select(R, joints, name):
    R = as_curve(R, name)
    if joints is not None:
        idx = np.asarray(joints)
        if idx.dtype == bool:
            if idx.shape != (R.shape[1],):
                raise CurveError(f"{name}: joint mask has shape {idx.shape}, the curve has {R.shape[1]} joints")
            idx = np.flatnonzero(idx)
        idx = idx.astype(np.int64).reshape(-1)
        if idx.size == 0:
            raise CurveError(f"{name}: empty joint selection")
        if idx.min() < -R.shape[1] or idx.max() >= R.shape[1]:
            raise CurveError(f"{name}: joint index out of range for {R.shape[1]} joints")
        R = R[:, idx]
    return R


def development_increments(R, joints=None):
    """Increments of the development, shape (frames-1, 3*joints): log(R[k+1] R[k]^T) as rotation
    vectors, joint j in columns 3j..3j+2. ``joints``: indices or a boolean mask to keep."""
    R = _select(R, joints, "curve")
    eta = relative_rotvecs(R)
    return eta.reshape(eta.shape[0], 3 * R.shape[1])


def development(R, joints=None):
    """The development of the curve: points (frames, 3*joints), starting at 0 (sec. 7.2)."""
    return _points(development_increments(R, joints))


def signature(R, level, *, joints=None, method="auto"):
    """Truncated signature (levels 1..level, iisignature layout, length ``signature_dim(3*joints,
    level)``) of the development of the curve R: (frames, joints, 3, 3) or (frames, joints, 4) xyzw."""
    level = _check_level(level)
    dx = development_increments(R, joints)
    return _sig_flat(dx, level, resolve_method(method, dx.shape[1]))


def log_signature(R, level, *, joints=None, basis="lyndon", method="auto"):
    """Log-signature of the development of the curve R: in iisignature's default (Lyndon) basis, or
    expanded in tensor space with ``basis="tensor"`` (orthonormal coordinates)."""
    level = _check_level(level)
    basis = _check_basis(basis)
    dx = development_increments(R, joints)
    return _logsig_flat(dx, level, resolve_method(method, dx.shape[1], log=True), basis)


def _pair_increments(R0, R1, joints, drop_still):
    """Increments of both developments on the same joints; joints still in both are dropped."""
    A = _select(R0, joints, "R0")
    B = _select(R1, joints, "R1")
    if A.shape[1] != B.shape[1]:
        raise CurveError(f"the curves have {A.shape[1]} and {B.shape[1]} joints")
    ea, eb = relative_rotvecs(A), relative_rotvecs(B)
    if drop_still:
        keep = ~(still_joints(A) & still_joints(B))
        if keep.any() and not keep.all():
            ea, eb = ea[:, keep], eb[:, keep]
    return ea.reshape(ea.shape[0], 3 * ea.shape[1]), eb.reshape(eb.shape[0], 3 * eb.shape[1])


def _pair_log_signatures(R0, R1, level, joints, drop_still, basis, method):
    """The flat log-signatures of both curves' developments, on the joints they are compared on."""
    level = _check_level(level)
    basis = _check_basis(basis)
    dx, dy = _pair_increments(R0, R1, joints, drop_still)
    m = resolve_method(method, dx.shape[1], log=True)
    return _logsig_flat(dx, level, m, basis), _logsig_flat(dy, level, m, basis)


def group_distance(R0, R1, level, *, joints=None, drop_still=True, method="auto"):
    """rho^n between the developments of two curves (eqs. 8.1-8.3; Lyons-Victoir norm, both terms).

    ``drop_still`` drops joints that are still in both curves (they change nothing but the cost)."""
    level = _check_level(level)
    dx, dy = _pair_increments(R0, R1, joints, drop_still)
    return _group_distance_dx(dx, dy, level, resolve_method(method, dx.shape[1]))


def concat_distance(R0, R1, level, *, joints=None, drop_still=True, basis="lyndon", method="auto"):
    """sigma_*^n (eq. 8.5) with the group concatenation of eq. 7.9 (path concatenation of the
    developments)."""
    level = _check_level(level)
    dx, dy = _pair_increments(R0, R1, joints, drop_still)
    m = resolve_method(method, dx.shape[1], log=True)
    return _concat_distance_dx(dx, dy, level, m, _check_basis(basis))


def linear_distance(R0, R1, level, *, joints=None, drop_still=True, basis="lyndon", method="auto"):
    """sigma_L^n = |log S(R0) - log S(R1)| (eq. 8.6)."""
    x, y = _pair_log_signatures(R0, R1, level, joints, drop_still, basis, method)
    return float(np.linalg.norm(x - y))


def normalized_distance(R0, R1, level, *, joints=None, drop_still=True, basis="lyndon", method="auto"):
    """sim^n (eq. 9.1), in [0, 2]; 0 when both curves are still, 1 when exactly one is."""
    return normalized_difference(*_pair_log_signatures(R0, R1, level, joints, drop_still, basis, method))
