"""The local search as the default ranking (``rank_clips``, the ``rank`` and ``distance`` commands): its order and
scores against ``core.search.local.features`` called directly, its entries in the signature cache (a second process reads
them, nothing is computed again), clips it cannot read (ranked after the others by sim3 with one warning; such a
query refused in one line), and the signature search still selectable by name."""

import dataclasses
import json
import os

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core import search as index, rigs
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.search.local import description, features as ls
from blender_shapesig.core.io import sources
from blender_shapesig.core.metrics import DEFAULT_METRIC, clip_distance, parse_metric


def _read(path, asf=None, bone_map="auto"):
    return sources.read_one(sources.ClipSpec(str(path), asf=None if asf is None else str(asf), bone_map=bone_map))


@pytest.fixture(scope="module")
def clips(data_dir):
    a = data_dir / "acclaim"
    return {
        "07_01": _read(a / "07_01.amc", a / "07-walk.asf"), "07_02": _read(a / "07_02.amc", a / "07-walk.asf"),
        "09_02": _read(a / "09_02.amc", a / "09-run.asf"), "09_03": _read(a / "09_03.amc", a / "09-run.asf"),
        "16_15": _read(a / "16_15.bvh"), "13_32": _read(data_dir / "bvh" / "13_32.bvh"),
        "08_01": _read(data_dir / "bvh" / "08_01.bvh"),
    }


def _described(qe, cands):
    """What happens in the clips (``description``), written out: the root mean square of the differences of the
    body's parts, plus for a striking query the arms' (strike, guard), gated by its strike."""
    q, D = qe.describe.astype(float), np.array([c.describe for c in cands], float)
    b, k = description.BODY, description.PARTS.index("strike")
    body = np.sqrt(np.mean((D[:, :b] - q[:b]) ** 2, axis=1))
    arms = np.sqrt(np.mean((D[:, b:] - q[b:]) ** 2, axis=1)) * min(1.0, max(q[k], 0.0) / description.STRIKE_GATE)
    return description.WEIGHT * body + description.ARM_WEIGHT * arms


def test_local_is_the_default_metric():
    assert DEFAULT_METRIC == "local" and parse_metric("local") == ("local", None)
    with pytest.raises(ShapeSigError, match="first stage cannot be local"):
        parse_metric("local+elastic5")


def test_rank_orders_and_scores_as_the_local_search(clips):
    q = clips["07_01"]
    lib = [c for n, c in clips.items() if n != "07_01"]
    got = index.rank_clips(q, lib, rerank=3)  # the default metric; a shortlist of 3
    # the truth, from core.search.local.features directly
    qe = ls.index_entry(q)
    entries = [ls.index_entry(c) for c in lib]
    order = ls.search(qe, entries, shortlist=3)
    assert [r.name for r in got] == [lib[i].name for i in order]
    d1 = ls.first_stage(qe, entries)
    head = list(np.argsort(d1, kind="stable")[:3])
    score = ls.combine(d1[head], ls.rerank(qe, [entries[i] for i in head]))
    score = score + _described(qe, [entries[i] for i in head])
    want = dict(zip((lib[i].name for i in head), score))
    rows = {r.name: r for r in got}
    for name, s in want.items():
        assert rows[name].distance == pytest.approx(s, rel=1e-5) and rows[name].dtw is not None
    tail = [r for r in got if r.name not in want]
    assert all(r.dtw is None and r.distance >= max(want.values()) for r in tail)
    assert [r.distance for r in got] == sorted(r.distance for r in got)
    # float32 window distances, summed in another order over the stacked library: equal to float32's precision
    assert all(r.first_stage == pytest.approx(d1[[c.name for c in lib].index(r.name)], rel=1e-5) for r in got)
    assert got[0].name == "07_02" and {r.metric for r in got} == {"local"}  # the other walk of the same subject


