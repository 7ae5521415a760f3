"""No command overwrites a user's file: ``blend --out`` naming a source is refused, an existing output of
``blend``, ``dedupe``, ``matrix``, ``evaluate`` and ``rank --thumbnails`` is replaced only with ``--overwrite``
(one line, exit 2, the file untouched), and outputs appear complete or not at all; a ``--cache`` that cannot be
used and a ``--scheduler`` that is not a Dask scheduler are one line and exit 2."""

import hashlib
import json
import os
import shutil
import socket
import threading

import pytest

from blender_shapesig import cli
from tests.helpers.hostile import BVH, make_blend

ACC = BVH.parent.parent / "data" / "acclaim"


def _digest(path):
    return hashlib.sha1(path.read_bytes()).hexdigest()


def _run(capsys, args):
    code = cli.main([str(a) for a in args])
    return code, capsys.readouterr()


def _refused(code, io, path, digest):
    assert code == 2 and io.err.count("\n") == 1 and "--overwrite" in io.err, io.err
    assert _digest(path) == digest


@pytest.fixture
def lib(tmp_path):
    folder = tmp_path / "lib"
    folder.mkdir()
    for name in ("07_01", "09_02", "09_03"):
        shutil.copy(BVH / f"{name}.bvh", folder / f"{name}.bvh")
    return folder


def test_dedupe_keeps_an_existing_report(capsys, lib, tmp_path):
    out = tmp_path / "report"
    out.mkdir()
    mine = out / "report.html"
    mine.write_text("<p>my notes</p>")
    digest = _digest(mine)
    code, io = _run(capsys, ["dedupe", lib, "--out", out, "--no-plots", "--no-cache", "--no-progress"])
    _refused(code, io, mine, digest)
    assert not (out / "report.json").exists()
    code, io = _run(capsys, ["dedupe", lib, "--out", out, "--no-plots", "--no-cache", "--no-progress",
                             "--overwrite", "--json"])
    assert code == 0, io.err
    assert json.loads((out / "report.json").read_text())["clips"] == 3 and _digest(mine) != digest
    assert [n for n in os.listdir(out) if n.startswith(".")] == []  # no temporary file left


