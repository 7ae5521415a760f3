"""Curves in SO(3)^d (reference secs. 4-6): validation, the right logarithmic derivative, the SRVT and its inverse,
piecewise-geodesic interpolation and the L2 distance d_P*. A curve is ``(frames, joints, 3, 3)`` matrices (or
``(frames, joints, 4)`` xyzw quaternions) at times from 0 to 1, a geodesic between samples, so its derivative and
SRVT are piecewise constant (one row per interval). See docs/model.md.
"""

import contextlib

import numpy as np

from . import so3
from ..errors import CurveError

__all__ = [
    "as_curve",
    "as_curve_pair",
    "as_times",
    "uniform_times",
    "move_to_identity",
    "relative_rotvecs",
    "right_log_derivative",
    "srvt",
    "srvt_of_velocity",
    "ZERO_STEP",
    "SRVT_NORMS",
    "DEFAULT_SRVT_NORM",
    "use_srvt_norm",
    "inverse_srvt",
    "geodesic_interpolate",
    "l2_distance",
    "srvt_l2_squared",
]


def as_curve(R, name="curve"):
    """Return ``R`` as a float64 array (frames, joints, 3, 3) of rotation matrices.

    Quaternions (frames, joints, 4) in (x, y, z, w) order are normalized and converted. A 3-D
    array (frames, 3, 3) is taken as a single joint. Raises CurveError on any other shape, on
    fewer than one frame, or on non-finite values.
    """
    arr = np.asarray(R, dtype=np.float64)
    if arr.ndim == 3 and arr.shape[1:] == (3, 3):
        arr = arr[:, None]
    if arr.ndim == 3 and arr.shape[-1] == 4:
        if not np.all(np.isfinite(arr)):
            raise CurveError(f"{name}: quaternions contain NaN or infinite values")
        norms = np.linalg.norm(arr, axis=-1)
        if np.any(norms < 1e-12):
            raise CurveError(f"{name}: a quaternion has zero length")
        arr = so3.matrix_from_quat(arr, scalar_first=False)
    if arr.ndim != 4 or arr.shape[-2:] != (3, 3):
        raise CurveError(
            f"{name}: expected rotation matrices (frames, joints, 3, 3) or quaternions "
            f"(frames, joints, 4), got shape {arr.shape}"
        )
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise CurveError(f"{name}: needs at least one frame and one joint, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CurveError(f"{name}: rotation matrices contain NaN or infinite values")
    return arr


def as_curve_pair(R0, R1):
    """Two curves (``as_curve``) of the same joints and at least two frames each, else CurveError."""
    R0, R1 = as_curve(R0, "R0"), as_curve(R1, "R1")
    if R0.shape[1] != R1.shape[1]:
        raise CurveError(f"the curves have {R0.shape[1]} and {R1.shape[1]} joints")
    if R0.shape[0] < 2 or R1.shape[0] < 2:
        raise CurveError("each curve needs at least two frames")
    return R0, R1


def uniform_times(frames):
    """The uniform grid of [0, 1] with ``frames`` points (``[0.0]`` for one frame)."""
    if frames == 1:
        return np.zeros(1)
    return np.linspace(0.0, 1.0, frames)


def as_times(t, frames, name="t"):
    """Validate a time grid for a curve of ``frames`` samples; None means uniform."""
    if t is None:
        return uniform_times(frames)
    t = np.asarray(t, dtype=np.float64)
    if t.shape != (frames,):
        raise CurveError(f"{name}: expected shape ({frames},), got {t.shape}")
    if not np.all(np.isfinite(t)):
        raise CurveError(f"{name}: contains NaN or infinite values")
    if frames > 1:
        if np.any(np.diff(t) <= 0):
            raise CurveError(f"{name}: times must be strictly increasing")
        if abs(t[0]) > 1e-12 or abs(t[-1] - 1.0) > 1e-12:
            raise CurveError(f"{name}: times must run from 0 to 1, got {t[0]!r} to {t[-1]!r}")
    return t


def move_to_identity(R):
    """Right-translate every joint so that the curve starts at the identity (P*): R[k] R[0]^T."""
    R = as_curve(R)
    return R @ np.swapaxes(R[0], -1, -2)[None]


def relative_rotvecs(R):
    """log(R[k+1] R[k]^T) as rotation vectors, shape (frames-1, joints, 3).

    These are the increments of the development of the curve in R^(3 joints); they do not depend
    on the time grid and are unchanged by a right translation of the curve.
    """
    return so3.relative_rotvecs(as_curve(R))




def right_log_derivative(R, t=None):
    """eta_k = log(R[k+1] R[k]^T) / (t[k+1] - t[k]), shape (frames-1, joints, 3) (eqs. 5.10, 5.13)."""
    R = as_curve(R)
    t = as_times(t, R.shape[0])
    return relative_rotvecs(R) / np.diff(t)[:, None, None]


# A step whose rotation angle is below this (radians) is rounding noise of a still joint: its velocity
# is taken as exactly zero. Without this, the square root of the SRVT turns 1e-16 of noise into 1e-8.
ZERO_STEP = 1e-12


# How the SRVT normalizes a velocity of SO(3)^d: "joint" divides each joint's eta_j by sqrt(|eta_j|) (eq. 5.11
# applied per factor, this package's original form); "group" divides the whole eta by sqrt(|eta|) with |eta| the
# norm of so(3)^d over all joints (eq. 4.5 with the product norm of sec. 5.1: the thesis' definition).
SRVT_NORMS = ("joint", "group")
DEFAULT_SRVT_NORM = "joint"


def _check_norm(norm):
    norm = DEFAULT_SRVT_NORM if norm is None else norm
    if norm not in SRVT_NORMS:
        raise CurveError(f"SRVT norm must be one of {', '.join(SRVT_NORMS)}, got {norm!r}")
    return norm


def srvt_of_velocity(eta, steps, norm=None):
    """q = eta / sqrt(|eta|) (eq. 5.11) from velocities ``eta`` (..., joints, 3) and the rotation ``steps`` they
    come from (rotation vectors, broadcastable to eta): zero where the step angle is at most ZERO_STEP
    (rounding noise of a still joint) or eta is 0. The one SRVT zero rule (``srvt``, the blends).

    ``norm``: "joint" (|eta_j| per joint) or "group" (|eta| over the last two axes, the so(3)^d norm; the zero
    rule still acts per joint before the norm is taken). None: ``DEFAULT_SRVT_NORM``."""
    norm_kind = _check_norm(norm)
    steps = np.asarray(steps)
    moving = np.einsum("...i,...i->...", steps, steps) > ZERO_STEP * ZERO_STEP
    if norm_kind == "group":
        eta = eta * np.broadcast_to(moving, eta.shape[:-1])[..., None]
        size = np.sqrt(np.sum(eta * eta, axis=(-2, -1)))
        scale = np.divide(1.0, np.sqrt(size), out=np.zeros_like(size), where=size > 0.0)
        return eta * scale[..., None, None]
    size = np.sqrt(np.einsum("...i,...i->...", eta, eta))
    nz = moving & (size > 0.0)
    scale = np.divide(1.0, np.sqrt(size), out=np.zeros_like(size), where=nz)
    return eta * scale[..., None]


def srvt(R, t=None, norm=None):
    """Square-root-velocity transform of a curve in SO(3)^d, shape (frames-1, joints, 3).

    ``norm="joint"``: q_k = eta_k / sqrt(|eta_k|) per joint (eq. 5.11 per factor); ``norm="group"``: the
    thesis' q_k = eta_k / sqrt(|eta_k|) with |eta_k| the norm of so(3)^d over all joints (eq. 4.5, sec. 5.1).
    None: ``DEFAULT_SRVT_NORM``. Both are elastic: under a reparametrization phi, q becomes (q o phi) sqrt(phi').
    A joint that does not move on an interval (eta = 0, or a step angle below ``ZERO_STEP`` = 1e-12 rad,
    i.e. rounding noise) contributes q = 0 there, not NaN.
    """
    R = as_curve(R)
    t = as_times(t, R.shape[0])
    steps = so3.relative_rotvecs(R)
    return srvt_of_velocity(steps / np.diff(t)[:, None, None], steps, norm)


def inverse_srvt(q, t=None, start=None, norm=None):
    """Invert the SRVT: R[0] = start, R[k+1] = exp((t[k+1]-t[k]) |q_k| q_k) R[k] (sec. 5.2).

    ``q`` has shape (frames-1, joints, 3); ``start`` is a pose (joints, 3, 3) or quaternions
    (joints, 4), the identity by default; ``norm`` as in ``srvt`` (|q_k| per joint or over all joints).
    Returns the curve (frames, joints, 3, 3).
    """
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 3 or q.shape[-1] != 3:
        raise CurveError(f"q: expected shape (intervals, joints, 3), got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise CurveError("q: contains NaN or infinite values")
    n, j = q.shape[:2]
    t = as_times(t, n + 1)
    R0 = None  # the identity
    if start is not None:
        R0 = as_curve(np.asarray(start)[None], name="start")[0]
        if R0.shape[0] != j:
            raise CurveError(f"start: has {R0.shape[0]} joints, q has {j}")
    if _check_norm(norm) == "group":
        size = np.sqrt(np.sum(q * q, axis=(1, 2)))[:, None, None]
    else:
        size = np.linalg.norm(q, axis=-1, keepdims=True)
    return so3.integrate(q * size * np.diff(t)[:, None, None], R0)


@contextlib.contextmanager
def use_srvt_norm(norm):
    """Within the block, ``srvt(R)`` without a ``norm`` (e.g. inside ``elastic``, whose DP takes curves) uses
    ``norm``: the evaluation compares both norms this way. Not thread-safe: set it around whole runs."""
    global DEFAULT_SRVT_NORM
    old, DEFAULT_SRVT_NORM = DEFAULT_SRVT_NORM, _check_norm(norm)
    try:
        yield
    finally:
        DEFAULT_SRVT_NORM = old


def geodesic_interpolate(R, t, t_new, *, increments=None):
    """Evaluate the piecewise-geodesic curve through samples R at times t (eqs. 5.8, 5.9).

    ``t`` may be None (uniform). ``t_new`` is any array of times in [t[0], t[-1]]; samples that
    hit a knot exactly return that sample unchanged. ``increments``: ``relative_rotvecs(R)`` when the
    caller already has them. Shape (len(t_new), joints, 3, 3).
    """
    R = as_curve(R)
    f = R.shape[0]
    t = as_times(t, f)
    t_new = np.asarray(t_new, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(t_new)):
        raise CurveError("t_new: contains NaN or infinite values")
    tol = 1e-12
    if t_new.size and (t_new.min() < t[0] - tol or t_new.max() > t[-1] + tol):
        raise CurveError(f"t_new: times must lie in [{t[0]}, {t[-1]}]")
    if f == 1:
        return np.repeat(R, t_new.size, axis=0)
    t_new = np.clip(t_new, t[0], t[-1])
    k = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, f - 2)
    frac = (t_new - t[k]) / (t[k + 1] - t[k])
    out = R[k].copy()
    inner = (frac > 0.0) & (frac < 1.0)
    if np.any(inner):
        rel = relative_rotvecs(R) if increments is None else increments
        out[inner] = so3.exp(rel[k[inner]] * frac[inner, None, None]) @ R[k[inner]]
    at_end = frac >= 1.0
    out[at_end] = R[k[at_end] + 1]
    return out


def srvt_l2_squared(q0, t0, q1, t1):
    """Integral over [0, 1] of |q0 - q1|^2 for piecewise-constant q on grids t0, t1.

    The breakpoints are merged exactly (sec. 6.2): on every interval of the merged grid both
    functions are constant.
    """
    if np.array_equal(t0, t1):
        diff = q0 - q1
        return float(np.sum(np.sum(diff * diff, axis=(1, 2)) * np.diff(t0)))
    merged = np.union1d(t0, t1)
    widths = np.diff(merged)
    mids = 0.5 * (merged[:-1] + merged[1:])
    i0 = np.clip(np.searchsorted(t0, mids, side="right") - 1, 0, len(t0) - 2)
    i1 = np.clip(np.searchsorted(t1, mids, side="right") - 1, 0, len(t1) - 2)
    diff = q0[i0] - q1[i1]
    return float(np.sum(np.sum(diff * diff, axis=(1, 2)) * widths))


def l2_distance(R0, R1, t0=None, t1=None):
    """d_P*: L2 distance of the SRVTs of both curves moved to P* (sec. 4.2, 6.2).

    On the merged grid when the grids differ (unequal frame counts or given times). The SRVT is
    invariant under right translation, so moving to P* changes nothing in q; it is done anyway to
    make the definition explicit.
    """
    R0, R1 = (move_to_identity(R) for R in as_curve_pair(R0, R1))
    t0 = as_times(t0, R0.shape[0], "t0")
    t1 = as_times(t1, R1.shape[0], "t1")
    return float(np.sqrt(max(srvt_l2_squared(srvt(R0, t0), t0, srvt(R1, t1), t1), 0.0)))
