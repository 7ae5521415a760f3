"""The evaluation harness (``blender_shapesig.evaluation``) and the matrices of ``core.pairwise`` against
hand-computed truth: 1-NN, two-stage 1-NN, confusion tables, MDS,
index parsing, metric names, and matrices that agree with the pairwise distance functions."""

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig import evaluation as ev
from blender_shapesig.core.geometry import curves
from blender_shapesig.core import metrics, pairwise
from blender_shapesig.core.signatures import signatures, tensor
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.clip.prepare import prepare_clip


def _points_matrix(P):
    P = np.asarray(P, dtype=float)
    return np.linalg.norm(P[:, None] - P[None], axis=-1)


def _random_curve(rng, frames, joints=3, scale=0.15):
    v = np.cumsum(rng.normal(scale=scale, size=(frames, joints, 3)), axis=0)
    return Rotation.from_rotvec(v.reshape(-1, 3)).as_matrix().reshape(frames, joints, 3, 3)


# --- metric names -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, canon",
    [
        ("l2", "l2"), ("ELASTIC", "elastic"), ("sim", "sim3"), ("sim2", "sim2"), ("group3", "group3"),
        ("sim3_tensor", "sim3_tensor"), ("sim3_tensor_levelnorm", "sim3_levelnorm_tensor"),
        ("elastic_numpy", "elastic_numpy"), ("sim3+elastic5", "sim3+elastic5"), ("l2+elastic2", "l2+elastic2"),
    ],
)
def test_metric_names(name, canon):
    assert metrics.metric_label(name) == canon


@pytest.mark.parametrize("bad", ["l3", "elastic2", "foo", "sim9", "group3_tensor", "l2_numpy", "elastic+elastic3",
                                 "sim3_levelnorm+", "concat3_levelnorm"])
def test_bad_metric_names(bad):
    with pytest.raises(ShapeSigError):
        metrics.metric_label(bad)


def test_two_stage_spec_first_stage():
    spec = metrics.parse_metric_spec("sim2_tensor+elastic4")
    assert spec.rerank == 4 and spec.first_stage.name == "sim2_tensor" and spec.first_stage.level == 2


def test_plain_metric_view_of_the_grammar():
    assert metrics.parse_metric("sim") == ("sim", metrics.DEFAULT_LEVEL)
    assert metrics.parse_metric("SIM", level=2) == ("sim", 2)
    assert metrics.parse_metric("l2", level=5) == ("l2", None)
    assert metrics.metric_label("group", 4) == "group4"
    # variants of the grammar exist for matrices only: the one-pair view refuses them instead of dropping them
    for name in ("sim3_tensor", "elastic_numpy", "sim3+elastic5", "sim2_levelnorm"):
        metrics.metric_label(name)
        with pytest.raises(ShapeSigError, match="only available for matrices"):
            metrics.parse_metric(name)


def test_spec_properties():
    spec = metrics.parse_metric_spec("sim2_tensor")
    assert spec.basis == "tensor" and not spec.plain and spec.first_stage is spec
    assert metrics.parse_metric_spec("linear").basis == "lyndon" and metrics.parse_metric_spec("linear").plain
    assert metrics.parse_metric_spec(spec) == spec


# --- 1-NN and confusion ---------------------------------------------------------------------------


def test_loo_1nn_hand_computed():
    # Points on a line: 0, 1, 5, 6, 6.5 with labels a a b b a.
    # Nearest: 0->1 (a, right), 1->0 (a, right), 5->6 (b, right), 6->6.5 (a, wrong), 6.5->6 (b, wrong).
    D = _points_matrix([[0.0], [1.0], [5.0], [6.0], [6.5]])
    acc, pred, nb = ev.loo_1nn(D, ["a", "a", "b", "b", "a"])
    assert nb == [1, 0, 3, 4, 3]
    assert pred == ["a", "a", "b", "a", "b"]
    assert acc == pytest.approx(3 / 5)


def test_mean_average_precision_hand_computed():
    # Same line as above. Query 0 (a): ranking 1(a) 2(b) 3(b) 4(a) -> AP (1/1 + 2/4)/2 = 0.75;
    # query 1: 0(a) 2 3 4(a) -> 0.75; query 2 (b): 3(b) first -> 1; query 3 (b): 4(a) 2(b) -> 1/2;
    # query 4 (a): 3(b) 2(b) 1(a) 0(a) -> (1/3 + 2/4)/2 = 5/12.
    D = _points_matrix([[0.0], [1.0], [5.0], [6.0], [6.5]])
    expect = (0.75 + 0.75 + 1.0 + 0.5 + 5 / 12) / 5
    assert ev.mean_average_precision(D, ["a", "a", "b", "b", "a"]) == pytest.approx(expect)
    assert ev.mean_average_precision(_points_matrix([[0.0], [0.1], [5.0], [5.1]]), list("aabb")) == 1.0


