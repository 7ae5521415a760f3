"""core.progress: the one progress contract ``progress(done, total) -> True to cancel`` at every place that takes
it — the index loops (a cancel keeps what was done), the distance matrices, the blends and the evaluation (a cancel
raises Cancelled) — and the one tqdm adapter of the command line and the evaluation."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig import cli
from blender_shapesig.core import search as index, pairwise, progress
from blender_shapesig.core.blend import blend_clip_series, make_blends
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.elastic.elastic import elastic_distance_matrix
from blender_shapesig.core.errors import Cancelled, ShapeSigError
from blender_shapesig.core.search.local.rank import local_entries
from blender_shapesig.core.search.moments.windows import rank_windows
from blender_shapesig.core.io.sources import read_one
from blender_shapesig.evaluation import run as evaluation_run
from blender_shapesig.evaluation.index import IndexEntry

ACCLAIM = [("07_01", "07-walk"), ("07_02", "07-walk"), ("09_02", "09-run"), ("09_03", "09-run"), ("16_15", "16")]


class Recorder:
    """A progress callback that records its calls and cancels once ``done`` reaches ``cancel_at``."""

    def __init__(self, cancel_at=None):
        self.calls, self.cancel_at = [], cancel_at

    def __call__(self, done, total):
        self.calls.append((done, total))
        return self.cancel_at is not None and done >= self.cancel_at

    def holds(self, total, finished=True):
        """The contract: ``done`` never decreases and stays in 0..total, ``total`` is the same in every call;
        a finished run ends at total, a cancelled one with the first call that asked to stop."""
        assert self.calls, "progress was never called"
        done = [d for d, _ in self.calls]
        assert {t for _, t in self.calls} == {total}
        assert done == sorted(done) and 0 <= done[0] and done[-1] <= total
        if finished:
            assert done[-1] == total
        else:
            assert done[-1] >= self.cancel_at and all(d < self.cancel_at for d in done[:-1])
        return done


def _curves(n=5, frames=18, joints=2, seed=3):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        steps = Rotation.from_rotvec(rng.normal(scale=0.2, size=(frames * joints, 3))).as_matrix()
        R = np.empty((frames, joints, 3, 3))
        R[0] = np.eye(3)
        steps = steps.reshape(frames, joints, 3, 3)
        for k in range(1, frames):
            R[k] = steps[k] @ R[k - 1]
        out.append(R)
    return out


@pytest.fixture(scope="module")
def clips(data_dir):
    """Five real CMU clips through the clip front door (bone map auto), the first 150 frames of each."""
    d = data_dir / "acclaim"
    return [read_one(str(d / f"{amc}.amc"), asf=str(d / f"{asf}.asf"), end=150, trim="none") for amc, asf in ACCLAIM]


# --------------------------------------------------------------------------------------- the helpers

def test_only_true_cancels():
    assert progress.wants_cancel(None, 0, 3) is False
    assert progress.wants_cancel(lambda d, t: None, 0, 3) is False
    assert progress.wants_cancel(lambda d, t: False, 0, 3) is False
    assert progress.wants_cancel(lambda d, t: True, 0, 3) is True
    with pytest.raises(Cancelled, match="^cancelled$"):
        progress.check(lambda d, t: True, 1, 3)
    assert issubclass(Cancelled, ShapeSigError)  # one line for a user, like every other error


def test_counter_reports_the_running_count():
    rec = Recorder(cancel_at=5)
    count = progress.Counter(rec, 9)
    count.add(2)
    count.add(0)
    count.add(2)
    with pytest.raises(Cancelled):
        count.add(3)
    assert rec.calls == [(2, 9), (2, 9), (4, 9), (7, 9)]


def test_bar_draws_on_stderr_and_never_cancels(capsys, monkeypatch):
    with progress.Bar("fast") as bar:  # work done within DELAY (a warm query): no bar
        assert [bar(k, 4) for k in range(5)] == [None] * 5
    assert capsys.readouterr().err == ""
    with progress.Bar("opened", total=4) as bar:  # a total given: drawn at once
        bar(1, 4)
    assert "opened" in capsys.readouterr().err
    monkeypatch.setattr(progress.Bar, "DELAY", 0.0)  # work that goes on: drawn
    with progress.Bar("loading") as bar:
        assert [bar(k, 4) for k in range(5)] == [None] * 5
    assert "loading" in capsys.readouterr().err
    with progress.Bar("quiet", enabled=False) as bar:
        assert bar(1, 4) is None
    with progress.Bar("one") as bar:  # fewer than two units: no bar
        bar(1, 1)
    assert capsys.readouterr().err == ""


# ------------------------------------------------------------------------------------------ matrices

MATRIX_CASES = [("l2", 1), ("elastic", 1), ("elastic", 2), ("sim3", 1), ("linear2", 1), ("group2", 1),
                ("concat2", 2)]


@pytest.mark.parametrize("metric,workers", MATRIX_CASES)
def test_distance_matrix_counts_pairs_and_cancels(metric, workers):
    curves = _curves()
    plain = pairwise.distance_matrix(curves, metric, depth=4, workers=workers)
    rec = Recorder()
    D = pairwise.distance_matrix(curves, metric, depth=4, workers=workers, progress=rec)
    np.testing.assert_array_equal(D, plain)  # reporting changes nothing
    rec.holds(10)
    rec = Recorder(cancel_at=3)
    with pytest.raises(Cancelled):
        pairwise.distance_matrix(curves, metric, depth=4, workers=workers, progress=rec)
    rec.holds(10, finished=False)


@pytest.mark.parametrize("metric", ["sim2", "l2"])
def test_cross_matrix_counts_pairs_and_cancels(metric):
    a, b = _curves(2, seed=1), _curves(3, seed=2)
    rec = Recorder()
    D = pairwise.cross_distance_matrix(a, b, metric, progress=rec)
    assert rec.holds(6) == [3, 6] and D.shape == (2, 3)
    rec = Recorder(cancel_at=1)
    with pytest.raises(Cancelled):
        pairwise.cross_distance_matrix(a, b, metric, progress=rec)
    assert rec.calls == [(3, 6)]


@pytest.mark.parametrize("workers", [1, 2])
def test_elastic_matrix_counts_pairs_and_cancels(workers):
    curves = _curves(4)
    rec = Recorder()
    elastic_distance_matrix(curves, depth=4, workers=workers, progress=rec)
    assert rec.holds(6) == [1, 2, 3, 4, 5, 6]
    rec = Recorder(cancel_at=2)
    with pytest.raises(Cancelled):
        elastic_distance_matrix(curves, depth=4, workers=workers, progress=rec)
    assert rec.holds(6, finished=False) == [1, 2]


def test_evaluation_counts_each_matrix_and_cancels(tmp_path):
    names = [f"c{k}" for k in range(5)]
    clips = {n: Clip(name=n, bones=("a", "b"), rotations=R) for n, R in zip(names, _curves(5, frames=30))}
    entries = [IndexEntry(file=f"{n}.amc", label="x" if k < 3 else "y") for k, n in enumerate(names)]
    rec = Recorder()
    evaluation_run.evaluate(entries, lambda e: clips[e.file[:-4]], ("l2", "sim2"), tmp_path / "a", workers=1,
                            figures=False, progress=rec)
    done = rec.holds(20)  # both matrices' pairs, one after the other
    assert done[:10] == list(range(1, 11)) and done[-1] == 20
    rec = Recorder(cancel_at=4)
    with pytest.raises(Cancelled):
        evaluation_run.evaluate(entries, lambda e: clips[e.file[:-4]], ("l2",), tmp_path / "b", workers=1,
                                figures=False, progress=rec)
    rec.holds(10, finished=False)


# --------------------------------------------------------------------------- index: a cancel keeps what was done

def test_index_loop_reports_items_and_keeps_what_was_done(clips):
    items = index.clip_items(clips)
    rec = Recorder()
    got = list(index.iter_entries(items, store=index.SignatureCache(), progress=rec))
    assert rec.holds(5) == [0, 1, 2, 3, 4, 5] and len(got) == 5
    store = index.SignatureCache()
    rec = Recorder(cancel_at=2)
    got = index.compute_entries(items, cache=store, progress=rec)
    assert rec.holds(5, finished=False) == [0, 1, 2]
    assert [item.key for item, _ in got] == [it.key for it in items[:2]]
    assert store.stats["misses"] == 2  # the two done are stored, the rest was never read


def test_local_entries_report_items_and_keep_what_was_done(clips):
    items = index.clip_items(clips)
    rec = Recorder()
    assert len(local_entries(items, index.SignatureCache(), rec)) == 5
    rec.holds(5)
    rec = Recorder(cancel_at=3)
    got = local_entries(items, index.SignatureCache(), rec)
    assert rec.holds(5, finished=False) == [0, 1, 2, 3]
    assert [item.key for item, _ in got] == [it.key for it in items[:3]]


@pytest.mark.parametrize("metric", ["local", "sim"])
def test_rank_reports_items_and_a_cancel_ranks_what_was_read(clips, metric):
    query, library = clips[0], clips[1:]
    rec = Recorder()
    full = index.rank_clips(query, library, metric=metric, progress=rec)
    rec.holds(4)
    assert len(full) == 4
    rec = Recorder(cancel_at=2)
    part = index.rank_clips(query, library, metric=metric, progress=rec)
    rec.holds(4, finished=False)
    two = index.rank_clips(query, library[:2], metric=metric)  # the ranking of the items read before the cancel
    assert [(r.name, r.distance) for r in part] == [(r.name, r.distance) for r in two]


def test_moments_report_items_and_a_cancel_ranks_what_was_read(clips):
    query = clips[0].crop(clips[0].frame_start, clips[0].frame_start + 59)
    rec = Recorder()
    full = rank_windows(query, clips[1:4], rerank=0, progress=rec)
    rec.holds(3)
    rec = Recorder(cancel_at=1)
    part = rank_windows(query, clips[1:4], rerank=0, progress=rec)
    assert rec.holds(3, finished=False) == [0, 1]
    assert [r.name for r in part] == [clips[1].name]
    assert part[0].distance == pytest.approx(next(r.distance for r in full if r.name == clips[1].name))


# ------------------------------------------------------------------------------------------------ blends

def test_blend_series_reports_blends_and_cancels(clips):
    a, b = clips[0], clips[2]
    rec = Recorder()
    out = blend_clip_series(a, b, [0.25, 0.5, 0.75], depth=4, frames=40, progress=rec)
    assert rec.holds(3) == [1, 2, 3] and len(out) == 3
    rec = Recorder(cancel_at=2)
    with pytest.raises(Cancelled):
        blend_clip_series(a, b, [0.25, 0.5, 0.75], depth=4, frames=40, progress=rec)
    assert rec.holds(3, finished=False) == [1, 2]


@pytest.mark.parametrize("n", [2, 3])
def test_make_blends_reports_blends_and_cancels(clips, n):
    src = [clips[0], clips[1], clips[2]][:n]
    weights = [tuple([1.0 / n] * n), tuple([0.5, 0.5] + [0.0] * (n - 2))]
    rec = Recorder()
    blends, _ = make_blends(src, weights, feet="none", depth=4, frames=40, progress=rec)
    assert rec.holds(2) == [1, 2] and len(blends) == 2
    rec = Recorder(cancel_at=1)
    with pytest.raises(Cancelled):
        make_blends(src, weights, feet="none", depth=4, frames=40, progress=rec)
    assert rec.calls == [(1, 2)]


# ------------------------------------------------------------------------------------- the command line

def test_command_line_draws_its_bars_through_the_adapter(data_dir, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(progress.Bar, "DELAY", 0.0)  # these small inputs finish within the bar's delay
    bvh = [str(data_dir / "bvh" / f"{n}.bvh") for n in ("07_01", "07_02", "09_02")]
    code = cli.main(["matrix", *bvh, "--metric", "sim2", "--out", str(tmp_path), "--no-figures", "--workers", "1",
                     "--end", "60"])
    err = capsys.readouterr().err
    assert code == 0 and "loading" in err and "matrix" in err
    code = cli.main(["matrix", *bvh, "--metric", "sim2", "--out", str(tmp_path), "--no-figures", "--workers", "1",
                     "--end", "60", "--no-progress", "--overwrite"])  # the same --out again: its files are replaced
    assert code == 0 and "loading" not in capsys.readouterr().err
