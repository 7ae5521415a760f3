"""Local-search entries made by hand for tests of one stage: ``entry(windows=..., sequence=...)`` fills what the
stage does not read with one-row placeholders."""

import numpy as np

from blender_shapesig.core.search.local.entry import LocalEntry

__all__ = ["entry"]


def entry(windows=None, sequence=None, path=None, **fields) -> LocalEntry:
    return LocalEntry(np.zeros((1, 1), np.float16) if windows is None else windows,
                      np.zeros((1, 1), np.float16) if sequence is None else sequence,
                      np.zeros(10, np.float32) if path is None else path, **fields)
