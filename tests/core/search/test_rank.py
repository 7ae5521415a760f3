"""core.search: the index entries, the cache and rank_clips, against independent truth
(signatures.log_signature / metrics.clip_distance on the full curves) on real CMU clips."""

import dataclasses
import json
import os
import shutil

import numpy as np
import pytest

from blender_shapesig.core import search as search
from blender_shapesig.core.signatures import signatures
from blender_shapesig.core.io import sources
from blender_shapesig.core.search.signature import words
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.metrics import clip_distance
from blender_shapesig.core.clip.prepare import decimate_clip, prepare_clip

ACCLAIM = [("07_01", "07-walk", "walk"), ("07_02", "07-walk", "walk"), ("09_02", "09-run", "run"),
           ("09_03", "09-run", "run"), ("16_15", "16", "walk")]


@pytest.fixture(scope="module")
def clips(data_dir):
    d = data_dir / "acclaim"
    out = {}
    for amc, asf, _ in ACCLAIM:
        out[amc] = load_acclaim(str(d / f"{amc}.amc"), str(d / f"{asf}.asf"))
    return out


@pytest.fixture(scope="module")
def mem():
    """One in-memory cache for the tests that are not about caching (entries are keyed by content)."""
    return search.SignatureCache()


def _modified(clip, name=None, frame=10, joint=None, angle=0.3):
    """A copy of the clip with one frame of one moving joint rotated further (an 'edited keyframe')."""
    R = clip.rotations.copy()
    j = joint if joint is not None else int(np.flatnonzero(~np.array([b in clip.still_bones() for b in clip.bones]))[0])
    c, s = np.cos(angle), np.sin(angle)
    R[frame, j] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ R[frame, j]
    return dataclasses.replace(clip, rotations=R, name=name or clip.name, meta={})  # same frame count


# ------------------------------------------------------------------------------------ word codes

def test_lyndon_letters_follow_iisignature_basis_order():
    iisignature = pytest.importorskip("iisignature")
    for dim, level in [(3, 3), (6, 3), (9, 2), (4, 4)]:
        basis = iisignature.basis(iisignature.prepare(dim, level, "S"))
        ours = words._local_letters(dim, level)
        assert len(basis) == len(ours)
        for text, row in zip(basis, ours):
            letters = [int(ch) - 1 for ch in text if ch.isdigit()]
            assert letters == [x for x in row if x >= 0]


def test_moving_joint_log_signature_is_the_full_one_restricted(clips):
    """Index entries keep only the moving joints; their coordinates are the full log-signature's
    coordinates of the same words, and every other coordinate of the full one is 0."""
    c = clips["07_01"].select(clips["07_01"].bones[:6])
    R = c.rotations.copy()
    R[:, 2] = R[0, 2]  # joint 2 still
    clip = dataclasses.replace(c, rotations=R)
    e = search.make_entry(clip, level=3)
    assert 2 not in e.moving and len(e.moving) >= 3
    # independent: all 6 joints, still one included, of the curve the index signs (the comparison time base)
    full = signatures.log_signature(prepare_clip(clip, smooth=0.0).rotations, 3)
    codes_full = search.word_codes(6, range(6), 3)
    codes_sub = search.word_codes(6, e.moving, 3)
    pos = {int(k): i for i, k in enumerate(codes_full)}
    idx = np.array([pos[int(k)] for k in codes_sub])
    np.testing.assert_allclose(e.direction * e.norm, full[idx], rtol=1e-5, atol=1e-7 * e.norm)
    rest = np.ones(full.size, bool)
    rest[idx] = False
    assert np.abs(full[rest]).max() < 1e-12 * max(1.0, e.norm)
    frames = prepare_clip(clip, smooth=0.0).frames  # 30 fps: a quarter of the 120 fps clip's
    assert e.frames == frames and frames < clip.frames
    assert e.increments.dtype == np.float32 and e.increments.shape == (frames - 1, len(e.moving), 3)


# ---------------------------------------------------------------------------------- rank_clips

