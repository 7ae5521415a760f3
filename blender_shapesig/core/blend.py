"""Time-aligned SRVT geodesic blends (reference eq. 5.14). Issue 6."""

__all__ = ["geodesic_blend"]


def geodesic_blend(R0, R1, weight, align=True, depth=9):
    raise NotImplementedError("geodesic_blend is not implemented yet")
