"""Planted feet in blends (issue 18): foot contacts of the sources, carried through the warp, kept planted in the
blend by an analytic two-bone IK post-pass. STUB: the contract only; the implementation lands with issue 18.

Contract (used by the blend command and operator):
    lock_feet(blend, sources) -> (Clip, report)
``blend`` is a result of ``core.blend`` (``meta["source_times"]``: per source, the time in seconds from that
source's first frame of every blended frame; for two-clip blends it can be derived from ``meta["time_map"]`` and
``meta["warp"]``); ``sources`` are the clips blended, the first one's rig being the blend's. Returns a new Clip (the
blend with planted feet) and a JSON-able report ``{"contacts": [...], "feet": [...], ...}``.
"""

__all__ = ["FEET_MODES", "lock_feet"]

FEET_MODES = ("lock", "none")


def lock_feet(blend, sources):
    """The blend unchanged and an empty report (stub; see the module docstring)."""
    return blend, {"contacts": [], "feet": []}
