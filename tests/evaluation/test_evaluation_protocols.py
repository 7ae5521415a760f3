"""``evaluate``'s protocols against brute-force truth: mAP for every metric (two-stage ones too), leave-one-group-out
(``--group COLUMN``), the local search as a metric and crop probes (a clip cut by 10 % at either end must find its
source first), through the library and the command line."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blender_shapesig import cli
from blender_shapesig import evaluation as ev
from blender_shapesig.core import rigs
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.search.local import features as ls
from blender_shapesig.core.io import sources
from blender_shapesig.evaluation import retrieval


def _average_precision(order, labels, q):
    hits, total = 0, []
    for rank, j in enumerate(order, start=1):
        if labels[j] == labels[q]:
            hits += 1
            total.append(hits / rank)
    return sum(total) / len(total) if total else None


def _brute(D, labels, groups=None, second=None, k=0):
    """1-NN accuracy and mAP by plain loops: candidates of other groups, sorted by (D, index), the first k by
    (second, position)."""
    n = len(labels)
    hits, aps = [], []
    for q in range(n):
        cand = [j for j in range(n) if j != q and (groups is None or groups[j] != groups[q])]
        order = sorted(cand, key=lambda j: (D[q][j], j))
        if k:
            head = sorted(enumerate(order[:k]), key=lambda t: (second[q][t[1]], t[0]))
            order = [j for _, j in head] + order[k:]
        hits.append(labels[order[0]] == labels[q])
        ap = _average_precision(order, labels, q)
        if ap is not None:
            aps.append(ap)
    return np.mean(hits), np.mean(aps)


def test_ranking_scores_hand_computed():
    labels = ["a", "a", "b", "b"]
    orders = [np.array([2, 1, 3]), np.array([0, 2, 3]), np.array([3, 0, 1]), np.array([0, 1, 2])]
    acc, pred, nearest, mAP = retrieval.ranking_scores(orders, labels)
    assert acc == 0.5 and pred == ["b", "a", "b", "a"] and nearest == [2, 0, 3, 0]
    assert mAP == pytest.approx((0.5 + 1.0 + 1.0 + 1 / 3) / 4)
    assert [list(c) for c in retrieval.candidates(4, ["x", "y", "x", "y"])] == [[1, 3], [0, 2], [1, 3], [0, 2]]
    with pytest.raises(ShapeSigError, match="alone in its group"):
        retrieval.ranking_scores([np.array([], int)] * 2, ["a", "a"])


def test_group_protocol_and_two_stage_map_match_brute_force(tmp_path):
    rng = np.random.default_rng(11)
    bases = {lab: Rotation.from_rotvec(np.cumsum(rng.normal(scale=s, size=(30 * 3, 3)), axis=0)).as_matrix()
             .reshape(30, 3, 3, 3) for lab, s in (("calm", 0.05), ("wild", 0.3))}
    clips, entries, groups = {}, [], []
    for k in range(4):
        for lab, base in bases.items():
            noise = Rotation.from_rotvec(rng.normal(scale=0.05, size=(90, 3))).as_matrix().reshape(30, 3, 3, 3)
            name = f"{lab}{k}"
            clips[name] = Clip(name=name, bones=("a", "b", "c"), rotations=noise @ base)
            entries.append(ev.IndexEntry(file=f"{name}.amc", label=lab))
            groups.append("g0" if k < 2 else "g1")
    labels = [e.label for e in entries]
    s = ev.evaluate(entries, lambda e: clips[e.file[:-4]], ("l2", "sim2", "elastic", "sim2+elastic2"), tmp_path,
                    workers=1, figures=False, groups=groups)
    assert s["protocol"] == "leave-one-group-out"
    M = {m: np.load(tmp_path / "matrices" / f"{m}.npy") for m in ("l2", "sim2", "elastic")}
    for m in M:
        acc, mAP = _brute(M[m], labels, groups)
        assert s["metrics"][m]["accuracy"] == pytest.approx(acc) and s["metrics"][m]["map"] == pytest.approx(mAP)
    acc, mAP = _brute(M["sim2"], labels, groups, M["elastic"], 2)
    row = s["metrics"]["sim2+elastic2"]
    assert row["accuracy"] == pytest.approx(acc) and row["map"] == pytest.approx(mAP)
    loo = ev.evaluate(entries, lambda e: clips[e.file[:-4]], ("sim2",), tmp_path / "loo", workers=1, figures=False)
    assert loo["metrics"]["sim2"]["map"] == pytest.approx(_brute(M["sim2"], labels)[1])
    assert loo["metrics"]["sim2"]["map"] == pytest.approx(ev.mean_average_precision(M["sim2"], labels))


def _mapped(data_dir, row, cut=None):
    spec = ev.entry_spec(row, str(data_dir), bone_map="none")
    clip = sources.read_one(spec)
    if cut:
        clip = ev.cut_clip(clip, cut, 0.1)
    return rigs.apply_bone_map(clip, "auto")


def test_cli_evaluates_local_by_group_with_crop_probes(capsys, data_dir, tmp_path):
    rows = [r for r in ev.read_index(str(data_dir / "labels.csv")) if r.label in ("walk", "run")]
    index = tmp_path / "set.csv"
    index.write_text("file,label,skeleton,format\n" + "".join(
        f"{r.file},{r.label},{r.skeleton},{r.file.split('/')[0]}\n" for r in rows))
    out = tmp_path / "out"
    code = cli.main(["evaluate", "--index", str(index), "--data", str(data_dir), "--out", str(out), "--metrics",
                     "local,sim3", "--group", "format", "--crops", "--no-figures", "--no-progress", "--json"])
    got = json.loads(capsys.readouterr().out)
    assert code == 0 and got["group"] == "format" and got["protocol"] == "leave-one-group-out"
    summary = json.loads((out / "summary.json").read_text())
    assert {"local", "sim3"} <= set(summary["metrics"]) and all("map" in r for r in summary["metrics"].values())
    # the truth: core.search.local.features on the clips, each query ranked among the other format's clips
    labels, fmt = [r.label for r in rows], [r.file.split("/")[0] for r in rows]
    entries = [ls.index_entry(_mapped(data_dir, r)) for r in rows]
    hits, aps = [], []
    for q in range(len(rows)):
        cand = [j for j in range(len(rows)) if fmt[j] != fmt[q]]
        order = [cand[i] for i in ls.search(entries[q], [entries[j] for j in cand])]
        hits.append(labels[order[0]] == labels[q])
        aps.append(_average_precision(order, labels, q))
    row = summary["metrics"]["local"]
    assert row["accuracy"] == pytest.approx(np.mean(hits)) and row["map"] == pytest.approx(np.mean(aps))
    for side in ("start", "end"):
        found = sum(ls.search(ls.index_entry(_mapped(data_dir, r, side)), entries)[0] == i for i, r in enumerate(rows))
        assert row["crops"][side] == found and row["crops"]["of"] == len(rows)
    assert row["crops"]["start"] + row["crops"]["end"] >= 2 * len(rows) - 2  # the local search finds its sources
    assert 0 <= summary["metrics"]["sim3"]["crops"]["start"] <= len(rows)
    with pytest.raises(ShapeSigError, match="no column 'actor'"):
        ev.read_index(str(index))[0].column("actor")
