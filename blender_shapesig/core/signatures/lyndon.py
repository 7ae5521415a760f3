"""Lyndon words and the Lyndon basis of the free Lie algebra (reference sec. 7, iisignature's ``logsig`` basis):
the words, the projection of a Lie element onto the basis and back, ``lyndon_log_signature`` (levels <= 3 straight
from the increments) and Witt's formula. It never imports iisignature. The public face is ``tensor``. See
docs/signatures.md.
"""

from functools import lru_cache

import numpy as np

from ..errors import ShapeSigError
from .algebra import check_size, level_count

__all__ = ["lyndon_words", "lyndon_projection", "lyndon_coordinates", "lyndon_log_signature", "lyndon_to_tensor",
           "log_signature_dim", "lyndon_level_sizes"]

# --- Lyndon words and the Lyndon basis ------------------------------------------------------------
#
# A word of length m over the letters 0..d-1 is coded as the integer sum_i w_i d^(m-1-i), so that the
# numeric order of codes is the lexicographic order of words and the code is the word's index in the
# row-major level-m tensor. A word is Lyndon when it is strictly smaller than all its proper
# rotations. Its standard bracketing is P_w = w for a letter and P_w = [P_u, P_v] for w = uv with v
# the longest proper suffix that is Lyndon ([a, b] = a⊗b - b⊗a). These brackets form a basis of the
# free Lie algebra (the basis of iisignature's ``logsig``, listed level by level in lexicographic
# order), and P_w = w + (words lexicographically greater than w). So the coordinates c of a Lie
# element L in this basis solve the unit-triangular system  L[u] = sum_w c_w <P_w, u>  over Lyndon
# words u, w: the projection is exact, not a least-squares fit.


@lru_cache(maxsize=None)
def _is_lyndon(dim, m):
    """Boolean mask over all d^m words of length m: is the word Lyndon."""
    check_size(dim, m)
    codes = np.arange(dim ** m, dtype=np.int64)
    ok = np.ones(codes.size, dtype=bool)
    for s in range(1, m):
        hi = dim ** (m - s)
        rot = (codes % hi) * dim ** s + codes // hi  # rotate left by s letters
        ok &= codes < rot
    ok.setflags(write=False)
    return ok


@lru_cache(maxsize=None)
def lyndon_words(dim, m):
    """Codes of the Lyndon words of length m over d letters, in lexicographic order."""
    codes = np.flatnonzero(_is_lyndon(dim, m)).astype(np.int64)
    codes.setflags(write=False)
    return codes