def test_rank_matches_clip_distance_and_walk_beats_runs(clips, mem):
    # the index signs the curves on the comparison time base, as clip_distance prepares them; see docs/search.md
    q = clips["07_01"]
    lib = [clips[k] for k in ("09_02", "07_02", "16_15", "09_03")]
    res = search.rank_clips(q, lib, cache=mem, metric="sim")
    assert [r.name for r in res][:2] in (["07_02", "16_15"], ["16_15", "07_02"])
    assert {r.name for r in res[2:]} == {"09_02", "09_03"}
    for r in res:
        truth = clip_distance(q, clips[r.name], "sim", 3)
        assert r.distance == pytest.approx(truth, rel=1e-5, abs=1e-6)
        assert r.elastic is None and r.frames == clips[r.name].frames  # the clip as read (its own rate)
    assert [r.distance for r in res] == sorted(r.distance for r in res)


def test_level_from_metric_name_and_argument(clips, mem):
    q, other = clips["07_01"], clips["09_02"]
    d2 = search.rank_clips(q, [other], metric="sim2", cache=mem)[0].distance
    assert d2 == pytest.approx(clip_distance(q, other, "sim", 2), rel=1e-5)
    assert search.rank_clips(q, [other], level=2, cache=mem, metric="sim")[0].distance == pytest.approx(d2, rel=1e-12)
    assert abs(d2 - search.rank_clips(q, [other], cache=mem, metric="sim")[0].distance) > 1e-3


def test_different_still_joints_and_other_skeletons(clips, mem):
    q = clips["07_01"]
    frozen = clips["07_02"].rotations.copy()
    frozen[:, 5] = frozen[0, 5]  # a joint that moves in the query is still in this clip
    c1 = dataclasses.replace(clips["07_02"], name="frozen", rotations=frozen)
    c2 = clips["09_02"].select(clips["09_02"].bones[:20])  # another skeleton: a bone subset
    c2.name = "subset"
    c3 = Clip("alien", ("a", "b"), np.repeat(np.eye(3)[None, None], 5, 0).repeat(2, 1))
    res = search.rank_clips(q, [c1, c2, c3], cache=mem, metric="sim")
    got = {r.name: r for r in res}
    assert set(got) == {"frozen", "subset"}
    assert got["frozen"].distance == pytest.approx(clip_distance(q, c1, "sim", 3), rel=1e-5)
    assert got["subset"].distance == pytest.approx(clip_distance(q, c2, "sim", 3), rel=1e-5)
    assert got["subset"].shared == 20 and got["frozen"].shared == len(q.bones)
    assert res.skipped == ["alien"]
    assert any("alien" in w and "no bones" in w for w in res.warnings)
    # 20 of 31 bones, but fewer than half of the query's moving ones? count them independently
    moving = {b for b in q.bones if b not in q.still_bones()}
    few = len(moving & set(c2.bones)) < 0.5 * len(moving)
    assert any("subset" in w for w in res.warnings) == few


def test_few_shared_bones_warns(clips, mem):
    q = clips["07_01"]
    small = clips["07_02"].select(clips["07_02"].bones[:4])
    small.name = "small"
    res = search.rank_clips(q, [small], cache=mem, metric="sim")
    assert len(res) == 1 and any("small" in w and "shares only" in w for w in res.warnings)


def test_still_clip_is_at_distance_one(clips, mem):
    q = clips["07_01"]
    still = dataclasses.replace(q, name="still", rotations=np.repeat(q.rotations[:1], 10, axis=0),
                                root_translation=None, meta={})
    res = search.rank_clips(q, [still], cache=mem, metric="sim")
    assert res[0].distance == pytest.approx(1.0)


