"""The truncated tensor algebra T^(n)(R^d) in numpy (reference sec. 7), iisignature's layout (a list of levels, each
row-major over its words): the public face of its two owners, ``algebra`` (sizes, products, exp, log and inverses,
``signature_from_increments`` by Chen's identity) and ``lyndon`` (Lyndon words, the projection onto the Lyndon
basis, ``lyndon_log_signature`` at levels <= 3 and Witt's formula). It never imports iisignature. See
docs/signatures.md.
"""

from .algebra import (CHUNK_ENTRIES, MAX_TENSOR_ENTRIES, antipode, check_size, exp, flatten, inverse, level_norms,
                      log, mul, one, signature_from_increments, tensor_size, unflatten, zero)
from .lyndon import (log_signature_dim, lyndon_coordinates, lyndon_level_sizes, lyndon_log_signature,
                     lyndon_projection, lyndon_to_tensor, lyndon_words)

__all__ = [
    "MAX_TENSOR_ENTRIES",
    "CHUNK_ENTRIES",
    "tensor_size",
    "check_size",
    "zero",
    "one",
    "flatten",
    "unflatten",
    "mul",
    "exp",
    "log",
    "inverse",
    "antipode",
    "level_norms",
    "signature_from_increments",
    "lyndon_words",
    "lyndon_projection",
    "lyndon_coordinates",
    "lyndon_log_signature",
    "lyndon_to_tensor",
    "log_signature_dim",
    "lyndon_level_sizes",
]
