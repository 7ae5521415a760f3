"""The command line and the panel share signature-cache entries: a folder library indexed the way the panel's
folder libraries are (``core.io.sources.library`` + ``core.search.build_index``) is a cache hit for ``rank`` on the
same files, because both key a file by ``ClipSpec.key`` (its bytes, skeleton, action and crop). .amc only: no bpy."""

import json
import pathlib
import shutil

from blender_shapesig import cli
from blender_shapesig.core import search as search
from blender_shapesig.core.io import sources

ACC = pathlib.Path(__file__).resolve().parents[1] / "data" / "acclaim"


def _rank(capsys, args):
    assert cli.main(args + ["--json", "--no-progress"]) == 0
    return json.loads(capsys.readouterr().out)


def test_panel_built_entries_are_cli_cache_hits(capsys, tmp_path):
    folder = tmp_path / "library"
    folder.mkdir()
    for name in ("09-run.asf", "09_02.amc", "09_03.amc"):  # one skeleton: found beside the takes
        shutil.copy2(ACC / name, folder / name)
    cache_dir = tmp_path / "cache"

    # what the panel's folder library does
    items = sources.library([folder], start=2)
    built = search.build_index(items, cache=search.SignatureCache(str(cache_dir)))
    # each take: its signature entry and its local-search entry (one read)
    assert built["clips"] == 2 and not built["errors"] and built["stats"]["misses"] == 4

    takes = [str(folder / "09_02.amc"), str(folder / "09_03.amc")]
    out = _rank(capsys, ["rank", takes[0], *takes, "--cache", str(cache_dir), "--start", "2"])
    assert out["cache"]["misses"] == 0 and out["cache"]["hits"] > 0, out["cache"]
    assert [r["clip"] for r in out["results"]][0] == "09_02"

    # another crop is another key: the CLI computes it (the keys are not equal by accident)
    other = _rank(capsys, ["rank", takes[0], *takes, "--cache", str(cache_dir), "--start", "3"])
    assert other["cache"]["misses"] > 0, other["cache"]


def test_a_cached_query_is_not_read_again_and_reports_the_same(capsys, tmp_path, monkeypatch):
    """The default search takes a cached query's entry as it is: the second call reads no clip at all (every read
    fails) and prints what the first printed, trimmed query or not; an entry stored without its first frame (an
    older cache) is read as before."""
    bvh = pathlib.Path(__file__).resolve().parents[1] / "data" / "bvh"
    lib = [str(bvh / n) for n in ("07_01.bvh", "07_02.bvh", "09_02.bvh")]
    for trim in ("auto", "none"):
        args = ["rank", lib[0], *lib[1:], "--cache", str(tmp_path / trim), "--trim", trim]
        first = _rank(capsys, args)
        assert first["cache"]["misses"] == 3
        with monkeypatch.context() as m:
            m.setattr(sources, "read", lambda *a, **k: (_ for _ in ()).throw(AssertionError("a clip was read")))
            again = _rank(capsys, args)
        assert again["cache"] == {"hits": 3, "misses": 0}
        assert {k: v for k, v in again.items() if k != "cache"} == {k: v for k, v in first.items() if k != "cache"}
        # the query's trim as reading it says: frames 1..N untrimmed (BVH frames count from 1), else the kept range
        assert (first["query_trim"][0] == 1) == (trim == "none") and first["query_trimmed"][0] >= 0

    from blender_shapesig.core.search.local import store as local_store

    meta = local_store._meta
    monkeypatch.setattr(local_store, "_meta", lambda e: {k: v for k, v in meta(e).items() if k != "first"})
    args = ["rank", lib[0], *lib[1:], "--cache", str(tmp_path / "old")]
    old = _rank(capsys, args)
    read = []
    real = sources.read
    monkeypatch.setattr(sources, "read", lambda spec, **k: read.append(spec.path) or real(spec, **k))
    again = _rank(capsys, args)
    assert read == [lib[0]] and again["results"] == old["results"]  # the query only, as before
