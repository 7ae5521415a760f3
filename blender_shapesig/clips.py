"""Deprecated: clips are read through ``core.sources`` (``read``/``read_one``; the Blender half is
``blender_shapesig.readers``). ``load_clips`` remains only for ``operators.search.result_action``; remove it
once that reads through ``core.sources.read``."""

from .core.sources import read

__all__ = ["load_clips"]


def load_clips(spec, asf=None, fps=None):
    """``core.sources.read(spec, asf=asf, fps=fps)``."""
    return read(spec, asf=asf, fps=fps)