def test_rerank_orders_head_by_elastic_distance(clips):
    # clips at the comparison rate (30 fps): the entries' low-pass then equals clip_distance's exactly
    q = decimate_clip(clips["07_01"].crop(end=clips["07_01"].frame_start + 239, clamp=True), 4)
    lib = [decimate_clip(c.crop(end=c.frame_start + 239, clamp=True), 4) for k, c in clips.items() if k != "07_01"]
    plain = search.rank_clips(q, lib, metric="sim")
    res = search.rank_clips(q, lib, rerank=3, metric="sim")
    head, tail = res[:3], res[3:]
    assert {r.name for r in head} == {r.name for r in plain[:3]}
    assert [r.name for r in tail] == [r.name for r in plain[3:]]
    assert [r.elastic for r in head] == sorted(r.elastic for r in head)
    assert all(r.elastic is None for r in tail)
    by = {c.name: c for c in lib}
    for r in head:
        assert r.elastic == pytest.approx(clip_distance(q, by[r.name], "elastic"), rel=1e-4)


def test_other_metrics_are_pairwise(clips, mem):
    q = clips["07_01"]
    q, lib = decimate_clip(q, 4), [decimate_clip(clips["09_02"], 4), decimate_clip(clips["07_02"], 4)]  # 30 fps
    res = search.rank_clips(q, lib, metric="l2", cache=mem)
    by = {c.name: c for c in lib}
    for r in res:
        assert r.distance == pytest.approx(clip_distance(q, by[r.name], "l2"), rel=1e-4)


def test_top_and_sketch_pool(clips, mem):
    q = clips["07_01"]
    lib = [clips[k] for k in ("09_02", "07_02", "16_15", "09_03")]
    exact = search.rank_clips(q, lib, cache=mem, metric="sim")
    # a pool of 2 sketch candidates out of 4: the sketch must still find the true best two
    res = search.rank_clips(q, lib, top=2, pool=2, cache=mem, metric="sim")
    assert [r.name for r in res] == [r.name for r in exact[:2]]
    assert res.stats["compared"] == 2
    assert [r.distance for r in res] == [r.distance for r in exact[:2]]


def test_sketch_distance_estimates_sim(clips):
    names = list(clips)
    entries = {k: search.make_entry(clips[k]) for k in names}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            exact = search.entry_distance(entries[a], entries[b])
            approx = float(np.linalg.norm(entries[a].sketch - entries[b].sketch))
            assert approx == pytest.approx(exact, rel=0.15)


def test_exclude_and_bad_input(clips, mem):
    q = clips["07_01"]
    res = search.rank_clips(q, [q, clips["07_02"]], exclude=(q.name,), cache=mem, metric="sim")
    assert [r.name for r in res] == ["07_02"]
    with pytest.raises(ShapeSigError, match="top"):
        search.rank_clips(q, [clips["07_02"]], top=0, cache=mem, metric="sim")
    with pytest.raises(ShapeSigError, match="unknown metric"):
        search.rank_clips(q, [clips["07_02"]], metric="cosine", cache=mem)
    with pytest.raises(ShapeSigError, match="Clips or LibraryItems"):
        search.rank_clips(q, ["07_02.amc"], cache=mem, metric="sim")
    with pytest.raises(ShapeSigError, match="query"):
        search.rank_clips("07_01", [clips["07_02"]], cache=mem, metric="sim")
    assert search.rank_clips(q, [], metric="sim") == []


# ------------------------------------------------------------------------------------------ cache

def test_cache_hits_across_instances_and_invalidation_after_an_edit(clips, tmp_path):
    q = clips["07_01"]
    lib = [clips[k] for k in ("07_02", "09_02", "16_15")]
    first = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path), metric="sim")
    assert first.stats["misses"] == 4 and first.stats["hits"] == 0 and first.stats["writes"] == 4
    again = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path), metric="sim")  # a new process, same folder
    assert again.stats["misses"] == 0 and again.stats["disk_hits"] == 4
    assert [(r.name, r.distance) for r in again] == [(r.name, r.distance) for r in first]
    # edit one keyframe of one library clip: its key changes, it alone is recomputed
    edited = _modified(clips["09_02"], frame=12)  # a frame the 30 fps time base keeps (every 4th at 120 fps)
    lib2 = [lib[0], edited, lib[2]]
    third = search.rank_clips(q, lib2, cache=search.SignatureCache(tmp_path), metric="sim")
    assert third.stats["misses"] == 1 and third.stats["disk_hits"] == 3
    d = {r.name: r.distance for r in third}
    assert d["09_02"] == pytest.approx(clip_distance(q, edited, "sim", 3), rel=1e-5)
    assert d["09_02"] != pytest.approx({r.name: r.distance for r in first}["09_02"], rel=1e-6)


