"""One compiled pass (numba, optional) from rotation matrices to the flattened per-joint SRVT of the elastic DP:
``srvt_rows(R, dt, zero_step)`` gives what ``curves.srvt(R, norm="joint")`` gives (increments, the closed-form
logarithm of ``so3``, the SRVT zero rule), to an ulp or two. ``HAVE_NUMBA`` False: ``srvt_rows`` is None.
See docs/elastic.md, "Implementation notes".
"""

import numpy as np

from . import _workspace

try:  # numba is optional, as for the DP kernels
    import numba as _numba
except Exception:  # pragma: no cover - Blender's Python
    _numba = None

HAVE_NUMBA = _numba is not None

__all__ = ["HAVE_NUMBA", "srvt_rows"]

srvt_rows = None

if HAVE_NUMBA:

    @_numba.njit(cache=True, nogil=True)
    def _increment(R, k, j):
        """The nine entries of M = R[k+1, j] R[k, j]^T, each summed (a0 b0 + a1 b1) + a2 b2 (so3._mul_transpose)."""
        A = R[k + 1, j]
        B = R[k, j]
        m00 = (A[0, 0] * B[0, 0] + A[0, 1] * B[0, 1]) + A[0, 2] * B[0, 2]
        m01 = (A[0, 0] * B[1, 0] + A[0, 1] * B[1, 1]) + A[0, 2] * B[1, 2]
        m02 = (A[0, 0] * B[2, 0] + A[0, 1] * B[2, 1]) + A[0, 2] * B[2, 2]
        m10 = (A[1, 0] * B[0, 0] + A[1, 1] * B[0, 1]) + A[1, 2] * B[0, 2]
        m11 = (A[1, 0] * B[1, 0] + A[1, 1] * B[1, 1]) + A[1, 2] * B[1, 2]
        m12 = (A[1, 0] * B[2, 0] + A[1, 1] * B[2, 1]) + A[1, 2] * B[2, 2]
        m20 = (A[2, 0] * B[0, 0] + A[2, 1] * B[0, 1]) + A[2, 2] * B[0, 2]
        m21 = (A[2, 0] * B[1, 0] + A[2, 1] * B[1, 1]) + A[2, 2] * B[1, 2]
        m22 = (A[2, 0] * B[2, 0] + A[2, 1] * B[2, 1]) + A[2, 2] * B[2, 2]
        return m00, m01, m02, m10, m11, m12, m20, m21, m22

    @_numba.njit(cache=True, nogil=True)
    def _axial_and_cos(R, w, s, c):
        """Per increment (row k * joints + j): w (3 rows), |w| and c = (tr M - 1) / 2 (so3._axial_and_cos)."""
        F, J = R.shape[0], R.shape[1]
        for k in range(F - 1):
            for j in range(J):
                m00, m01, m02, m10, m11, m12, m20, m21, m22 = _increment(R, k, j)
                r = k * J + j
                w0 = (m21 - m12) * 0.5
                w1 = (m02 - m20) * 0.5
                w2 = (m10 - m01) * 0.5
                w[0, r] = w0
                w[1, r] = w1
                w[2, r] = w2
                s[r] = np.sqrt((w0 * w0 + w1 * w1) + w2 * w2)
                c[r] = (((m00 + m11) + m22) - 1.0) * 0.5

    @_numba.njit(cache=True, nogil=True, error_model="numpy")  # IEEE division: every divisor is checked > 0
    def _srvt_from_angles(R, w, s, c, theta, dt, zero2, Q):
        F, J = R.shape[0], R.shape[1]
        for k in range(F - 1):
            inv = 1.0 / dt[k]  # one division per frame, not three per joint
            for j in range(J):
                r = k * J + j
                t = theta[r]
                if c[r] < 0.0:  # theta > pi/2: the axis from the symmetric part (so3._log_rows)
                    m00, m01, m02, m10, m11, m12, m20, m21, m22 = _increment(R, k, j)
                    cc = c[r]
                    d0 = m00 - cc
                    d1 = m11 - cc
                    d2 = m22 - cc
                    s01 = 0.5 * (m01 + m10)
                    s02 = 0.5 * (m02 + m20)
                    s12 = 0.5 * (m12 + m21)
                    if d0 >= d1 and d0 >= d2:  # the first largest diagonal, as np.argmax
                        x, y, z = d0, s01, s02
                    elif d1 >= d2:
                        x, y, z = s01, d1, s12
                    else:
                        x, y, z = s02, s12, d2
                    nrm = np.sqrt((x * x + y * y) + z * z)
                    x /= nrm
                    y /= nrm
                    z /= nrm
                    f = -t if (x * w[0, r] + y * w[1, r]) + z * w[2, r] < 0.0 else t
                    v0, v1, v2 = x * f, y * f, z * f
                else:
                    ratio = t / s[r] if s[r] > 0.0 else 1.0
                    v0, v1, v2 = w[0, r] * ratio, w[1, r] * ratio, w[2, r] * ratio
                e0, e1, e2 = v0 * inv, v1 * inv, v2 * inv
                size = np.sqrt((e0 * e0 + e1 * e1) + e2 * e2)
                o = 3 * j
                if (v0 * v0 + v1 * v1) + v2 * v2 > zero2 and size > 0.0:  # the SRVT zero rule
                    scale = 1.0 / np.sqrt(size)
                    Q[k, o] = e0 * scale
                    Q[k, o + 1] = e1 * scale
                    Q[k, o + 2] = e2 * scale
                else:
                    Q[k, o] = 0.0
                    Q[k, o + 1] = 0.0
                    Q[k, o + 2] = 0.0

    def srvt_rows(R, dt, zero_step, work=None):
        """Q (frames-1, 3 joints) of a curve R (frames, joints, 3, 3) with frames >= 2 and intervals ``dt``.
        ``work``: None, or the name of this thread's reused array for Q (``_workspace``; its temporaries too)."""
        R = np.ascontiguousarray(R, dtype=np.float64)
        F, J = R.shape[0], R.shape[1]
        n = (F - 1) * J
        reuse = work is not None
        w = _workspace.array("srvt_w", (3, n), reuse)
        s, c, theta = (_workspace.array(name, (n,), reuse) for name in ("srvt_s", "srvt_c", "srvt_theta"))
        _axial_and_cos(R, w, s, c)
        np.arctan2(s, c, out=theta)  # numpy's vectorized arctan2, the one so3.log uses
        Q = _workspace.array(work, (F - 1, 3 * J), reuse)
        _srvt_from_angles(R, w, s, c, theta, np.ascontiguousarray(dt, dtype=np.float64),
                          float(zero_step) * float(zero_step), Q)
        return Q
