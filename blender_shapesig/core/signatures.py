"""Signatures, log-signatures and the signature similarity measures (reference secs. 7-9). Issue 5."""

__all__ = [
    "signature", "log_signature", "group_distance", "concat_distance", "linear_distance",
    "normalized_distance",
]


def _todo(*_a, **_k):
    raise NotImplementedError("signatures are not implemented yet")


signature = log_signature = group_distance = concat_distance = linear_distance = _todo
normalized_distance = _todo