def test_corrupt_and_outdated_entries_are_rebuilt(clips, tmp_path):
    q, c = clips["07_01"], clips["07_02"]
    cache = search.SignatureCache(tmp_path)
    truth = search.rank_clips(q, [c], cache=cache, metric="sim")[0].distance
    key = search.clip_key(c)
    fn = cache.file_for(key, search.DEFAULT_LEVEL)
    # 1) garbage bytes
    with open(fn, "wb") as f:
        f.write(b"not a zip file at all")
    res = search.rank_clips(q, [c], cache=search.SignatureCache(tmp_path), metric="sim")
    assert res.stats["invalid"] == 1 and res.stats["misses"] == 1
    assert res[0].distance == pytest.approx(truth, rel=1e-12)
    assert np.load(fn)["meta"].size > 0  # rewritten, readable
    # 2) truncated file
    data = open(fn, "rb").read()
    with open(fn, "wb") as f:
        f.write(data[: len(data) // 2])
    res = search.rank_clips(q, [c], cache=search.SignatureCache(tmp_path), metric="sim")
    assert res.stats["invalid"] == 1 and res[0].distance == pytest.approx(truth, rel=1e-12)
    # 3) an entry of another format version
    with np.load(fn) as z:
        arrays = dict(z)
    meta = json.loads(bytes(arrays["meta"]).decode())
    meta["format"] = search.CACHE_FORMAT + 1
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    np.savez(fn, **arrays)
    res = search.rank_clips(q, [c], cache=search.SignatureCache(tmp_path), metric="sim")
    assert res.stats["invalid"] == 1 and res.stats["misses"] == 1
    # 4) spoiled after the light read (meta + sketch) and before the directions are needed: recomputed
    cache2 = search.SignatureCache(tmp_path)
    item = search.clip_items([c])[0]
    assert search.item_entries(item, search.DEFAULT_LEVEL, cache2)[0].direction is None  # a light read
    with open(fn, "wb") as f:
        f.write(b"spoiled")
    res = search.rank_clips(q, [item], cache=cache2, metric="sim")
    assert res.stats["invalid"] == 1 and res.stats["misses"] == 1
    assert res[0].distance == pytest.approx(truth, rel=1e-12)
    # 5) a manifest of another version removes the cache's own entry files (in its own folder)
    own = os.path.join(tmp_path, search.CACHE_SUBDIR)
    with open(os.path.join(own, "manifest.json"), "w") as f:
        json.dump({"format": -1}, f)
    cache = search.SignatureCache(tmp_path)
    assert cache.stats["invalid"] == 1 and cache.disk_usage()[0] == 0
    # 6) an unreadable manifest too
    with open(os.path.join(own, "manifest.json"), "w") as f:
        f.write("{")
    assert search.SignatureCache(tmp_path).stats["invalid"] == 1


def test_memory_limit_drops_and_rereads(clips, tmp_path):
    q = clips["07_01"]
    lib = [clips[k] for k in ("07_02", "09_02", "09_03", "16_15")]
    truth = [(r.name, r.distance) for r in search.rank_clips(q, lib, cache=search.SignatureCache(), metric="sim")]
    cache = search.SignatureCache(tmp_path, memory_limit=1)
    search.rank_clips(q, lib, cache=cache, metric="sim")
    dropped = [e for (_k, _l), es in cache._mem.items() for e in es if e.direction is None]
    assert dropped  # the limit forced entries out of memory
    res = search.rank_clips(q, lib, cache=cache, metric="sim")
    assert [(r.name, r.distance) for r in res] == truth
    assert res.stats["misses"] == 0
    loaded = [e for (_k, _l), es in cache._mem.items() for e in es if e.direction is not None]
    assert len(loaded) == 1  # re-reads keep within the limit too (only the last one loaded stays)
    assert cache.contains(search.clip_key(lib[0]), search.DEFAULT_LEVEL)
    assert not cache.contains("clip:nothing", search.DEFAULT_LEVEL)


def test_folder_library_keys_follow_file_contents(data_dir, tmp_path):
    src = data_dir / "acclaim"
    for n in ("07-walk.asf", "07_01.amc", "07_02.amc"):
        shutil.copy(src / n, tmp_path / n)
    (tmp_path / "notes.txt").write_text("not a clip")
    cache_dir = tmp_path / "cache"
    items = search.folder_library(tmp_path, asf=str(tmp_path / "07-walk.asf"))
    assert [it.name for it in items] == ["07_01", "07_02"]
    # folder .amc clips are read through the front door (armature axes, the comparison space): so must the query be
    q = sources.read_one(sources.ClipSpec(str(src / "07_01.amc"), asf=str(src / "07-walk.asf")))
    first = search.rank_clips(q, items, cache=search.SignatureCache(cache_dir), metric="sim")
    assert first[0].name == "07_01" and first[0].distance == pytest.approx(0.0, abs=1e-6)
    again = search.rank_clips(q, search.folder_library(tmp_path, asf=str(tmp_path / "07-walk.asf")),
                              cache=search.SignatureCache(cache_dir), metric="sim")
    assert again.stats["misses"] == 0
    # edit one value in 07_02.amc: only that file is read again
    text = (tmp_path / "07_02.amc").read_text().splitlines()
    i = next(k for k, line in enumerate(text) if line.startswith("lfemur"))
    parts = text[i].split()
    parts[1] = str(float(parts[1]) + 5.0)
    text[i] = " ".join(parts)
    (tmp_path / "07_02.amc").write_text("\n".join(text) + "\n")
    third = search.rank_clips(q, search.folder_library(tmp_path, asf=str(tmp_path / "07-walk.asf")),
                              cache=search.SignatureCache(cache_dir), metric="sim")
    assert third.stats["misses"] == 1 and third.stats["disk_hits"] == 2
    with pytest.raises(ShapeSigError, match="not found"):
        search.folder_library(tmp_path / "nope")


def test_build_index_progress_and_cancel(clips, tmp_path):
    items = search.clip_items(list(clips.values()))
    seen = []
    info = search.build_index(items, cache=search.SignatureCache(tmp_path),
                              progress=lambda i, n: seen.append((i, n)) or i >= 2)
    assert info["clips"] == 2 and seen == [(0, 5), (1, 5), (2, 5)]  # cancelled before the third: no final call
    info = search.build_index(items, cache=search.SignatureCache(tmp_path))
    # two items were indexed (signature and local entries: 4 files), three are computed (6 entries)
    assert info["clips"] == 5 and info["stats"]["disk_hits"] == 4 and info["stats"]["misses"] == 6


def test_default_cache_dir_honours_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "x"))
    assert search.default_cache_dir() == str(tmp_path / "x")


