"""Generated frames between a last known pose and a target pose, without training: the SO(3)^d geodesic from one
to the other with the motion's velocities carried in and out (``geodesic_gap``): each joint follows
``R0 exp(s D)`` (D = log(R0^T R1), s = t / T) times an inertialized offset ``exp(f0(t) d0 + f1(t) d1)`` where
d0, d1 are the differences between the clips' own body velocities at the seams and the geodesic's, and f0, f1 are
critically damped (``t e^{-t/tau}``) and windowed so the offsets vanish at both ends with the velocities exact
there; the root path the same way about the straight line. See docs/transitions.md, "In-betweening".
"""

import numpy as np

from ..geometry import so3

__all__ = ["TAU", "geodesic_gap", "seam_velocities", "ease_weights", "gap_times"]

TAU = 0.12  # s: the time constant of the carried velocities (t e^{-t/TAU} peaks at TAU)


def gap_times(frames, fps):
    """(t, T): the generated frames' times after the last known pose (1/fps .. frames/fps) and the gap's whole span
    T = (frames + 1) / fps (to the target pose)."""
    return np.arange(1, frames + 1) / float(fps), (frames + 1) / float(fps)


def _damped(t, T, tau):
    """(f0, f1): the windowed critically damped profiles of the module docstring (f0' (0) = 1, f1'(T) = 1, both 0
    with f0'(T) = f1'(0) = 0 at the other end)."""
    s = t / T
    if tau is None:  # undamped: the cubic Hermite about the geodesic
        return t * (1.0 - s) ** 2, -(T - t) * s ** 2
    return t * np.exp(-t / tau) * (1.0 - s) ** 2, -(T - t) * np.exp(-(T - t) / tau) * s ** 2


def seam_velocities(X, root, fps, at_end):
    """(omega (bones, 3) body angular velocities in rad/s, v (3,) root velocity) of a clip's last (``at_end``) or
    first two frames; (None, None) for a one-frame clip (its velocity is unknown: the geodesic's is taken)."""
    if len(X) < 2:
        return None, None
    a, b = (X[-2], X[-1]) if at_end else (X[0], X[1])
    pa, pb = (root[-2], root[-1]) if at_end else (root[0], root[1])
    return so3.log(np.swapaxes(a, -1, -2) @ b) * fps, (pb - pa) * fps


def geodesic_gap(X0, p0, w0, v0, X1, p1, w1, v1, frames, fps, tau=TAU):
    """(X (frames, bones, 3, 3), root (frames, 3)): the module docstring's in-between from pose X0 (bones, 3, 3) at
    root p0 with body velocities w0 (bones, 3) and root velocity v0 to X1, p1, w1, v1 over ``frames`` generated
    frames at ``fps`` (the target is frame ``frames + 1``); a velocity given as None is the geodesic's (nothing
    carried)."""
    t, T = gap_times(frames, fps)
    s = t / T
    D = so3.log(np.swapaxes(X0, -1, -2) @ X1)
    dp = p1 - p0
    w0, w1 = (D / T if w is None else w for w in (w0, w1))
    v0, v1 = (dp / T if v is None else v for v in (v0, v1))
    f0, f1 = _damped(t, T, tau)
    geo = X0[None] @ so3.exp(s[:, None, None] * D[None])
    off = f0[:, None, None] * (w0 - D / T)[None] + f1[:, None, None] * (w1 - D / T)[None]
    X = geo @ so3.exp(off)
    root = p0[None] + s[:, None] * dp[None] + f0[:, None] * (v0 - dp / T)[None] + f1[:, None] * (v1 - dp / T)[None]
    return X, root


def ease_weights(frames):
    """(frames,) smoothstep weights of the generated frames from the last known pose (0) to the target (1): zero
    slope at both ends (offsets faded with them add no velocity at the seams)."""
    s = np.arange(1, frames + 1) / float(frames + 1)
    return s * s * (3.0 - 2.0 * s)
