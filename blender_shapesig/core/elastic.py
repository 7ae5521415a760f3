"""Elastic shape distance d_S* by dynamic programming (reference secs. 4.3, 6.2). Issue 4."""

__all__ = ["elastic_align", "elastic_distance", "reparametrize"]


def elastic_align(R0, R1, depth=9, penalty=0.0):
    raise NotImplementedError("elastic_align is not implemented yet")


def elastic_distance(R0, R1, depth=9, penalty=0.0):
    raise NotImplementedError("elastic_distance is not implemented yet")


def reparametrize(R, t, warp):
    raise NotImplementedError("reparametrize is not implemented yet")