def test_compact_index_ranks_by_sketch(clips, tmp_path):
    q = clips["07_01"]
    lib = [clips[k] for k in ("09_02", "07_02", "16_15", "09_03")]
    exact = {r.name: r.distance for r in search.rank_clips(q, lib, cache=search.SignatureCache(), metric="sim")}
    compact = search.SignatureCache(tmp_path, max_direction=10_000)  # 31-bone level-3 directions are longer
    res = search.rank_clips(q, lib, cache=compact, rerank=1, metric="sim")
    assert all(r.approximate for r in res)
    assert [r.name for r in res][:2] == sorted(exact, key=exact.get)[:2]
    for r in res:
        assert r.distance == pytest.approx(exact[r.name], rel=0.15)
    assert res[0].elastic is not None  # the elastic re-rank does not need the directions
    # on disk: no direction stored, read back the same, and much smaller than the exact entries
    again = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path, max_direction=10_000), metric="sim")
    assert again.stats["misses"] == 0 and [r.distance for r in again][1:] == [r.distance for r in res][1:]
    full = search.SignatureCache(tmp_path / "full")
    search.rank_clips(q, lib, cache=full, metric="sim")
    assert compact.disk_usage()[1] < 0.5 * full.disk_usage()[1]
    # the exact cache in the same folder does not reuse compact entries
    mixed = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path), metric="sim")
    assert mixed.stats["misses"] == 5 and not any(r.approximate for r in mixed)