def test_silhouette_hand_computed():
    # Points 0, 1 (a) and 10, 11 (b): a_i = 1 for all; b = 10.5, 9.5, 9.5, 10.5.
    D = _points_matrix([[0.0], [1.0], [10.0], [11.0]])
    expect = (9.5 / 10.5 + 8.5 / 9.5) / 2
    assert ev.silhouette(D, list("aabb")) == pytest.approx(expect)
    # A singleton class scores 0 for its clip; swapping the labels gives negative widths.
    assert ev.silhouette(D, list("abab")) < 0
    # aaab: clip 0: a = (1 + 10)/2, b = 11 -> 0.5; clip 1: a = (1 + 9)/2, b = 10 -> 0.5;
    # clip 2: a = (10 + 9)/2, b = 1 -> -8.5/9.5; clip 3 alone -> 0.
    assert ev.silhouette(D, list("aaab")) == pytest.approx((0.5 + 0.5 - 8.5 / 9.5 + 0.0) / 4)


def test_loo_1nn_ties_take_lowest_index_and_ignore_nan():
    D = np.array([[0, 2, 2, np.nan], [2, 0, 1, 1], [2, 1, 0, 3], [np.nan, 1, 3, 0]], dtype=float)
    acc, pred, nb = ev.loo_1nn(D, ["x", "y", "y", "x"])
    assert nb == [1, 2, 1, 1]
    assert acc == pytest.approx(2 / 4)


def test_loo_1nn_rejects_bad_shapes():
    with pytest.raises(ShapeSigError):
        ev.loo_1nn(np.zeros((3, 3)), ["a", "b"])
    with pytest.raises(ShapeSigError):
        ev.loo_1nn(np.zeros((2, 3)), ["a", "b"])


def test_two_stage_reranks_the_shortlist():
    # First stage: clip 0's nearest is 1 (wrong class), then 2 (right class); the second-stage
    # matrix prefers 2. With k=1 the shortlist is only clip 1, with k=2 the re-rank finds clip 2.
    first = _points_matrix([[0.0], [1.0], [1.5], [10.0]])
    second = first.copy()
    second[0, 1] = second[1, 0] = 9.0
    labels = ["a", "b", "a", "b"]
    acc1, pred1, nb1, pairs1 = ev.two_stage_1nn(first, labels, 1, second)
    assert nb1[0] == 1 and pred1[0] == "b"
    acc2, pred2, nb2, pairs2 = ev.two_stage_1nn(first, labels, 2, second)
    assert nb2[0] == 2 and pred2[0] == "a"
    # Every pair evaluated once, i < j; k=2 over 4 clips needs at most 4*2 pairs.
    assert all(i < j for i, j in pairs2) and len(pairs2) <= 8
    # With k = n-1 the two-stage result is plain 1-NN on the second matrix.
    acc_full, pred_full, _, _ = ev.two_stage_1nn(first, labels, 3, second)
    assert (acc_full, pred_full) == ev.loo_1nn(second, labels)[:2]


def test_two_stage_callable_counts_calls():
    D = _points_matrix([[0.0], [1.0], [3.0], [7.0], [8.0]])
    calls = []

    def second(i, j):
        calls.append((i, j))
        return D[i, j]

    _, _, _, pairs = ev.two_stage_1nn(D, list("aabbb"), 2, second)
    assert len(calls) == len(set(calls)) == len(pairs)


def test_confusion_table_and_markdown():
    classes, table = ev.confusion_table(["w", "w", "r", "j", "r"], ["w", "r", "r", "w", "r"], ["w", "r", "j"])
    assert classes == ["w", "r", "j"]
    assert table.tolist() == [[1, 1, 0], [0, 2, 0], [1, 0, 0]]
    md = ev.format_confusion(classes, table)
    assert md.splitlines()[2] == "| w | 1 | 1 | 0 |"


# --- MDS ------------------------------------------------------------------------------------------


def test_classical_mds_recovers_planar_configuration():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(9, 2)) * [3.0, 1.0]
    D = _points_matrix(P)
    X = ev.classical_mds(D, 2)
    np.testing.assert_allclose(_points_matrix(X), D, atol=1e-9)
    assert ev.procrustes_error(X, P) < 1e-9


def test_smacof_exact_on_euclidean_and_improves_stress():
    rng = np.random.default_rng(2)
    P = rng.normal(size=(8, 2))
    X, stress = ev.smacof(_points_matrix(P), 2)
    assert stress < 1e-12
    assert ev.procrustes_error(X, P) < 1e-6
    # Non-Euclidean distances (points in 3-D): SMACOF never ends worse than its classical start.
    Q = rng.normal(size=(10, 3))
    D = _points_matrix(Q)
    X0 = ev.classical_mds(D, 2)
    X1, s1 = ev.smacof(D, 2)
    iu = np.triu_indices(10, 1)
    s0 = float(np.sum((D[iu] - _points_matrix(X0)[iu]) ** 2))
    assert s1 <= s0 + 1e-12


