"""The local search's library file (``core.search.local.library``, ``local_pack.bin``): ranking from the memory-mapped
file equals the per-file store and ``core.search.local.features`` called directly; a clip added, changed or removed is seen;
a damaged file is refused in one line and rebuilt; the first stage streamed over row ranges and its prefilter; the
``index`` command's JSON, also on a Dask LocalCluster."""

import json
from dataclasses import replace
import os
import shutil

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core import search as index
from blender_shapesig.core.search.local import description, features as ls
from blender_shapesig.core.search.local.library import open_library
from blender_shapesig.core.search.local.store import LOCAL_PACK
from tests.helpers.local_entries import entry
from blender_shapesig.core.io import sources


def _items(folder):
    return [sources.spec_item(sources.ClipSpec(str(folder / f))) for f in sorted(os.listdir(folder))]


@pytest.fixture
def lib_dir(data_dir, tmp_path):
    d = tmp_path / "lib"
    d.mkdir()
    for f in sorted((data_dir / "bvh").glob("*.bvh")):
        shutil.copy(f, d / f.name)
    shutil.copy(data_dir / "acclaim" / "16_15.bvh", d / "16_15.bvh")
    return d


def _names(results):
    return [(r.name, round(r.distance, 5)) for r in results]


@pytest.mark.parametrize("query", ["08_01.bvh", "09_02.bvh"])  # a walk; a run, whose arms strike (the union)
def test_ranking_from_the_library_file_equals_the_per_file_store_and_the_search(lib_dir, tmp_path, query):
    items = _items(lib_dir)
    q = sources.read_one(sources.ClipSpec(str(lib_dir / query)))
    assert description.strikes(ls.index_entry(q)) == (query == "09_02.bvh")
    cache = tmp_path / "cache"
    first = index.rank_clips(q, items, cache=index.SignatureCache(cache))  # computes, writes files and the pack
    pack = cache / index.CACHE_SUBDIR / LOCAL_PACK
    assert open_library(str(pack)).arrays["windows"].shape[1] == ls.DIM
    fresh = index.SignatureCache(cache)
    again = index.rank_clips(q, items, cache=fresh)
    assert fresh.stats["writes"] == 0 and isinstance(fresh.local._lib.arrays["windows"].base, np.memmap)
    # the union's descriptions come from the file's array, row for row the entries' own (``described_rows``)
    _key, ranked_entries, block = fresh.local._local_memo
    assert np.array_equal(block["descriptions"], description.described_rows(ranked_entries), equal_nan=True)
    assert _names(again) == _names(first)
    # the scores too: what happens in each clip (``description``) is read back from the file, not dropped
    assert open_library(str(pack)).arrays["descriptions"].shape[1] == len(description.PARTS)
    assert [r.distance for r in again] == pytest.approx([r.distance for r in first], rel=1e-6)
    # the truth: core.search.local.features on entries computed here
    entries = [ls.index_entry(c) for it in items for c in it.clips()]
    order = ls.search(ls.index_entry(q), entries)
    names = [c.name for it in items for c in it.clips()]
    assert [r.name for r in again] == [names[i] for i in order]