def test_file_items_for_command_line_specs(data_dir, tmp_path):
    d = data_dir / "acclaim"
    asf = str(d / "07-walk.asf")
    specs = [str(d / "07_01.amc"), str(d / "07_02.amc"), str(d / "07_01.amc")]
    items = search.folder_library(specs, asf=asf)
    assert [it.name for it in items] == ["07_01", "07_02"]  # repeated specs once, in the given order
    cropped = search.folder_library(specs[:1], asf=asf, start=10, end=60)
    assert cropped[0].key != items[0].key
    (clip,) = cropped[0].clips()
    assert (clip.frame_start, clip.frames) == (10, 51)
    with pytest.raises(ShapeSigError, match="not found"):
        search.folder_library([str(tmp_path / "x.blend#walk")])
    # a reader named by module path (.blend's lives in the Blender layer) is imported when first needed: without it, one line
    from blender_shapesig.core.io import registry

    saved = dict(registry._READERS)
    try:
        registry._READERS[".bvh"] = "blender_shapesig._no_such_reader_module:read"
        with pytest.raises(ShapeSigError, match="needs Blender"):
            search.folder_library([str(data_dir / "bvh" / "07_01.bvh")])[0].clips()
    finally:
        registry._READERS.update(saved)
    # a file that cannot be read is reported by rank_clips as a warning, the others are ranked
    bad = tmp_path / "bad.amc"
    bad.write_text("this is not an AMC file\n")
    q = load_acclaim(specs[0], asf)
    res = search.rank_clips(q, search.folder_library([str(bad), specs[1]], asf=asf), metric="sim")
    assert [r.name for r in res] == ["07_02"] and any("bad" in w for w in res.warnings)


def test_clips_sharing_few_moving_bones_rank_after_the_rest(data_dir):
    """A clip compared on a small part of the body must not outrank whole-body matches (even re-ranked)."""
    acc = data_dir / "acclaim"
    q = load_acclaim(str(acc / "07_01.amc"), str(acc / "07-walk.asf"), axes="blender")
    walk = load_acclaim(str(acc / "07_02.amc"), str(acc / "07-walk.asf"), axes="blender")
    run = load_acclaim(str(acc / "09_02.amc"), str(acc / "09-run.asf"), axes="blender")
    # the same walk as q, but only two of its bones: alone, its distance on them is ~0
    head_only = q.select(("head", "lowerneck"))
    head_only.name = "head_only"
    for rerank in (0, 3):
        res = search.rank_clips(q, [head_only, run, walk], rerank=rerank, metric="sim")
        assert [r.name for r in res] == ["07_02", "09_02", "head_only"], rerank
        assert [r.partial for r in res] == [False, False, True]
        assert res[2].distance < res[0].distance  # it would have been first on distance alone
    assert any("head_only: shares only" in w for w in res.warnings)


def test_store_is_pure_and_the_index_generator_fills_it(clips, tmp_path):
    """The store only stores (it never loads a clip); iter_entries computes one item per step, puts it in the
    store and records an unreadable item as a one-line error."""
    store = search.SignatureCache(tmp_path)
    assert not hasattr(store, "entries")
    items = search.clip_items([clips["07_01"], clips["07_02"]])

    def unreadable():
        raise ShapeSigError("unreadable")

    bad = search.LibraryItem("bad", "clip:bad", unreadable)
    errors = []
    steps = search.iter_entries(items + [bad], 3, store, errors)
    item, got = next(steps)
    assert item is items[0] and [e.name for e in got] == ["07_01"] and store.contains(item.key, 3)
    assert not store.contains(items[1].key, 3)  # lazy: nothing is computed before its step
    rest = list(steps)
    assert [(it.name, len(got)) for it, got in rest] == [("07_02", 1), ("bad", 0)]
    assert errors == ["bad: unreadable"]
    assert store.stats["misses"] == 3 and store.stats["writes"] == 2
    with pytest.raises(ShapeSigError, match="unreadable"):
        list(search.iter_entries([bad], 3, store))
    fresh = search.SignatureCache(tmp_path)
    assert [len(got) for _, got in search.iter_entries(items, 3, fresh)] == [1, 1]
    assert fresh.stats["misses"] == 0 and fresh.stats["disk_hits"] == 2
    # compact mode is the store's: put drops directions longer than max_direction
    compact = search.SignatureCache(max_direction=10)
    e = search.make_entry(clips["07_01"], 3, key="k")
    compact.put("k", 3, [e])
    assert e.direction is None and not e.exact and compact.get("k", 3) == [e]