def test_rank_local_rows_made_when_read_equal_the_rule(clips):
    """``rank_local``'s rows after the shortlist are made when read: the same rows as the rule written out (score
    max(the shortlist's worst, (1 + mix) d1 / mean d1 of the shortlist), order by the first stage), by index, by
    negative index, by slice and by iteration."""
    from blender_shapesig.core.search.local.rank import rank_local

    qe = ls.index_entry(clips["07_01"])
    entries = [ls.index_entry(c) for n, c in clips.items() if n != "07_01"]
    rows = rank_local(qe, [(None, e) for e in entries], index.SignatureCache(), shortlist=2)
    d1 = ls.first_stage(qe, entries)
    order = np.argsort(d1, kind="stable")
    head = order[:2]
    score = ls.combine(d1[head], ls.rerank(qe, [entries[i] for i in head]))
    score = score + _described(qe, [entries[i] for i in head])
    want = [(int(head[k]), score[k], d1[head[k]]) for k in np.argsort(score, kind="stable")]
    want += [(int(i), max(score.max(), 2.0 * d1[i] / d1[head].mean()), d1[i]) for i in order[2:]]
    assert len(rows) == len(entries) == len(want)
    got = list(rows)
    assert [r[0] for r in got] == [w[0] for w in want]
    assert np.allclose([r[1] for r in got], [w[1] for w in want], rtol=1e-12)
    assert np.allclose([r[2] for r in got], [w[2] for w in want], rtol=1e-12)
    assert [r[3] is None for r in got] == [False, False] + [True] * (len(want) - 2)
    assert rows[-1] == got[-1] and rows[1:4] == got[1:4]
    with pytest.raises(IndexError):
        rows[len(want)]


def test_local_entries_live_in_the_signature_cache(clips, tmp_path):
    q, lib = clips["09_02"], [clips[n] for n in ("09_03", "07_01", "13_32")]
    first = index.rank_clips(q, lib, cache=index.SignatureCache(tmp_path))
    assert first.stats["misses"] == 4 and first.stats["writes"] == 4
    again = index.rank_clips(q, lib, cache=index.SignatureCache(tmp_path))  # a new process, the same folder
    assert again.stats["misses"] == 0 and again.stats["disk_hits"] == 4
    assert [(r.name, r.distance) for r in again] == [(r.name, r.distance) for r in first]
    own = os.listdir(tmp_path / index.CACHE_SUBDIR)
    assert sum(n.endswith(".npz") and len(n) == 44 for n in own) == 4 and "local_pack.bin" in own
    # the pack answers a new process; a damaged pack is ignored (the files answer), a damaged file is rebuilt
    folder = tmp_path / index.CACHE_SUBDIR
    (folder / "local_pack.bin").write_bytes(b"garbage")
    third = index.rank_clips(q, lib, cache=index.SignatureCache(tmp_path))
    assert third.stats["misses"] == 0 and [(r.name, r.distance) for r in third] == [(r.name, r.distance) for r in first]
    cache = index.SignatureCache(tmp_path)
    victim = cache.local.file_for(sources.clip_item(lib[0]).key, ls.settings_key())
    with open(victim, "wb") as fh:
        fh.write(b"not a zip")
    fourth = index.rank_clips(q, lib, cache=cache)
    assert fourth.stats["invalid"] == 1 and fourth.stats["misses"] == 1
    assert [(r.name, r.distance) for r in fourth] == [(r.name, r.distance) for r in first]
    # another setting is another entry; clearing deletes only the cache's own files
    (tmp_path / index.CACHE_SUBDIR / "notes.txt").write_text("mine")
    index.SignatureCache(tmp_path).clear()
    assert sorted(os.listdir(folder)) == ["CACHEDIR.TAG", "manifest.json", "notes.txt"]