def test_matrix_keeps_an_existing_matrix_and_writes_nothing_on_failure(capsys, lib, tmp_path, monkeypatch):
    out = tmp_path / "m"
    out.mkdir()
    mine = out / "matrix.csv"
    mine.write_text("mine\n")
    digest = _digest(mine)
    clips = sorted(lib.iterdir())
    code, io = _run(capsys, ["matrix", *clips, "--out", out, "--metric", "sim2", "--no-progress"])
    _refused(code, io, mine, digest)
    from blender_shapesig import evaluation

    def full_disk(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(evaluation, "plot_dendrogram", full_disk)  # fails after the matrix and the MDS plot
    code, io = _run(capsys, ["matrix", *clips, "--out", out, "--metric", "sim2", "--no-progress", "--overwrite"])
    assert code == 2 and "No space left" in io.err
    assert sorted(os.listdir(out)) == ["matrix.csv"] and _digest(mine) == digest  # nothing half-written
    monkeypatch.undo()
    code, io = _run(capsys, ["matrix", *clips, "--out", out, "--metric", "sim2", "--no-progress", "--overwrite"])
    assert code == 0, io.err
    assert sorted(os.listdir(out)) == ["dendrogram.png", "matrix.csv", "matrix.npy", "mds.png"]


def test_rank_thumbnails_keep_existing_pictures(capsys, lib, tmp_path):
    pics = tmp_path / "pics"
    pics.mkdir()
    mine = pics / "query.png"
    mine.write_bytes(b"my picture")
    digest = _digest(mine)
    args = ["rank", BVH / "09_02.bvh", lib, "--thumbnails", pics, "--cache", tmp_path / "c", "--no-progress"]
    code, io = _run(capsys, args)
    _refused(code, io, mine, digest)
    assert os.listdir(pics) == ["query.png"]
    code, io = _run(capsys, args + ["--overwrite"])
    assert code == 0, io.err
    assert mine.read_bytes().startswith(b"\x89PNG") and len(os.listdir(pics)) == 4


def test_evaluate_keeps_an_existing_summary(capsys, tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    rows = ["file,label"]
    for name, label in (("07_01", "walk"), ("07_02", "walk"), ("09_02", "run"), ("09_03", "run")):
        shutil.copy(BVH / f"{name}.bvh", data / f"{name}.bvh")
        rows.append(f"{name}.bvh,{label}")
    (data / "index.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "eval"
    out.mkdir()
    mine = out / "summary.json"
    mine.write_text("{}")
    digest = _digest(mine)
    args = ["evaluate", "--index", data / "index.csv", "--data", data, "--out", out, "--metrics", "sim2",
            "--no-figures", "--no-progress"]
    code, io = _run(capsys, args)
    _refused(code, io, mine, digest)
    code, io = _run(capsys, args + ["--overwrite"])
    assert code == 0, io.err
    assert json.loads(mine.read_text())["clips"] == 4


@pytest.fixture
def blend_source(tmp_path):
    pytest.importorskip("bpy", reason="writing a .blend needs the bpy module")
    return make_blend(tmp_path / "A.blend")


def test_blend_never_writes_over_a_source(capsys, blend_source, tmp_path):
    digest = _digest(blend_source)
    for extra in ([], ["--overwrite"]):
        code, io = _run(capsys, ["blend", blend_source, BVH / "09_03.bvh", "--weight", "0.5", "--out", blend_source,
                                 "--no-progress", *extra])
        assert code == 2 and io.err.count("\n") == 1 and "source" in io.err, io.err
        assert _digest(blend_source) == digest
    other = tmp_path / "out.blend"
    other.write_bytes(b"my file")
    code, io = _run(capsys, ["blend", blend_source, BVH / "09_03.bvh", "--weight", "0.5", "--out", other,
                             "--no-progress"])
    _refused(code, io, other, _digest(other))
    code, io = _run(capsys, ["blend", blend_source, BVH / "09_03.bvh", "--weight", "0.5", "--out", other,
                             "--no-progress", "--overwrite", "--json"])
    assert code == 0, io.err
    assert other.read_bytes()[:7] == b"BLENDER" or other.read_bytes()[:4] == b"\x28\xb5\x2f\xfd"  # (zstd)
    assert sorted(os.listdir(tmp_path)) == ["A.blend", "out.blend"]  # no temporary file left


def test_a_cache_that_cannot_be_used_is_an_error(capsys, lib, tmp_path):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("x")
    linked = tmp_path / "linked"
    linked.mkdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    os.symlink(elsewhere, linked / "blender_shapesig-cache")
    for cache in (not_a_folder / "sub", linked):
        for command in (["rank", BVH / "09_02.bvh", lib], ["index", lib]):
            code, io = _run(capsys, command + ["--cache", cache, "--no-progress"])
            assert code == 2 and io.err.count("\n") == 1 and "--cache" in io.err, io.err
    assert os.listdir(elsewhere) == []  # nothing written where the link points


def _silent_server():
    """A TCP server that accepts and says nothing (an HTTP server waiting for its request)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    conns = []
    threading.Thread(target=lambda: conns.append(srv.accept()), daemon=True).start()
    return srv


@pytest.mark.parametrize("sched", ["foo:bar", "http://127.0.0.1:8786", "tls://127.0.0.1:8786", "tcp://127.0.0.1",
                                   "nonsense", "tcp://127.0.0.1:99999", "closed", "silent"])
def test_a_scheduler_that_is_not_one_is_one_line(capsys, lib, tmp_path, sched):
    pytest.importorskip("distributed")
    if sched == "closed":
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        sched = f"tcp://127.0.0.1:{s.getsockname()[1]}"
        s.close()
    srv = None
    if sched == "silent":
        srv = _silent_server()
        sched = f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    try:
        code, io = _run(capsys, ["index", lib, "--scheduler", sched, "--cache", tmp_path / "c", "--no-progress"])
    finally:
        if srv is not None:
            srv.close()
    assert code == 2 and io.err.count("\n") == 1 and "--scheduler" in io.err and "Traceback" not in io.err, io.err
    assert not (tmp_path / "c").exists()  # refused before any clip was read or the cache made