def test_light_pack_answers_lookups_of_a_new_process_in_one_read(clips, tmp_path, monkeypatch):
    """rank_clips saves a light pack (meta + sketches of every entry file); a new SignatureCache looks items up
    from it without opening their entry files, but not an entry whose file changed since, nor from a bad pack."""
    from blender_shapesig.core.search import store as store_mod

    q = clips["07_01"]
    lib = [clips[k] for k in ("07_02", "09_02", "16_15")]
    first = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path), metric="sim")
    assert (tmp_path / search.CACHE_SUBDIR / store_mod._PACK).exists()
    opened = []
    real_load = store_mod.np.load

    def counting_load(fn, *a, **k):
        opened.append(os.path.basename(fn))
        return real_load(fn, *a, **k)

    monkeypatch.setattr(store_mod.np, "load", counting_load)
    cache = search.SignatureCache(tmp_path)
    items = search.clip_items([q] + lib)
    for it in items:
        assert cache.get(it.key, 3) is not None
    assert opened == [store_mod._PACK]  # one read for the four lookups
    again = search.rank_clips(q, lib, cache=search.SignatureCache(tmp_path), metric="sim")
    assert [(r.name, r.distance) for r in again] == [(r.name, r.distance) for r in first]
    # an entry file rewritten since the pack was saved is read from its file
    target = cache.file_for(items[1].key, 3)
    data = open(target, "rb").read()
    os.remove(target)
    with open(target, "wb") as fh:
        fh.write(data + b"")
    os.utime(target, ns=(1, 1))
    opened.clear()
    assert search.SignatureCache(tmp_path).get(items[1].key, 3) is not None
    assert opened == [store_mod._PACK, os.path.basename(target)]
    # a damaged pack is ignored: every entry is read from its own file
    (tmp_path / search.CACHE_SUBDIR / store_mod._PACK).write_bytes(b"not a pack")
    opened.clear()
    fresh = search.SignatureCache(tmp_path)
    assert all(fresh.get(it.key, 3) is not None for it in items) and len(opened) == 1 + len(items)


@pytest.mark.parametrize("metric", ["local", "sim3"])
def test_each_row_carries_the_item_it_came_from(data_dir, tmp_path, metric):
    """Byte-identical copies (one key) in two folders are two rows, each naming its own file through its item;
    every row's item is one of the library's and has the row's key (the command line and the panel read it)."""
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        shutil.copy(data_dir / "bvh" / "07_02.bvh", tmp_path / sub / "07_02.bvh")
    shutil.copy(data_dir / "bvh" / "09_02.bvh", tmp_path / "a" / "09_02.bvh")
    items = sources.library([str(tmp_path / "a"), str(tmp_path / "b")])
    query = sources.library([str(data_dir / "bvh" / "07_01.bvh")])[0]
    got = search.rank_clips(query, items, metric=metric, cache=search.SignatureCache())
    assert len(got) == 3 and all(any(r.item is it for it in items) and r.item.key == r.key for r in got)
    copies = [r.item.path for r in got if r.name == "07_02"]
    assert sorted(copies) == [str(tmp_path / "a" / "07_02.bvh"), str(tmp_path / "b" / "07_02.bvh")]
