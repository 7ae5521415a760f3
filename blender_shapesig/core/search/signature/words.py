"""Word codes and the count sketch of the signature index: every Lyndon word gets a global integer code over the
skeleton's letters (joint j has letters 3j, 3j+1, 3j+2), so directions computed on different sets of moving
joints match word by word, exactly (``entry.entry_distance``), and the codes hash into a count sketch whose
buckets are comparable across clips. See docs/search.md.
"""

from functools import lru_cache

import numpy as np

from ...signatures import tensor
from ...errors import ShapeSigError

__all__ = ["SKETCH_DIM", "SKETCH_SEED", "word_codes", "sketch"]

# Count-sketch buckets per clip (float32): recall@10 against the exact ranking in docs/search.md.
SKETCH_DIM = 4096
SKETCH_SEED = 0x9E3779B97F4A7C15
_MASK64 = (1 << 64) - 1


@lru_cache(maxsize=64)
def _local_letters(n_letters, level):
    """Letters (words, level) of the Lyndon words over n_letters letters, levels 1..level in the order of
    ``signatures.log_signature`` (level by level, lexicographic), padded with -1."""
    blocks = []
    for m in range(1, level + 1):
        codes = tensor.lyndon_words(n_letters, m)
        powers = n_letters ** np.arange(m - 1, -1, -1, dtype=np.int64)
        letters = (codes[:, None] // powers[None, :]) % n_letters
        pad = np.full((letters.shape[0], level - m), -1, dtype=np.int64)
        blocks.append(np.hstack([letters, pad]))
    out = np.vstack(blocks) if blocks else np.zeros((0, level), np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=256)
def _word_codes(n_bones, moving, level):
    """Global codes: a word's letters (global letter + 1, 0 for padding) read as digits in base 3 n_bones + 1."""
    letters_global = np.array([3 * j + a for j in moving for a in range(3)], dtype=np.int64)
    local = _local_letters(len(letters_global), level)
    base = 3 * n_bones + 1
    if base ** level >= 2 ** 62:
        raise ShapeSigError(f"too many bones ({n_bones}) for a level-{level} index")
    g = np.where(local >= 0, letters_global[np.maximum(local, 0)] + 1, 0)
    powers = base ** np.arange(level - 1, -1, -1, dtype=np.int64)
    codes = g @ powers
    codes.setflags(write=False)
    return codes


def word_codes(n_bones, moving, level):
    """Global integer codes of the Lyndon words over the letters of the ``moving`` joints (indices into a
    skeleton of ``n_bones``), in the order of the log-signature computed on those joints alone."""
    return _word_codes(int(n_bones), tuple(int(j) for j in moving), int(level))


def _splitmix64(x):
    x = (x + np.uint64(SKETCH_SEED)) & np.uint64(_MASK64)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@lru_cache(maxsize=256)
def _sketch_map(n_bones, moving, level, dim):
    codes = _word_codes(n_bones, moving, level).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = _splitmix64(codes)
    bucket = (h % np.uint64(dim)).astype(np.int64)
    sign = np.where((h >> np.uint64(40)) & np.uint64(1), 1.0, -1.0)
    return bucket, sign


def sketch(direction, n_bones, moving, level, dim=SKETCH_DIM):
    """Count sketch of a log-signature direction: word w adds sign(w) * u_w to bucket(w), both from a
    hash of the word's global code, so sketches of clips with different moving joints are comparable
    and |sketch(u) - sketch(v)| estimates |u - v| (unbiased in the square)."""
    if not len(moving):
        return np.zeros(int(dim), np.float32)
    bucket, sign = _sketch_map(int(n_bones), tuple(int(j) for j in moving), int(level), int(dim))
    return np.bincount(bucket, weights=sign * np.asarray(direction, np.float64), minlength=dim).astype(np.float32)
