"""The truncated tensor algebra T^(n)(R^d) in numpy (reference sec. 7), iisignature's layout (a list of levels, each
row-major over its words): sizes and the size cap, products, exp, log and inverses, and
``signature_from_increments`` (Chen's identity). The public face is ``tensor``. See docs/signatures.md.
"""

import math

import numpy as np

from ..errors import ShapeSigError

__all__ = ["MAX_TENSOR_ENTRIES", "CHUNK_ENTRIES", "tensor_size", "check_size", "zero", "one", "flatten", "unflatten",
           "level_count", "mul", "exp", "log", "inverse", "antipode", "level_norms", "signature_from_increments"]
# Largest number of coefficients of one level we agree to build (d^n): 93 dimensions at level 3 is
# 804,357; level 4 would be 74.8 million (600 MB per tensor) and is refused with a clear message.
MAX_TENSOR_ENTRIES = 20_000_000


def tensor_size(dim, level):
    """Number of coefficients of levels 1..level: d + d^2 + ... + d^n (iisignature.siglength)."""
    return sum(dim ** k for k in range(1, level + 1))


def check_size(dim, level):
    """Raise ShapeSigError when d^level is too large to hold in memory."""
    if dim < 1 or level < 1:
        raise ShapeSigError(f"signature needs dimension >= 1 and level >= 1, got {dim} and {level}")
    if dim ** level > MAX_TENSOR_ENTRIES:
        raise ShapeSigError(
            f"a level-{level} signature of a {dim}-dimensional path has {dim ** level:,} coefficients "
            f"at the top level (limit {MAX_TENSOR_ENTRIES:,}); use a lower level or fewer joints"
        )


def zero(dim, level):
    return [np.zeros(dim ** k) for k in range(level + 1)]


def one(dim, level):
    t = zero(dim, level)
    t[0][0] = 1.0
    return t


def flatten(t):
    """Levels 1..n concatenated (level 0 dropped): the iisignature layout."""
    return np.concatenate([np.asarray(a, dtype=np.float64).reshape(-1) for a in t[1:]])


def unflatten(v, dim, level, scalar=1.0):
    """Inverse of ``flatten``; level 0 is set to ``scalar`` (1 for a signature, 0 for a log)."""
    v = np.asarray(v, dtype=np.float64).reshape(-1)
    if v.size != tensor_size(dim, level):
        raise ShapeSigError(
            f"expected {tensor_size(dim, level)} coefficients for dimension {dim} level {level}, got {v.size}"
        )
    out = [np.array([float(scalar)])]
    pos = 0
    for k in range(1, level + 1):
        out.append(v[pos:pos + dim ** k].copy())
        pos += dim ** k
    return out


def level_count(t):
    """The top level n of a tensor [a_0, ..., a_n]."""
    return len(t) - 1


def mul(a, b, level=None):
    """Truncated tensor product a ⊗ b (levels 0..level)."""
    n = min(level_count(a), level_count(b)) if level is None else level
    out = []
    for k in range(n + 1):
        acc = None
        for i in range(k + 1):
            ai, bj = a[i], b[k - i]
            if not ai.any() or not bj.any():
                continue
            term = np.multiply.outer(ai, bj).reshape(-1)
            acc = term if acc is None else acc + term
        if acc is None:
            acc = np.zeros(a[1].size ** k if k else 1)
        out.append(acc)
    return out


def exp(v, level):
    """exp_⊗(v) = 1 + v + v⊗v/2! + ... truncated (eq. 7.3)."""
    v = np.asarray(v, dtype=np.float64).reshape(-1)
    out = [np.ones(1), v.copy()]
    for k in range(2, level + 1):
        out.append(np.multiply.outer(out[-1], v).reshape(-1) / k)
    return out[: level + 1]


def log(a):
    """Truncated logarithm of a tensor with a_0 > 0 (sec. 7.5), in closed form:

        log a = log a_0 + sum_{k=1}^{n} (-1)^{k+1} X^{⊗k} / k,     X = a / a_0 - 1.

    X has no level-0 part, so X^{⊗k} starts at level k; each power is built from the previous one
    level by level, skipping the levels that are zero (at level 3: three outer products in all).
    """
    n = level_count(a)
    a0 = float(a[0][0])
    if not a0 > 0:
        raise ShapeSigError("the logarithm needs a positive level-0 coefficient")
    x = [None] + [ak / a0 for ak in a[1:]]
    out = [np.array([math.log(a0)])] + [xk.copy() for xk in x[1:]]
    power = x  # X^k: power[j] for j >= k (entries below k unused)
    for k in range(2, n + 1):
        new = [None] * (n + 1)
        for j in range(k, n + 1):
            acc = None
            for i in range(1, j - k + 2):  # (X^(k-1))_{j-i} ⊗ X_i, with j - i >= k - 1
                term = np.multiply.outer(power[j - i], x[i]).reshape(-1)
                acc = term if acc is None else acc + term
            new[j] = acc
            out[j] += (((-1) ** (k + 1)) / k) * acc
        power = new
    return out


