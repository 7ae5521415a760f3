"""One BLAS thread for a block of work (``one_blas_thread``), also where numpy was imported before us (Blender):
small matrix products of the index run faster without OpenBLAS's own threads. The count is lowered through
OpenBLAS's ``openblas_set_num_threads`` and restored; with another BLAS nothing happens. See docs/search.md,
"At library scale".
"""

import contextlib
import ctypes
import glob
import os

__all__ = ["one_blas_thread", "blas_threads"]

# (set, get) symbol pairs of numpy's OpenBLAS builds: scipy-openblas (numpy >= 2), openblas64_ (numpy 1.26), plain.
_SYMBOLS = (
    ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
    ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
    ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
    ("openblas_set_num_threads", "openblas_get_num_threads"),
)
_API = []  # [None] or [(set, get)] after the first look-up


def _find():
    import numpy

    base = os.path.dirname(numpy.__file__)
    paths = []
    for pattern in (os.path.join(base, os.pardir, "numpy.libs", "*openblas*"),
                    os.path.join(base, ".dylibs", "*openblas*")):
        paths.extend(sorted(glob.glob(pattern)))
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for set_name, get_name in _SYMBOLS:
            setter, getter = getattr(lib, set_name, None), getattr(lib, get_name, None)
            if setter is not None and getter is not None:
                setter.argtypes, setter.restype = [ctypes.c_int], None
                getter.argtypes, getter.restype = [], ctypes.c_int
                return setter, getter
    return None


def _api():
    if not _API:
        try:
            _API.append(_find())
        except Exception:  # noqa: BLE001 - any failure: leave BLAS as it is
            _API.append(None)
    return _API[0]


def blas_threads():
    """OpenBLAS's current thread count, or None when numpy's OpenBLAS was not found."""
    api = _api()
    return None if api is None else int(api[1]())


@contextlib.contextmanager
def one_blas_thread():
    """Run the block (or, as a decorator, the function) with one OpenBLAS thread; the count before is restored."""
    api = _api()
    before = int(api[1]()) if api is not None else 1
    if before <= 1:
        yield
        return
    api[0](1)
    try:
        yield
    finally:
        api[0](before)
