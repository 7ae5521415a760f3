"""The rotation toolkit of the package, pure numpy and vectorized over leading axes: SO(3) ``log`` / ``exp``,
increments and their integration, the nearest rotation, quaternions in either component order
(``scalar_first``), Blender's Euler modes and rotation channels, headings about an up axis and the one stillness
rule. Names follow scipy's ``Rotation`` (``matrix_from_quat``, ``euler_from_matrix``, ...). Conventions and the
accuracy of ``log`` / ``exp``: docs/dev/rotations.md.
"""

import numpy as np

from ..errors import ShapeSigError

__all__ = [
    "log", "exp", "angle", "relative_rotvecs", "integrate", "nearest_rotation", "align", "heading", "turn", "twist",
    "matrix_from_quat", "quat_from_matrix", "continuous_quats",
    "matrix_from_euler", "euler_from_matrix",
    "matrices_from_channels", "channels_from_matrices",
    "still_joints", "STILL_TOLERANCE", "EULER_MODES", "ROTATION_MODES",
]

EULER_MODES = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
ROTATION_MODES = EULER_MODES + ("QUATERNION", "AXIS_ANGLE")
_AX = {"X": 0, "Y": 1, "Z": 2}

# Below this angle exp uses the Taylor series of sin(t)/t and 2 sin^2(t/2)/t^2 (error < t^4/5040).
_SERIES = 1e-6


def _entries(R):
    """The nine entries of (..., 3, 3) matrices as flat arrays (row-major) and the leading shape."""
    R = np.asarray(R, dtype=np.float64)
    if R.shape[-2:] != (3, 3):
        raise ShapeSigError(f"expected rotation matrices (..., 3, 3), got shape {R.shape}")
    return R.reshape(-1, 9).T, R.shape[:-2]


def _axial_and_cos(m):
    """w = axial vector of (R - R^T)/2 (= sin(theta) a) as rows (3, n), s = |w| and c = (tr R - 1)/2
    (= cos(theta)), from the nine entry rows m. (Written with few temporaries: fresh arrays cost page faults.)"""
    n = m.shape[1]
    w = np.empty((3, n))
    np.subtract(m[7], m[5], out=w[0])
    np.subtract(m[2], m[6], out=w[1])
    np.subtract(m[3], m[1], out=w[2])
    w *= 0.5
    s = np.einsum("in,in->n", w, w)
    np.sqrt(s, out=s)
    c = np.add(m[0], m[4])
    c += m[8]
    c -= 1.0
    c *= 0.5
    return w, s, c


def angle(R):
    """Rotation angles in [0, pi] of matrices (..., 3, 3): arctan2(|w|, c), accurate near 0 and pi."""
    m, lead = _entries(R)
    _, s, c = _axial_and_cos(m)
    return np.arctan2(s, c).reshape(lead)


def log(R):
    """Rotation vectors (..., 3) of rotation matrices (..., 3, 3) (scipy's ``as_rotvec``), angle in [0, pi].

    See the module docstring for the branches that keep full precision near 0 and pi.
    """
    m, lead = _entries(R)
    return _log_rows(m).reshape(lead + (3,))


def _log_rows(m):
    """log of matrices given as nine entry rows m (9, n) (row-major): rotation vectors (n, 3)."""
    w, s, c = _axial_and_cos(m)
    theta = np.arctan2(s, c)
    ratio = np.divide(theta, s, out=np.ones_like(s), where=s > 0.0)  # theta / sin(theta); 1 at identity
    out = np.empty((s.size, 3))
    np.multiply(w, ratio, out=out.T)
    far = np.flatnonzero(c < 0.0)  # theta > pi/2: the axis from the symmetric part
    if far.size:
        mf = m[:, far]
        cf = c[far]
        d = mf[0:9:4] - cf  # diagonal of B - c I, B = (R + R^T)/2 = c I + (1 - c) a a^T
        s01, s02, s12 = 0.5 * (mf[1] + mf[3]), 0.5 * (mf[2] + mf[6]), 0.5 * (mf[5] + mf[7])
        cols = np.array([[d[0], s01, s02], [s01, d[1], s12], [s02, s12, d[2]]])
        col = cols[np.argmax(d, axis=0), :, np.arange(far.size)]  # (far, 3): the column of largest diagonal
        col /= np.linalg.norm(col, axis=1, keepdims=True)
        sign = np.where(np.einsum("ni,in->n", col, w[:, far]) < 0.0, -1.0, 1.0)
        out[far] = col * (sign * theta[far])[:, None]
    return out


