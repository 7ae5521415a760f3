"""core.blas: one OpenBLAS thread for a block of work (index entries, ranking), the count before restored."""

import numpy as np
import pytest

from blender_shapesig.core import blas
from blender_shapesig.core import search as search
from blender_shapesig.core.io import sources
from blender_shapesig.core.search.signature import index as signature_index
from blender_shapesig.core.io.acclaim import load_acclaim

needs_openblas = pytest.mark.skipif(blas.blas_threads() is None, reason="numpy's OpenBLAS not found")


@pytest.fixture
def two_threads():
    """OpenBLAS at two threads for the test (also on a one-core machine), the count before restored after."""
    setter = blas._api()[0]
    before = blas.blas_threads()
    setter(2)
    yield
    setter(before)


@needs_openblas
def test_one_thread_inside_restored_after_also_on_error_and_nested(two_threads):
    assert blas.blas_threads() == 2
    with blas.one_blas_thread():
        assert blas.blas_threads() == 1
        with blas.one_blas_thread():
            assert blas.blas_threads() == 1
        assert blas.blas_threads() == 1
    assert blas.blas_threads() == 2
    with pytest.raises(ZeroDivisionError):
        with blas.one_blas_thread():
            1 / 0
    assert blas.blas_threads() == 2
    a = np.random.default_rng(3).normal(size=(300, 60))
    with blas.one_blas_thread():
        inside = a.T @ a
    np.testing.assert_allclose(inside, a.T @ a, rtol=1e-12, atol=1e-12)


@needs_openblas
def test_index_entries_and_ranking_run_on_one_thread(two_threads, data_dir, monkeypatch):
    seen = []
    make_entry = signature_index.make_entry

    def spy(*args, **kwargs):
        seen.append(blas.blas_threads())
        return make_entry(*args, **kwargs)

    monkeypatch.setattr(signature_index, "make_entry", spy)
    d = data_dir / "acclaim"
    a = load_acclaim(str(d / "07_01.amc"), str(d / "07-walk.asf"))
    b = load_acclaim(str(d / "07_02.amc"), str(d / "07-walk.asf"))
    res = search.rank_clips(sources.clip_item(a), [sources.clip_item(b)], cache=search.SignatureCache(), metric="sim")
    assert len(res) == 1 and seen == [1, 1]
    assert blas.blas_threads() == 2


def test_without_openblas_nothing_changes(monkeypatch):
    monkeypatch.setattr(blas, "_API", [None])
    assert blas.blas_threads() is None
    with blas.one_blas_thread():
        assert blas.blas_threads() is None