def inverse(a):
    """Inverse in the truncated tensor algebra by the series (1 + X)^-1 = sum (-X)^k (any a_0 != 0)."""
    n = level_count(a)
    a0 = float(a[0][0])
    if a0 == 0:
        raise ShapeSigError("the tensor is not invertible (level-0 coefficient 0)")
    x = [np.zeros(1)] + [ak / a0 for ak in a[1:]]
    # Horner: acc = 1; acc = 1 - X acc, n times.
    acc = [np.ones(1)] + [np.zeros_like(ak) for ak in x[1:]]
    for _ in range(n):
        prod = mul(x, acc, n)
        acc = [np.ones(1) - prod[0]] + [-p for p in prod[1:]]
    return [ak / a0 for ak in acc]


def antipode(a, dim):
    """Word reversal with sign (-1)^k at level k: the inverse of a group-like element (a signature).

    S(x)^-1 = S(reversed x) (eq. 7.6) and its coefficient of the word w is (-1)^|w| times that of w read
    backwards. Exact also for truncated signatures. For a non-group-like tensor use ``inverse``.
    """
    out = [a[0].copy()]
    for k in range(1, level_count(a) + 1):
        t = a[k].reshape((dim,) * k).transpose(tuple(range(k - 1, -1, -1)))
        out.append(((-1.0) ** k) * t.reshape(-1))
    return out


def level_norms(t):
    """Euclidean norm of every level 1..n."""
    return np.array([float(np.linalg.norm(ak)) for ak in t[1:]])


# Steps processed at once by signature_from_increments: the intermediate arrays hold about
# chunk * d^(level-1) values; longer paths are cut into chunks joined by Chen's identity.
CHUNK_ENTRIES = 4_000_000


def signature_from_increments(dx, level):
    """Signature (levels 0..level) of the piecewise-linear path with increments ``dx`` (m, d).

    Long paths are cut into chunks of at most max(64, CHUNK_ENTRIES / d^(level-1)) steps, whose
    signatures are multiplied (Chen's identity, eq. 7.4), so memory stays bounded.
    """
    dx = np.asarray(dx, dtype=np.float64)
    if dx.ndim != 2:
        raise ShapeSigError(f"increments must have shape (steps, dim), got {dx.shape}")
    m, d = dx.shape
    check_size(d, level)
    chunk = max(64, CHUNK_ENTRIES // max(1, d ** (level - 1)))
    if m <= chunk:
        return _signature_chunk(dx, level)
    out = None
    for start in range(0, m, chunk):
        part = _signature_chunk(dx[start:start + chunk], level)
        out = part if out is None else mul(out, part, level)
    return out


def _signature_chunk(dx, level):
    """Signature (levels 0..level) of the piecewise-linear path with increments ``dx`` (m, d).

    Chen's identity S = exp(dx_1) ⊗ ... ⊗ exp(dx_m) (sec. 7.1). Writing P_j[k] for level j of the
    signature of the first k pieces, one step adds

        P_j[k] - P_j[k-1] = (P_{j-1}[k-1] + B_{j-1}[k]) ⊗ dx_k,

    where B is Horner's partial sum of the lower terms (B = dx/j, then B = (P_i + B) ⊗ dx / (j-i) for
    i = 1 .. j-2). The levels below the top are therefore cumulative sums over time of outer
    products, and the top level is the single matrix product T^T dx with T the (m, d^(n-1)) stack of
    the bracketed terms: the top level, the costly one, is one BLAS call.
    """
    m, d = dx.shape
    out = [np.ones(1)]
    if m == 0:
        return out + [np.zeros(d ** k) for k in range(1, level + 1)]
    # prev[j]: (m, d^j), level j of the signature *before* each step (exclusive prefix); prev[0] = 1.
    prev = [np.ones((m, 1))]
    for j in range(1, level + 1):
        if j == 1:
            t_mat = np.ones((m, 1))
        else:
            # T_k = P_{j-1}[k-1] + B_{j-1}[k]; Horner with divisors j, j-1, ..., 2.
            b = dx / j
            for i in range(1, j - 1):
                b = np.multiply((prev[i] + b)[:, :, None], dx[:, None, :] / (j - i)).reshape(m, -1)
            b += prev[j - 1]
            t_mat = b
        if j == level:
            # Top level: sum_k T_k ⊗ dx_k = T^T dx, one matrix product over time (computed as
            # (dx^T T)^T, which BLAS does about twice as fast for this memory layout).
            out.append((dx.T @ t_mat).T.reshape(-1))
            break
        steps = np.multiply(t_mat[:, :, None], dx[:, None, :]).reshape(m, -1)
        excl = _exclusive_cumsum(steps)  # level j before each step
        out.append(excl[-1] + steps[-1])
        prev.append(excl)
    return out


def _exclusive_cumsum(steps):
    """out[0] = 0, out[k] = steps[0] + ... + steps[k-1] along axis 0.

    A loop over rows of whole-row additions: about ten times faster than ``np.cumsum(axis=0)`` on
    (steps, d^k) arrays with long rows, with the same additions in the same order.
    """
    out = np.empty_like(steps)
    out[0] = 0.0
    for k in range(1, steps.shape[0]):
        np.add(out[k - 1], steps[k - 1], out=out[k])
    return out