def exp(v):
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (scipy's ``from_rotvec``; Rodrigues).

    Computed on rows of all the rotations at once; the result may be a non-contiguous view of them.
    """
    v = np.asarray(v, dtype=np.float64)
    if v.shape[-1:] != (3,):
        raise ShapeSigError(f"expected rotation vectors (..., 3), got shape {v.shape}")
    lead = v.shape[:-1]
    u = np.ascontiguousarray(v.reshape(-1, 3).T)  # rows x, y, z
    x, y, z = u
    t2 = x * x
    t2 += y * y
    t2 += z * z
    t = np.sqrt(t2)
    half = np.multiply(t, 0.5)
    h = np.sin(half)  # sin(t) = 2 h k, cos(t) = 1 - 2 h^2, 2 sin^2(t/2) / t^2 = 2 (h / t)^2
    k = np.cos(half, out=half)
    small = t < _SERIES
    any_small = small.any()
    if any_small:
        t[small] = 1.0
    a = np.multiply(h, k, out=k)
    a += a
    a /= t
    b = np.divide(h, t, out=t)
    b *= b
    b += b
    if any_small:
        a[small] = 1.0 - t2[small] / 6.0
        b[small] = 0.5 - t2[small] / 24.0
    c = np.multiply(h, h, out=h)
    c *= -2.0
    c += 1.0
    bu = np.multiply(u, b)  # b x, b y, b z
    o = np.empty((9, u.shape[1]))  # entry rows, row-major
    np.multiply(bu, u, out=o[0:9:4])
    o[0:9:4] += c
    bxy, bxz, byz = bu[0] * y, bu[0] * z, np.multiply(bu[1], z, out=bu[2])
    ax, ay, az = np.multiply(u, a, out=u)
    np.subtract(bxy, az, out=o[1])
    np.add(bxz, ay, out=o[2])
    np.add(bxy, az, out=o[3])
    np.subtract(byz, ax, out=o[5])
    np.subtract(bxz, ay, out=o[6])
    np.add(byz, ax, out=o[7])
    return o.T.reshape(lead + (3, 3))


def _mul_transpose(A, B):
    """A @ B^T for (..., 3, 3) stacks as nine entry rows (9, n) (faster than batched matmul on 3x3 blocks)."""
    a = A.reshape(-1, 9).T
    b = B.reshape(-1, 9).T
    out = np.empty(a.shape)
    tmp = np.empty(a.shape[1])
    for i in range(3):
        for j in range(3):
            o = out[3 * i + j]
            np.multiply(a[3 * i], b[3 * j], out=o)
            for k in (1, 2):
                np.multiply(a[3 * i + k], b[3 * j + k], out=tmp)
                o += tmp
    return out


def relative_rotvecs(R):
    """Increments log(R[k+1] R[k]^T) of a curve R (frames, ..., 3, 3): rotation vectors (frames-1, ..., 3).

    They do not depend on the time grid and are unchanged by a right translation of the curve.
    """
    R = np.asarray(R, dtype=np.float64)
    if R.shape[0] < 2:
        return np.zeros((0,) + R.shape[1:-2] + (3,))
    return _log_rows(_mul_transpose(R[1:], R[:-1])).reshape((R.shape[0] - 1,) + R.shape[1:-2] + (3,))


def integrate(steps, start=None):
    """The curve with increments ``steps`` (rotation vectors (n, ..., 3)): R[0] = start (the identity by
    default, else matrices broadcastable to (..., 3, 3)), R[k+1] = exp(steps[k]) R[k]. Shape (n+1, ..., 3, 3).
    The inverse of ``relative_rotvecs``."""
    E = exp(steps)
    out = np.empty((E.shape[0] + 1,) + E.shape[1:])
    out[0] = np.eye(3) if start is None else start
    for k in range(E.shape[0]):
        np.matmul(E[k], out[k], out=out[k + 1])
    return out


def nearest_rotation(M):
    """The rotations nearest (in Frobenius norm) to matrices M (..., 3, 3): the polar factor U V^T of the
    SVD, with the last singular direction flipped when det(U V^T) < 0. Blender stores rest matrices in
    float32, and those of very short bones are orthogonal only to ~1e-5."""
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=np.float64))
    R = U @ Vt
    flip = np.linalg.det(R) < 0
    if np.any(flip):
        U[flip, :, -1] *= -1
        R = U @ Vt
    return R


# ------------------------------------------------------------------------------------ quaternions


# ----------------------------------------------------------------------------------- directions and "up"


def align(u, v):
    """The smallest rotations (..., 3, 3) turning directions ``u`` into ``v`` (..., 3; any lengths): about
    u x v by the angle between them; a half turn about a normal of ``u`` when they are opposite."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    axis = np.cross(u, v)
    s = np.linalg.norm(axis, axis=-1, keepdims=True)
    c = np.sum(u * v, axis=-1, keepdims=True)
    normal = np.cross(u, np.eye(3)[np.argmin(np.abs(u), axis=-1)])
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    opposite = (s < 1e-12) & (c < 0)
    unit = np.where(opposite, normal, axis / np.maximum(s, 1e-300))
    return exp(np.where(s < 1e-12, np.where(opposite, np.pi, 0.0), np.arctan2(s, c)) * unit)


def _horizontal_reference(up):
    """A unit vector perpendicular to ``up``: the coordinate axis least aligned with it, made horizontal."""
    ref = np.eye(3)[int(np.argmin(np.abs(up)))]
    ref = ref - (ref @ up) * up
    return ref / np.linalg.norm(ref)


def heading(R, up, ref=None):
    """The heading of rotations R (..., 3, 3) about the unit vector ``up``: the signed angle (radians) by which
    R turns a horizontal reference vector (``ref``, default the coordinate axis least aligned with ``up``) about
    ``up``, measured on its horizontal part."""
    up = np.asarray(up, dtype=np.float64)
    ref = _horizontal_reference(up) if ref is None else np.asarray(ref, dtype=np.float64)
    g = np.asarray(R, dtype=np.float64) @ ref
    return np.arctan2(np.cross(ref, g) @ up, g @ ref)


def turn(v, up, angle):
    """Vectors ``v`` (..., 3) turned about the unit vector ``up`` by ``angle`` (radians; a number or one per
    vector), by Rodrigues' formula."""
    v = np.asarray(v, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64)
    a = np.asarray(angle, dtype=np.float64)[..., None]
    c, s = np.cos(a), np.sin(a)
    return v * c + np.cross(up, v) * s + (v @ up)[..., None] * up * (1.0 - c)


def twist(R, axis):
    """The twist angle (radians, in (-pi, pi]) of rotations R (..., 3, 3) about the unit ``axis`` in their
    swing-twist decomposition: ``2 atan2(q_v . axis, q_w)`` of the unit quaternion of R."""
    q = quat_from_matrix(np.asarray(R, dtype=np.float64), scalar_first=True)
    a = 2.0 * np.arctan2(q[..., 1:] @ np.asarray(axis, dtype=np.float64), q[..., 0])
    return np.where(a > np.pi, a - 2.0 * np.pi, np.where(a <= -np.pi, a + 2.0 * np.pi, a))


def matrix_from_quat(q, *, scalar_first):
    """Rotation matrices (..., 3, 3) of non-zero quaternions (..., 4), normalized on the way (as scipy).
    ``scalar_first``: True for Blender's (w, x, y, z), False for scipy's (x, y, z, w)."""
    q = np.asarray(q, dtype=np.float64)
    lead = q.shape[:-1]
    c = q.reshape(-1, 4).T
    w, x, y, z = c if scalar_first else (c[3], c[0], c[1], c[2])
    s = 2.0 / (w * w + x * x + y * y + z * z)
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    out = np.stack([1.0 - yy - zz, xy - wz, xz + wy,
                    xy + wz, 1.0 - xx - zz, yz - wx,
                    xz - wy, yz + wx, 1.0 - xx - yy], axis=-1)
    return out.reshape(lead + (3, 3))


def quat_from_matrix(R, *, scalar_first):
    """Unit quaternions (..., 4) of rotation matrices (..., 3, 3), with w >= 0 (Shepperd's method: the
    candidate with the largest of 4w^2, 4x^2, 4y^2, 4z^2 is computed, so no component loses digits)."""
    m, lead = _entries(R)
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    n = m.shape[1]
    cand = np.empty((4, 4, n))  # candidate, component (w, x, y, z), rotation
    cand[0] = (1 + m00 + m11 + m22, m21 - m12, m02 - m20, m10 - m01)
    cand[1] = (m21 - m12, 1 + m00 - m11 - m22, m01 + m10, m02 + m20)
    cand[2] = (m02 - m20, m01 + m10, 1 - m00 + m11 - m22, m12 + m21)
    cand[3] = (m10 - m01, m02 + m20, m12 + m21, 1 - m00 - m11 + m22)
    best = np.argmax(np.stack([cand[0, 0], cand[1, 1], cand[2, 2], cand[3, 3]]), axis=0)
    q = cand[best, :, np.arange(n)]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    if not scalar_first:
        q = q[:, [1, 2, 3, 0]]
    return q.reshape(lead + (4,))


def continuous_quats(q):
    """Quaternions (frames, ..., 4) with signs flipped so that consecutive ones lie in the same hemisphere
    (the same rotations; either component order)."""
    q = np.asarray(q, dtype=np.float64)
    if len(q) < 2:
        return q
    dots = np.einsum("...i,...i->...", q[1:], q[:-1])
    signs = np.concatenate([np.ones((1,) + dots.shape[1:]), np.cumprod(np.where(dots < 0, -1.0, 1.0), axis=0)])
    return q * signs[..., None]


# ----------------------------------------------------------------------------------------- Euler


def _axes(order):
    order = str(order).upper()
    if not order or any(a not in _AX for a in order):
        raise ShapeSigError(f"unknown Euler order {order!r}: use letters X, Y, Z (e.g. 'XYZ')")
    return [_AX[a] for a in order]


def matrix_from_euler(angles, order):
    """Rotation matrices (..., 3, 3) for angles (..., len(order)) in radians, in the order of the letters,
    about the fixed axes applied first letter first: ``R = R_last ... R_first`` (Blender's Euler mode of
    the same name; scipy's lowercase sequence). ``order``: 1 to 3 (or more) letters X, Y, Z."""
    axes = _axes(order)
    angles = np.asarray(angles, dtype=np.float64)
    if angles.shape[-1:] != (len(axes),):
        raise ShapeSigError(f"Euler order {order!r} needs {len(axes)} angles per rotation, got shape {angles.shape}")
    lead = angles.shape[:-1]
    # Rows of R as (3, 3, n) arrays: applying the rotation about axis ``ax`` to R changes only rows i, j
    # (R <- e R with e the elementary rotation), which avoids numpy's slow batched 3x3 products.
    flat = angles.reshape(-1, len(axes))
    rows = np.zeros((3, 3, flat.shape[0]))
    rows[0, 0] = rows[1, 1] = rows[2, 2] = 1.0
    for n, ax in enumerate(axes):
        c, s = np.cos(flat[:, n]), np.sin(flat[:, n])
        i, j = (ax + 1) % 3, (ax + 2) % 3
        ri, rj = rows[i].copy(), rows[j]
        rows[i] = c * ri - s * rj
        rows[j] = s * ri + c * rj
    return np.ascontiguousarray(np.moveaxis(rows, -1, 0)).reshape(lead + (3, 3))


def euler_from_matrix(R, order):
    """Angles (..., 3) in the order of the letters of the Euler mode ``order`` (three different letters,
    e.g. 'XYZ') of matrices (..., 3, 3); the middle angle in [-pi/2, pi/2] (the inverse of
    ``matrix_from_euler``). At gimbal lock (within 1e-14) the first angle is 0."""
    axes = _axes(order)
    if len(axes) != 3 or len(set(axes)) != 3:
        raise ShapeSigError(f"Euler mode {order!r}: expected three different letters (e.g. 'XYZ')")
    R = np.asarray(R, dtype=np.float64)
    i, j, k = axes
    s = 1.0 if (j - i) % 3 == 1 else -1.0
    cb = np.hypot(R[..., k, j], R[..., k, k])
    b = np.arctan2(-s * R[..., k, i], cb)  # accurate near +-pi/2, unlike arcsin
    a = np.arctan2(s * R[..., k, j], R[..., k, k])
    # At gimbal lock (cb = 0) only a + c or a - c is defined: a = 0 there. Near it a loses digits (~eps/cb),
    # but c is taken from M = R Ra^T = Rc Rb, whose (i, j) and (j, j) entries are -s sin(c) and cos(c)
    # whatever b is: the error of a moves R by ~cb * eps/cb only, and the angles always reproduce R.
    a = np.where(cb < 1e-14, 0.0, a)
    M = R @ matrix_from_euler(-a[..., None], order[0])
    c = np.arctan2(-s * M[..., i, j], M[..., j, j])
    return np.stack([a, b, c], axis=-1)


# ------------------------------------------------------------------------ Blender rotation channels


def matrices_from_channels(mode, values):
    """Rotation matrices (frames, 3, 3) from Blender channel values (frames, 3 or 4) in rotation ``mode``:
    'QUATERNION' (w, x, y, z; normalized, a zero quaternion is the identity), 'AXIS_ANGLE' (angle, x, y, z;
    a zero axis is the identity) or an Euler mode (x, y, z whatever the order)."""
    values = np.asarray(values, dtype=np.float64)
    if mode == "QUATERNION":
        zero = np.linalg.norm(values, axis=-1) < 1e-12
        return matrix_from_quat(np.where(zero[:, None], [1.0, 0.0, 0.0, 0.0], values), scalar_first=True)
    if mode == "AXIS_ANGLE":
        axis = values[:, 1:4]
        norm = np.linalg.norm(axis, axis=1)
        ok = norm > 1e-12
        return exp(axis * (np.where(ok, values[:, 0], 0.0) / np.where(ok, norm, 1.0))[:, None])
    if mode in EULER_MODES:
        return matrix_from_euler(values[:, _axes(mode)], mode)
    raise ShapeSigError(f"unknown rotation mode {mode!r}")


def _continuous_axis_angle(R):
    """(angle, x, y, z) rows for matrices (frames, 3, 3) with a continuous axis and unwrapped angle."""
    v = log(R)  # angle in [0, pi]
    angle = np.linalg.norm(v, axis=1)
    axis = np.zeros_like(v)
    ok = angle > 1e-12
    axis[ok] = v[ok] / angle[ok, None]
    # undefined axes (zero angle) take the nearest earlier defined axis (leading ones the first; +Y if none)
    if not ok.any():
        axis[:] = (0.0, 1.0, 0.0)
    elif not ok.all():
        idx = np.maximum.accumulate(np.where(ok, np.arange(len(ok)), -1))
        idx[idx < 0] = np.argmax(ok)
        axis = axis[idx]
    if len(axis) > 1:
        dots = np.einsum("ij,ij->i", axis[1:], axis[:-1])
        signs = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
        axis = axis * signs[:, None]
        angle = np.unwrap(angle * signs)  # (angle + 2 pi k, axis) is the same rotation
    return np.column_stack([angle, axis])


def channels_from_matrices(mode, R):
    """Blender channel values (frames, 3 or 4) for matrices (frames, 3, 3) in ``mode``: quaternions
    (w, x, y, z) sign-continuous, Euler (x, y, z) unwrapped (no 2 pi jumps), axis-angle (angle, x, y, z)
    with a continuous axis."""
    R = np.asarray(R, dtype=np.float64)
    if mode == "QUATERNION":
        return continuous_quats(quat_from_matrix(R, scalar_first=True))
    if mode == "AXIS_ANGLE":
        return _continuous_axis_angle(R)
    if mode in EULER_MODES:
        out = np.empty((len(R), 3))
        out[:, _axes(mode)] = euler_from_matrix(R, mode)
        return np.unwrap(out, axis=0)
    raise ShapeSigError(f"unknown rotation mode {mode!r}")


# ------------------------------------------------------------------------------------- stillness

# A joint whose rotation never moves more than this angle (radians) away from its first frame is "still".
STILL_TOLERANCE = 1e-6


def still_joints(R, tolerance=STILL_TOLERANCE):
    """Boolean mask (joints,) of a curve R (frames, joints, 3, 3): True where the joint stays within
    ``tolerance`` radians of its first frame: max_k angle(R[k] R[0]^T) <= tolerance.

    The one stillness rule of the package (Clip.still_bones, restrict_to_shared, the signature
    measures' ``drop_still``, a read action's ``meta["still_bones"]``, the blend's warp bones, the
    search index's moving joints). It lives here because it is a property of the rotations alone. Why
    this form: distance from the first pose is what "does not move" means (a slow drift made of tiny
    steps is not still), and every step of a still joint is then at most 2 tolerance by the triangle
    inequality, so dropping it changes a signature measure by that order at most. The angle is
    ``angle`` (arctan2), exact to round-off, where arccos of the trace had a floor of ~1e-8.
    """
    R = np.asarray(R, dtype=np.float64)
    if R.shape[0] < 2:
        return np.ones(R.shape[1], dtype=bool)
    rel = _mul_transpose(R, np.broadcast_to(R[:1], R.shape))
    _, s, c = _axial_and_cos(rel)
    return np.arctan2(s, c).reshape(R.shape[:2]).max(axis=0) <= tolerance