def test_unreadable_library_clips_come_last_by_sim3_and_a_query_is_refused(clips):
    walk = clips["07_02"]
    bm = walk.meta["bone_map"]  # a rig whose rest skeleton lacks the legs: no body for the local search
    heads = {b: h for b, h in walk.meta["rest_heads"].items() if b not in (bm["thigh.L"], bm["thigh.R"])}
    walk = walk.crop(walk.frame_start + 1, None)  # other data, another key (a clip's key is its rotations)
    legless = dataclasses.replace(walk, name="legless", meta=dict(walk.meta, rest_heads=heads))
    got = index.rank_clips(clips["07_01"], [legless, clips["09_02"], clips["07_02"], clips["13_32"]])
    assert [r.name for r in got][-1] == "legless" and got[-1].metric == "sim3"
    assert [r.metric for r in got[:-1]] == ["local"] * 3
    assert got[-1].distance == pytest.approx(clip_distance(clips["07_01"], legless, "sim3"), rel=1e-5)
    # in an animator's words (core.measure_words): no metric name in the warning or the refusal
    assert len(got.warnings) == 1 and "legless" in got.warnings[0] and "by motion only" in got.warnings[0]
    assert "sim3" not in got.warnings[0]
    with pytest.raises(ShapeSigError, match="local search cannot read the query .* Similarity: Motion only") as info:
        index.rank_clips(legless, [clips["09_02"]])
    assert "\n" not in str(info.value) and "sim3" not in str(info.value)


def test_a_pair_compares_by_the_first_stage(clips):
    a, b = clips["07_01"], clips["09_02"]
    d = clip_distance(a, b, "local")
    assert d == pytest.approx(ls.first_stage(ls.index_entry(a), [ls.index_entry(b)])[0], rel=1e-12) and d > 0
    assert clip_distance(a, a, "local") < 0.01 * d


def _cli(capsys, args):
    code = cli.main(args + ["--json", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def test_cli_rank_defaults_to_local_and_keeps_sim3(capsys, data_dir, tmp_path):
    a = data_dir / "acclaim"
    asf = ["--asf", str(a / "07-walk.asf")]
    files = [str(a / n) for n in ("07_01.amc", "07_02.amc")]
    runs = [str(data_dir / "bvh" / n) for n in ("09_02.bvh", "13_32.bvh")]
    cache = ["--cache", str(tmp_path)]
    out = _cli(capsys, ["rank", files[0], files[1], *runs, *cache, *asf])
    assert out["metric"] == "local" and out["results"][0]["clip"] == "07_02"
    row = out["results"][0]
    assert {"clip", "distance", "elastic", "path", "action", "metric", "first_stage", "dtw"} <= set(row)
    walk = lambda f: _read(f, a / "07-walk.asf")  # noqa: E731
    truth = index.rank_clips(walk(files[0]), [walk(files[1])] + [_read(f) for f in runs])
    assert [r["clip"] for r in out["results"]] == [r.name for r in truth]
    assert [r["distance"] for r in out["results"]] == pytest.approx([r.distance for r in truth], rel=1e-6)
    sim = _cli(capsys, ["rank", files[0], files[1], *runs, *cache, "--metric", "sim3", *asf])
    assert sim["metric"] == "sim3" and "metric" not in sim["results"][0]
    truth = index.rank_clips(walk(files[0]), [walk(files[1])] + [_read(f) for f in runs], metric="sim")
    assert [r["distance"] for r in sim["results"]] == pytest.approx([r.distance for r in truth], rel=1e-6)
    pair = _cli(capsys, ["distance", files[0], runs[0], "--metric", "local", *asf])
    assert pair["metric"] == "local" and pair["distance"] == pytest.approx(
        clip_distance(walk(files[0]), _read(runs[0]), "local"), rel=1e-9)


def test_rank_help_names_the_default(capsys):
    assert cli.main(["rank", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "The default search, --metric local, is Motion and pose" in text and "--metric sim3" in text


def test_nearest_is_the_head_of_a_stable_sort():
    """``nearest(d, n)`` gives the first ``n`` of ``np.argsort(d, kind="stable")``: with ties at the cut (the lower
    index first), with infinities, with NaNs among the first n, and n at or beyond the length."""
    rng = np.random.default_rng(7)
    for trial in range(200):
        d = rng.integers(0, 6, int(rng.integers(1, 40))).astype(float)  # many ties
        if trial % 3 == 1:
            d[rng.integers(0, len(d), 3)] = np.inf
        if trial % 5 == 2:
            d[rng.integers(0, len(d), 2)] = np.nan
        for n in (1, 2, 5, len(d), len(d) + 3):
            assert ls.nearest(d, n).tolist() == np.argsort(d, kind="stable")[:n].tolist(), (d, n)