def test_added_changed_removed_clips_and_a_damaged_file(lib_dir, tmp_path, data_dir):
    cache = tmp_path / "cache"
    q = sources.read_one(sources.ClipSpec(str(lib_dir / "08_01.bvh")))
    index.rank_clips(q, _items(lib_dir), cache=index.SignatureCache(cache))
    # added: a clip that was not there; changed: another file's bytes under a name; removed: one file gone
    shutil.copy(data_dir / "bvh" / "13_32.bvh", lib_dir / "new.bvh")
    shutil.copy(data_dir / "bvh" / "08_01.bvh", lib_dir / "16_15.bvh")
    (lib_dir / "13_32.bvh").unlink()
    items = _items(lib_dir)
    got = index.rank_clips(q, items, cache=index.SignatureCache(cache))
    want = index.rank_clips(q, items, cache=None)
    assert _names(got) == _names(want) and {r.name for r in got} == {c.name for it in items for c in it.clips()}
    # damaged: truncated -> refused in one line, deleted, the ranking unchanged, the file written again
    pack = cache / index.CACHE_SUBDIR / LOCAL_PACK
    data = pack.read_bytes()
    pack.write_bytes(data[:len(data) // 2])
    with pytest.raises(ValueError, match="damaged") as exc:
        open_library(str(pack))
    assert "\n" not in str(exc.value)
    store = index.SignatureCache(cache)
    again = index.rank_clips(q, items, cache=store)
    assert _names(again) == _names(want)
    assert store.local.warning and "\n" not in store.local.warning and store.stats["invalid"] >= 1
    assert open_library(str(pack)).arrays["windows"].shape[0] > 0
    # garbage in place of the header: refused too
    pack.write_bytes(b"SHAPESIG-LPACK2\n" + b"\xff" * 64)
    with pytest.raises(ValueError, match="damaged"):
        open_library(str(pack))


def test_first_stage_over_row_ranges_in_any_order_and_the_prefilter():
    rng = np.random.default_rng(3)
    entries = [entry(windows=rng.standard_normal((rng.integers(2, 9), 8)).astype(np.float16)) for _ in range(40)]
    q = entry(windows=rng.standard_normal((5, 8)).astype(np.float16))
    block = ls.stack(entries)
    want = ls.first_stage(q, entries)
    # brute force, independent: the Chamfer by definition
    for i in (0, 17, 39):
        D = np.linalg.norm(np.asarray(q.windows, float)[:, None] - np.asarray(entries[i].windows, float)[None],
                           axis=2)
        assert want[i] == pytest.approx(0.5 * (D.min(1).mean() + D.min(0).mean()), rel=1e-4)
    perm = rng.permutation(40)  # the same rows, the entries in another order, and tiny blocks
    shuffled = dict(block, starts=block["starts"][perm], ends=block["ends"][perm])
    assert np.allclose(ls.first_stage(q, shuffled, block=7), want[perm], rtol=1e-6)
    # the prefilter: exact for the kept, the others after them in the prefilter's order
    coarse = np.stack([ls.coarse_windows(e.windows, 4) for e in entries])
    got = ls.first_stage(q, dict(block, coarse=coarse), keep=10)
    exact = np.isclose(got, want, rtol=1e-6)
    assert exact.sum() >= 10 and got[~exact].min() >= got[exact].max()


def test_index_command_json_and_dask(capsys, lib_dir, tmp_path):
    cache = tmp_path / "c"
    assert cli.main(["index", str(lib_dir), "--cache", str(cache), "--json", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out)
    n = len(os.listdir(lib_dir))
    assert out["clips"] == n and out["computed"] == n and out["seconds"] > 0
    assert (cache / index.CACHE_SUBDIR / LOCAL_PACK).exists()
    assert cli.main(["index", str(lib_dir), "--cache", str(cache), "--json", "--no-progress"]) == 0
    assert json.loads(capsys.readouterr().out)["computed"] == 0  # nothing again
    # a second cache filled on a Dask cluster holds the same entries
    import distributed
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        cache2 = tmp_path / "d"
        assert cli.main(["index", str(lib_dir), "--cache", str(cache2), "--json", "--no-progress",
                         "--scheduler", c.scheduler_address]) == 0
    assert json.loads(capsys.readouterr().out)["computed"] == n
    a, b = index.SignatureCache(cache), index.SignatureCache(cache2)
    for it in _items(lib_dir):
        ea, eb = a.local.get(it.key, ls.settings_key()), b.local.get(it.key, ls.settings_key())
        assert np.array_equal(np.asarray(ea[0].windows), np.asarray(eb[0].windows))
    assert cli.main(["index", str(lib_dir), "--scheduler", "nonsense"]) == 2


def test_rank_scheduler_computes_the_missing_entries_on_a_dask_cluster(capsys, lib_dir, tmp_path):
    """``rank --scheduler``: the library's entries computed on a LocalCluster, stored once, the ranking then only
    reads them (cache misses: the query alone) and equals the ranking computed in this process."""
    import distributed

    query = str(lib_dir / "08_01.bvh")
    base = ["rank", query, str(lib_dir), "--json", "--no-progress", "--top", "5"]
    assert cli.main(base + ["--cache", str(tmp_path / "plain")]) == 0
    plain = json.loads(capsys.readouterr().out)
    n = len(os.listdir(lib_dir))
    assert plain["cache"]["misses"] >= n  # computed here, clip after clip
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        for metric in ([], ["--metric", "sim3"]):
            dask_run = base + metric + ["--cache", str(tmp_path / "dask"), "--scheduler", c.scheduler_address]
            assert cli.main(dask_run) == 0
            out = json.loads(capsys.readouterr().out)
            assert out["computed"] == n and out["cache"]["misses"] <= 1  # the query's entry is this process'
            if not metric:
                assert [(r["clip"], round(r["distance"], 6)) for r in out["results"]] == \
                       [(r["clip"], round(r["distance"], 6)) for r in plain["results"]]
        assert cli.main(base + ["--cache", str(tmp_path / "dask"), "--scheduler", c.scheduler_address]) == 0
        assert json.loads(capsys.readouterr().out)["computed"] == 0  # nothing again
    assert cli.main(base + ["--scheduler", "nonsense"]) == 2
    assert cli.main(base + ["--windows", "--scheduler", "threads"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 2 and err.count("--scheduler") == 2


def test_rank_scheduler_without_dask_is_one_line_naming_the_package(lib_dir, tmp_path):
    """Dask is optional: made unimportable, ``rank --scheduler`` stops with one line naming what to install,
    before any clip is read; without the option the ranking runs."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['dask'] = sys.modules['distributed'] = None; "
            "from blender_shapesig import cli; sys.exit(cli.main(sys.argv[1:]))")
    env = dict(os.environ, PYTHONPATH=str(ls.__file__).rsplit("/blender_shapesig/", 1)[0])
    args = [sys.executable, "-c", code, "rank", str(lib_dir / "08_01.bvh"), str(lib_dir), "--no-cache", "--top", "2",
            "--no-progress"]
    for sched, package in (("threads", "'dask'"), ("tcp://127.0.0.1:8786", "'distributed'")):
        p = subprocess.run(args + ["--scheduler", sched], env=env, capture_output=True, text=True)
        assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
        assert package in p.stderr and "pip install" in p.stderr and "Traceback" not in p.stderr
    assert subprocess.run(args, env=env, capture_output=True, text=True).returncode == 0


def _mapped(path):
    with open("/proc/self/maps") as f:
        return any(line.rstrip().endswith(str(path)) for line in f)


@pytest.mark.parametrize("locked", [True, False])
def test_the_library_file_is_closed_before_it_is_replaced_where_mapped_files_are_locked(
        lib_dir, tmp_path, data_dir, monkeypatch, locked):
    """Windows refuses to replace a file this process has memory-mapped. Simulated here (Linux's /proc/self/maps
    tells whether the file is mapped): with ``MAPPED_FILES_LOCKED`` the store closes the map before writing the
    file again (no warning, the file holds the added clip, the ranking is the one computed without a cache);
    without it the simulated refusal turns the disk off with one warning (what Windows did before)."""
    from blender_shapesig.core.search.local import store as local_store

    q = sources.read_one(sources.ClipSpec(str(lib_dir / "08_01.bvh")))
    cache = tmp_path / "cache"
    index.rank_clips(q, _items(lib_dir), cache=index.SignatureCache(cache))
    pack = cache / index.CACHE_SUBDIR / LOCAL_PACK
    store = index.SignatureCache(cache)
    index.rank_clips(q, _items(lib_dir), cache=store)
    assert _mapped(pack)  # the entries are read from the mapped file
    real = os.replace

    def windows_replace(src, dst):
        if _mapped(dst):
            raise PermissionError(13, "The process cannot access the file because it is being used", str(dst))
        return real(src, dst)

    monkeypatch.setattr(local_store, "MAPPED_FILES_LOCKED", locked)
    monkeypatch.setattr(os, "replace", windows_replace)
    shutil.copy(data_dir / "bvh" / "13_32.bvh", lib_dir / "added.bvh")
    got = index.rank_clips(q, _items(lib_dir), cache=store)
    monkeypatch.setattr(os, "replace", real)
    if locked:
        assert store.warning is None and not _mapped(pack)
        assert "added" in {m["name"] for *_, meta, _ in open_library(str(pack)).files for m in meta["clips"]}
        assert _names(got) == _names(index.rank_clips(q, _items(lib_dir), cache=None))
    else:
        assert store.warning and "signature cache off" in store.warning and "\n" not in store.warning


def test_joint_lists_are_stored_once_per_rig_and_version_2_files_still_open(tmp_path):
    """The header keeps each distinct joint list once (a 100,000-clip library of a few rigs would otherwise carry
    about a kilobyte of joint names per clip, read at every opening); entries read back have their own lists.
    A file of version 2 (the lists in each clip) still opens with the same entries."""
    import struct

    from blender_shapesig.core.search.local import library as ll
    from blender_shapesig.core.search.local import take

    rng = np.random.default_rng(4)
    rig_a = [f"bone_with_a_long_name_{i:02d}" for i in range(12)]
    rig_b = ["hips", "thigh.L", "thigh.R"]
    clips, entries = [], []
    for i in range(9):
        joints = rig_a if i % 3 else rig_b
        clips.append({"name": f"c{i}", "frames": 10, "bones": len(joints), "trimmed": [], "joints": joints,
                      "still": joints[:2], "rig_joints": ["hips"]})
        entries.append(entry(windows=rng.standard_normal((3, ls.DIM)).astype(np.float16),
                             sequence=rng.standard_normal((4, 3 * len(ls.POINTS))).astype(np.float16),
                             take=rng.standard_normal(take.DIM).astype(np.float32),
                             take_mask=(rng.random(len(take.JOINTS)) < 0.8).astype(np.uint8)))
    fn = tmp_path / "lib.bin"
    with open(fn, "wb") as f:
        ll.write_library(f, [("f", 1, 2, {"clips": clips}, entries)], "fmt")
    data = fn.read_bytes()
    assert data.count(b"bone_with_a_long_name_07") == 1

    def read_back(path):
        lib = open_library(str(path))
        return [lib.entry(m, r) for *_, meta, rows in lib.files for m, r in zip(meta["clips"], rows)]

    for want, e, got in zip(clips, entries, read_back(fn)):
        assert got.joints == tuple(want["joints"]) and got.still == tuple(want["still"])
        assert got.rig_joints == ("hips",)
        assert np.array_equal(got.take, e.take) and np.array_equal(got.take_mask, e.take_mask)
    # version 2: the same arrays, the lists written in each clip (the arrays start after a reserve of 4 KB)
    (n,) = struct.unpack("<Q", data[len(ll.MAGIC):len(ll.MAGIC) + 8])
    header = json.loads(data[len(ll.MAGIC) + 8:len(ll.MAGIC) + 8 + n])
    tables = header.pop("lists")
    for m in header["files"][0][3]["clips"]:
        for k in ll.JOINT_LISTS:
            m[k] = tables[m[k]]
    text = json.dumps(header).encode()
    v2 = b"SHAPESIG-LPACK2\n" + struct.pack("<Q", len(text)) + text
    start = min(a[0] for a in header["arrays"].values())
    assert len(v2) <= start
    (tmp_path / "v2.bin").write_bytes(v2 + b"\0" * (start - len(v2)) + data[start:])
    old = read_back(tmp_path / "v2.bin")
    for a, b in zip(read_back(fn), old):
        assert a.joints == b.joints and np.array_equal(a.windows, b.windows)
    # a list number that is not in the table: refused in one line
    bad = data.replace(b'"rig_joints": 2', b'"rig_joints": 9', 1)
    assert bad != data
    (tmp_path / "bad.bin").write_bytes(bad)
    with pytest.raises(ValueError, match="damaged"):
        open_library(str(tmp_path / "bad.bin"))


def test_a_cache_of_an_older_recipe_keeps_working(lib_dir, tmp_path):
    """A cache folder used before the whole take was stored holds entries without it (another settings key, kept in
    the pack until their files go): the next ranking writes the pack with them (a zero mask: read back as no take;
    a description of another recipe's width: read back as none),
    ranks as a fresh cache does, and releasing the memory map copies them without a take."""
    items = _items(lib_dir)
    q = sources.read_one(sources.ClipSpec(str(lib_dir / "08_01.bvh")))
    folder = tmp_path / "cache"
    old = index.SignatureCache(folder)
    # and a description of another number of parts (the recipe before the arms' numbers had nine): read back as none
    olds = [replace(ls.index_entry(c), take=None, take_mask=None, seconds=0.0, name="old",
                    describe=np.arange(len(description.PARTS) + 1, dtype=np.float32)) for c in items[0].clips()]
    old.local.put(items[0].key, "an older recipe", olds)
    old.local.save_pack()
    store = index.SignatureCache(folder)
    got = index.rank_clips(q, items, cache=store)  # reads the old pack, writes the new one
    assert _names(got) == _names(index.rank_clips(q, items, cache=None))
    reopened = index.SignatureCache(folder)
    back = reopened.local.get(items[0].key, "an older recipe")
    assert back is not None and back[0].take is None and len(back[0].windows) == len(olds[0].windows)
    assert back[0].describe is None
    fresh = reopened.local.get(items[0].key, ls.settings_key())
    assert fresh is not None and fresh[0].take_mask.any()
    reopened.local.release()
    assert back[0].take is None and isinstance(fresh[0].take, np.ndarray)