def test_procrustes_detects_different_shapes():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    kite = np.array([[0, 0], [2, 0], [1, 1], [0, 1]], dtype=float)
    assert ev.procrustes_error(square @ np.array([[0, -1], [1, 0]]) + 5, square) < 1e-12
    assert ev.procrustes_error(kite, square) > 0.1


def test_linkage_groups_clusters():
    D = _points_matrix([[0.0], [0.1], [0.2], [5.0], [5.1]])
    Z = ev.linkage_matrix(D)
    from scipy.cluster.hierarchy import fcluster

    assert len(set(fcluster(Z, 2, criterion="maxclust")[:3])) == 1
    assert fcluster(Z, 2, criterion="maxclust")[3] == fcluster(Z, 2, criterion="maxclust")[4]
    assert fcluster(Z, 2, criterion="maxclust")[0] != fcluster(Z, 2, criterion="maxclust")[3]


# --- index files ----------------------------------------------------------------------------------


def test_read_index_optional_columns(tmp_path):
    p = tmp_path / "i.csv"
    p.write_text("file,label,skeleton,start,end\na.bvh,walk,,2,\nb.amc,run,s.asf,,100\n")
    e = ev.read_index(p)
    assert [(x.file, x.label, x.skeleton, x.start, x.end) for x in e] == [
        ("a.bvh", "walk", "", 2, None), ("b.amc", "run", "s.asf", None, 100)]
    q = tmp_path / "j.csv"
    q.write_text("file,label\nc.amc,jump\n")
    assert ev.read_index(q)[0].start is None


@pytest.mark.parametrize("text", ["file,name\na,b\n", "file,label\n", "file,label,start\na.bvh,walk,x\n",
                                  "file,label\na.bvh,\n"])
def test_read_index_errors(tmp_path, text):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(ShapeSigError):
        ev.read_index(p)


def test_repository_labels_csv_parses(data_dir):
    entries = ev.read_index(data_dir / "labels.csv")
    assert {e.label for e in entries} == {"walk", "run", "jump"}
    assert all((data_dir / e.file).exists() for e in entries)


def test_lyndon_level_sizes_match_witt_formula():
    assert tensor.lyndon_level_sizes(2, 5) == [2, 1, 2, 3, 6]
    assert tensor.lyndon_level_sizes(3, 3) == [3, 3, 8]
    assert sum(tensor.lyndon_level_sizes(60, 3)) == signatures.log_signature_dim(60, 3)


# --- matrices agree with the pairwise functions ---------------------------------------------------


@pytest.fixture(scope="module")
def small_curves():
    rng = np.random.default_rng(5)
    return [_random_curve(rng, f) for f in (12, 15, 19, 23)]


@pytest.mark.parametrize(
    "metric, fn",
    [
        ("l2", lambda a, b: curves.l2_distance(a, b)),
        ("group2", lambda a, b: signatures.group_distance(a, b, 2)),
        ("group3", lambda a, b: signatures.group_distance(a, b, 3)),
        ("concat3", lambda a, b: signatures.concat_distance(a, b, 3)),
        ("linear3", lambda a, b: signatures.linear_distance(a, b, 3)),
        ("sim2", lambda a, b: signatures.normalized_distance(a, b, 2)),
        ("sim3", lambda a, b: signatures.normalized_distance(a, b, 3)),
        ("linear3_tensor", lambda a, b: signatures.linear_distance(a, b, 3, basis="tensor")),
        ("sim3_tensor", lambda a, b: signatures.normalized_distance(a, b, 3, basis="tensor")),
    ],
)
def test_matrix_matches_pairwise(small_curves, metric, fn):
    n = len(small_curves)
    ref = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if i != j:
                ref[i, j] = fn(small_curves[i], small_curves[j])
    # the parallel path is the same code for every feature metric: check it on three of them
    for workers in (1, 2) if metric in ("group3", "concat3", "sim3") else (1,):
        D = pairwise.distance_matrix(small_curves, metric, workers=workers)
        np.testing.assert_allclose(D, ref, rtol=1e-10, atol=1e-12, err_msg=f"workers={workers}")