@lru_cache(maxsize=None)
def _factorization(dim, m):
    """(split, shape) per Lyndon word of length m: w = w[:split] w[split:] standard factorization;
    shape is a nested tuple describing the bracketing tree (a leaf is 1)."""
    codes = lyndon_words(dim, m)
    if m == 1:
        return np.zeros(codes.size, dtype=np.int64), np.zeros(codes.size, dtype=np.int64), [1]
    split = np.zeros(codes.size, dtype=np.int64)
    for s in range(m - 1, 0, -1):  # prefix length s; the smallest s with a Lyndon suffix wins
        suffix = codes % dim ** (m - s)
        lyn = _is_lyndon(dim, m - s)[suffix]
        split[lyn] = s
    shapes = []
    shape_id = np.zeros(codes.size, dtype=np.int64)
    for s in np.unique(split):
        sel = split == s
        u = codes[sel] // dim ** (m - s)
        v = codes[sel] % dim ** (m - s)
        _, su_id, su_shapes = _factorization(dim, int(s))
        _, sv_id, sv_shapes = _factorization(dim, int(m - s))
        iu = su_id[np.searchsorted(lyndon_words(dim, int(s)), u)]
        iv = sv_id[np.searchsorted(lyndon_words(dim, int(m - s)), v)]
        pairs = np.stack([iu, iv], axis=1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        for k, (a, b) in enumerate(uniq):
            shape = (su_shapes[a], sv_shapes[b])
            if shape not in shapes:
                shapes.append(shape)
            shape_id[np.flatnonzero(sel)[inv.reshape(-1) == k]] = shapes.index(shape)
    return split, shape_id, shapes


def _shape_length(shape):
    return 1 if shape == 1 else _shape_length(shape[0]) + _shape_length(shape[1])


def _expand_shape(shape, offset=0):
    """Expansion of a bracketing tree over letter positions: list of (positions, sign)."""
    if shape == 1:
        return [((offset,), 1)]
    left, right = shape
    lu = _shape_length(left)
    eu = _expand_shape(left, offset)
    ev = _expand_shape(right, offset + lu)
    out = []
    for pu, su in eu:
        for pv, sv in ev:
            out.append((pu + pv, su * sv))
            out.append((pv + pu, -su * sv))
    return out


def _letters(codes, dim, m):
    powers = dim ** np.arange(m - 1, -1, -1, dtype=np.int64)
    return (codes[:, None] // powers[None, :]) % dim


@lru_cache(maxsize=None)
def _bracket_matrix(dim, m):
    """Sparse (d^m, n_lyndon) matrix whose column w is the tensor expansion of P_w."""
    codes = lyndon_words(dim, m)
    _, shape_id, shapes = _factorization(dim, m)
    powers = dim ** np.arange(m - 1, -1, -1, dtype=np.int64)
    rows, cols, vals = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    for h, shape in enumerate(shapes):
        idx = np.flatnonzero(shape_id == h)
        letters = _letters(codes[idx], dim, m)
        for positions, sign in _expand_shape(shape):
            rows.append(letters[:, list(positions)] @ powers)
            cols.append(idx)
            vals.append(np.full(idx.size, float(sign)))
    import scipy.sparse as sp  # imported when first needed: ~0.2 s of every command line's start otherwise

    mat = sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(dim ** m, codes.size)
    )
    mat.sum_duplicates()
    mat.eliminate_zeros()
    return mat


@lru_cache(maxsize=None)
def _projection_level(dim, m):
    """Sparse matrix Q (n_lyndon, n_lyndon) with c = Q L[lyndon codes] for a Lie element L at level m."""
    codes = lyndon_words(dim, m)
    mat = _bracket_matrix(dim, m)[codes].tocsr()  # rows restricted to Lyndon words: unit triangular
    n = codes.size
    import scipy.sparse as sp

    eye = sp.identity(n, format="csr")
    if n == 0:
        return eye
    nil = (mat - eye).tocsr()
    nil.eliminate_zeros()
    # Unit lower-triangular: the inverse is the finite Neumann series sum_k (-N)^k (N nilpotent).
    inv = eye.copy()
    term = eye
    for _ in range(n):
        term = (-nil @ term).tocsr()
        term.eliminate_zeros()
        if term.nnz == 0:
            break
        inv = inv + term
    inv = inv.tocsr()
    inv.eliminate_zeros()
    return inv


def lyndon_projection(dim, level):
    """Build (and cache) the Lyndon projection for all levels 1..level; returns nothing useful but
    makes the first ``lyndon_coordinates`` call fast. Cost is reported by the benchmark."""
    check_size(dim, level)
    for m in range(1, level + 1):
        _projection_level(dim, m)


def lyndon_coordinates(t, dim):
    """Coordinates in the Lyndon basis (iisignature's ``logsig`` order) of a Lie element given in
    tensor form (levels 0..n, level 0 ignored). Returns one flat vector, level by level."""
    out = []
    for m in range(1, level_count(t) + 1):
        lm = np.asarray(t[m]).reshape(-1)
        out.append(_projection_level(dim, m) @ lm[lyndon_words(dim, m)])
    return np.concatenate(out) if out else np.zeros(0)


@lru_cache(maxsize=None)
def _lyndon3_letters(dim):
    """Letters (a, b, c) of the Lyndon words of length 3 in code order: a <= b, a < c (read-only arrays)."""
    out = tuple(np.ascontiguousarray(x) for x in _letters(lyndon_words(dim, 3), dim, 3).T)
    for x in out:
        x.setflags(write=False)
    return out


def lyndon_log_signature(dx, level):
    """Lyndon coordinates (``lyndon_coordinates``' order) of the log-signature at ``level`` <= 3 of the
    piecewise-linear path with increments ``dx`` (m, d), by matrix products.

    With P_k = dx_0 + ... + dx_(k-1) (the point before step k), Y_k = dx_(k+1) + ... + dx_(m-1) (what is left
    after it), M_k = P_k + dx_k/2 and U_k = P_k/2 + dx_k/6, Chen's identity (``_signature_chunk``) gives

        S1 = sum_k dx_k,     S2 = sum_k M_k ⊗ dx_k = M^T dx,
        S3 = sum_k (S2[<k] + P_k ⊗ dx_k/2 + dx_k ⊗ dx_k/6) ⊗ dx_k,

    and summing by parts, sum_k S2[<k] ⊗ dx_k = sum_l (M_l ⊗ dx_l) ⊗ Y_l, so

        S3[a, b, c] = sum_k dx_k[b] (M_k[a] Y_k[c] + U_k[a] dx_k[c]):

    one matrix product per first letter a, without the (m, d^2) table of running level-2 sums. The projection
    onto the Lyndon basis reads only the Lyndon words' coordinates of the tensor logarithm, and a word abc is
    Lyndon iff a <= b and a < c, so for each a only the block b >= a, c > a is formed (a third of S3): with
    log = S - (S1 ⊗ S2 + S2 ⊗ S1)/2 + S1^3/3 at level 3 (``log``, closed form), the block's coordinates are
    read in the order of the Lyndon codes. Level 2: S2 - S1 ⊗ S1 / 2 on the words a < b.
    """
    dx = np.asarray(dx, dtype=np.float64)
    if dx.ndim != 2:
        raise ShapeSigError(f"increments must have shape (steps, dim), got {dx.shape}")
    if not 1 <= level <= 3:
        raise ShapeSigError(f"lyndon_log_signature needs a level from 1 to 3, got {level}")
    m, d = dx.shape
    check_size(d, level)
    s1 = dx.sum(axis=0)
    out = [_projection_level(d, 1) @ s1]
    if level == 1:
        return out[0]
    prev = np.zeros_like(dx)
    if m > 1:
        np.cumsum(dx[:-1], axis=0, out=prev[1:])
    s2 = (prev + 0.5 * dx).T @ dx
    l2 = s2 - 0.5 * np.multiply.outer(s1, s1)
    out.append(_projection_level(d, 2) @ l2.reshape(-1)[lyndon_words(d, 2)])
    if level == 3:
        mk = prev + 0.5 * dx
        uk = 0.5 * prev + dx / 6.0
        rest = np.zeros_like(dx)
        if m > 1:
            np.cumsum(dx[:0:-1], axis=0, out=rest[-2::-1])
        la, lb, lc = _lyndon3_letters(d)
        s3 = np.empty(la.size)
        pos = 0
        for a in range(d - 1):  # S3[a, b >= a, c > a], in the order of the Lyndon codes
            v = mk[:, a:a + 1] * rest[:, a + 1:]
            v += uk[:, a:a + 1] * dx[:, a + 1:]
            size = (d - a) * (d - a - 1)
            np.matmul(dx[:, a:].T, v, out=s3[pos:pos + size].reshape(d - a, d - a - 1))
            pos += size
        # log at level 3 on the Lyndon words: S3 - (S1 ⊗ S2 + S2 ⊗ S1)/2 + S1^3/3
        s3 -= s1[la] * (0.5 * s2[lb, lc] - s1[lb] * s1[lc] / 3.0) + 0.5 * s2[la, lb] * s1[lc]
        out.append(_projection_level(d, 3) @ s3)
    return np.concatenate(out)


def lyndon_to_tensor(c, dim, level):
    """The Lie element sum_w c_w P_w in tensor form (levels 0..level): inverse of lyndon_coordinates."""
    c = np.asarray(c, dtype=np.float64).reshape(-1)
    if c.size != log_signature_dim(dim, level):
        raise ShapeSigError(
            f"expected {log_signature_dim(dim, level)} Lyndon coordinates for dimension {dim} level {level}, "
            f"got {c.size}"
        )
    out = [np.zeros(1)]
    pos = 0
    for m in range(1, level + 1):
        n = lyndon_words(dim, m).size
        out.append(_bracket_matrix(dim, m) @ c[pos:pos + n])
        pos += n
    return out


def _mobius(n):
    result, k, p = 1, n, 2
    while p * p <= k:
        if k % p == 0:
            k //= p
            if k % p == 0:
                return 0
            result = -result
        p += 1
    if k > 1:
        result = -result
    return result


def lyndon_level_sizes(dim, level):
    """Number of Lyndon words of each length 1..level over ``dim`` letters (Witt's formula
    (1/m) sum_{k | m} mu(k) dim^(m/k)): the log-signature's coordinates per level."""
    if dim < 1 or level < 1:
        raise ShapeSigError(f"log-signature needs dimension >= 1 and level >= 1, got {dim} and {level}")
    return [sum(_mobius(k) * dim ** (m // k) for k in range(1, m + 1) if m % k == 0) // m
            for m in range(1, level + 1)]


def log_signature_dim(dim, level):
    """Dimension of the free Lie algebra over R^dim truncated at ``level``: the sum of
    ``lyndon_level_sizes``; equals iisignature.logsiglength."""
    return sum(lyndon_level_sizes(dim, level))