def test_levelnorm_weighs_every_level_equally(small_curves):
    # Hand-made: each level block scaled to unit length, then divided by sqrt(levels).
    R = small_curves[0]
    ls = signatures.log_signature(R, 3)
    d = 3 * R.shape[1]
    sizes = tensor.lyndon_level_sizes(d, 3)
    blocks = np.split(ls, np.cumsum(sizes)[:-1])
    expect = np.concatenate([b / np.linalg.norm(b) for b in blocks]) / math.sqrt(3)
    got = pairwise.log_signature_feature(R, 3, levelnorm=True)
    np.testing.assert_allclose(got, expect, rtol=1e-12)
    assert np.linalg.norm(got) == pytest.approx(1.0)
    # Distances between unit vectors with non-zero differences lie in (0, 2].
    D = pairwise.distance_matrix(small_curves, "sim3_levelnorm", workers=1)
    assert np.all(D[~np.eye(len(small_curves), dtype=bool)] > 0)
    assert np.all(D <= 2 + 1e-12)


def test_sim_matrix_uses_the_one_zero_rule(small_curves):
    # A still curve and one whose log-signature is below signatures.ZERO_NORM have no direction: the matrix
    # gives what signatures.normalized_distance gives (1 against a moving curve, 0 between the two).
    still = np.repeat(np.eye(3)[None, None], 12, axis=0).repeat(3, axis=1)
    tiny = _random_curve(np.random.default_rng(3), 12, scale=1e-15)
    assert 0 < np.linalg.norm(signatures.log_signature(tiny, 2)) <= signatures.ZERO_NORM
    group = [still, tiny] + list(small_curves[:2])
    D = pairwise.distance_matrix(group, "sim2", workers=1)
    for i in range(len(group)):
        for j in range(len(group)):
            if i != j:
                assert D[i, j] == signatures.normalized_distance(group[i], group[j], 2)
    assert D[0, 1] == 0.0 and D[0, 2] == 1.0 and D[1, 3] == 1.0


def test_core_pairwise_needs_no_plotting():
    import subprocess
    import sys

    code = ("import sys, blender_shapesig.core.pairwise, blender_shapesig.core.metrics; "
            "assert 'matplotlib' not in sys.modules and 'blender_shapesig.evaluation' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_two_stage_metric_refused_as_matrix(small_curves):
    with pytest.raises(ShapeSigError):
        pairwise.distance_matrix(small_curves, "sim3+elastic3")


# --- the whole evaluation on synthetic labelled clips -----------------------------------------------


def test_evaluate_writes_summary(tmp_path):
    rng = np.random.default_rng(7)
    base_a = _random_curve(rng, 30, scale=0.05)
    base_b = _random_curve(rng, 30, scale=0.4)
    clips = {}
    entries = []
    for k in range(3):
        for lab, base in (("calm", base_a), ("wild", base_b)):
            noise = Rotation.from_rotvec(rng.normal(scale=0.01, size=(30 * 3, 3))).as_matrix().reshape(30, 3, 3, 3)
            name = f"{lab}{k}"
            clips[name] = Clip(name=name, bones=("a", "b", "c"), rotations=noise @ base)
            entries.append(ev.IndexEntry(file=f"{name}.amc", label=lab, start=2, end=29))
    summary = ev.evaluate(entries, lambda e: clips[e.file[:-4]], ("l2", "sim2"), tmp_path, workers=1,
                          figures=True)
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["clips"] == 6 and set(on_disk["metrics"]) == {"l2", "sim2"}
    for row in on_disk["metrics"].values():
        assert row["accuracy"] == 1.0 and row["seconds"] >= 0
        assert row["confusion"]["table"] == [[3, 0], [0, 3]]
    assert summary["metrics"]["l2"]["accuracy"] == 1.0
    assert (tmp_path / "figures" / "mds_l2.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "figures" / "dendrogram_sim2.png").exists()
    M = np.load(tmp_path / "matrices" / "l2.npy")
    # Cropped to frames 2..29 (28 frames) before the distance, then on the comparison time base (core.clip.prepare).
    crop = [clips[e.file[:-4]].crop(2, 29) for e in entries]
    assert crop[0].frames == 28
    prepared = [prepare_clip(c).rotations for c in crop]
    assert M[0, 1] == pytest.approx(curves.l2_distance(prepared[0], prepared[1]))
    S = np.load(tmp_path / "matrices" / "sim2.npy")  # the same time base, without the low-pass
    sig = [prepare_clip(c, smooth=0.0).rotations for c in crop]
    assert S[0, 1] == pytest.approx(signatures.normalized_distance(sig[0], sig[1], 2))
    raw = ev.evaluate(entries, lambda e: clips[e.file[:-4]], ("l2",), tmp_path / "raw", workers=1,
                      figures=False, time_base=False)
    assert raw["time_base"] is None
    M = np.load(tmp_path / "raw" / "matrices" / "l2.npy")
    assert M[0, 1] == pytest.approx(curves.l2_distance(crop[0].rotations, crop[1].rotations))
