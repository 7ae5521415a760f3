"""A downloaded glTF or FBX cannot make the reading child read outside the library, wait on a FIFO or exhaust
memory: every ``buffers[]`` / ``images[]`` uri is checked before Blender's importer sees it (inside the file, a
``data:`` uri, or a regular file in the glTF's own folder within the memory budget), and an FBX whose arrays would
unpack over the budget is refused from its record headers, whatever its compression ratio. Each refusal is one
line for that file; the library's good clips are still ranked. A signal to the command line ends its reading
child and removes every temp folder."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from blender_shapesig.core.errors import ParseError, UnreadableFileError
from blender_shapesig.core.io.interchange import check_interchange
from blender_shapesig.readers import guard
from tests.helpers.hostile import BVH, ROOT, fbx_bomb, left_in, make_gltf, run_cli

pytest.importorskip("bpy", reason="Blender's glTF exporter writes the test files")


@pytest.fixture(scope="module")
def separate(tmp_path_factory):
    """w.gltf + w.bin (Blender's exporter), and beside its folder an ``outside`` folder holding a copy of w.bin."""
    base = tmp_path_factory.mktemp("gltf")
    lib = base / "lib"
    lib.mkdir()
    make_gltf(lib / "w.gltf")
    (base / "outside").mkdir()
    shutil.copy(lib / "w.bin", base / "outside" / "w.bin")
    return lib


def _variant(lib, name, buffer_uri=None, image_uri=None):
    doc = json.loads((lib / "w.gltf").read_text())
    if buffer_uri is not None:
        doc["buffers"][0]["uri"] = buffer_uri
    if image_uri is not None:
        doc.setdefault("images", []).append({"uri": image_uri, "name": "skin"})
    out = lib / name
    out.write_text(json.dumps(doc))
    return out


HOSTILE_BUFFERS = {
    "absolute": "{outside}/w.bin",
    "dotdot": "../outside/w.bin",
    "encoded": "..%2Foutside%2Fw.bin",
    "backslash": "..\\outside\\w.bin",
    "nested": "sub/../../outside/w.bin",
    "file_scheme": "file://{outside}/w.bin",
    "device": "/dev/zero",
    "passwd": "/etc/passwd",
    "fifo": "pipe.bin",
    "link_out": "link.bin",
    "missing": "nowhere.bin",
}


@pytest.fixture(scope="module")
def hostile(separate):
    outside = separate.parent / "outside"
    os.mkfifo(separate / "pipe.bin")
    os.symlink(outside / "w.bin", separate / "link.bin")
    return {case: _variant(separate, f"b_{case}.gltf", buffer_uri=uri.format(outside=outside))
            for case, uri in HOSTILE_BUFFERS.items()}


def test_the_separate_gltf_reads(separate):
    assert check_interchange(separate / "w.gltf")["animations"]


@pytest.mark.parametrize("case", sorted(HOSTILE_BUFFERS))
def test_a_buffer_outside_the_folder_is_refused_before_blender(hostile, case):
    with pytest.raises(ParseError) as info:
        check_interchange(hostile[case])
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(hostile[case])) and "buffer" in text


@pytest.mark.parametrize("uri", ["../outside/secret.png", "%2Fetc%2Fpasswd", "/dev/zero", "pipe.bin"])
def test_an_image_outside_the_folder_or_not_a_file_is_refused(hostile, separate, uri):
    path = _variant(separate, "image.gltf", image_uri=uri)
    with pytest.raises(ParseError, match="image"):
        check_interchange(path)


def test_a_missing_image_is_left_to_the_importer(separate):
    assert check_interchange(_variant(separate, "image_missing.gltf", image_uri="textures/skin.png"))["animations"]


def test_an_fbx_deflate_bomb_is_refused_from_its_headers(tmp_path):
    bomb = fbx_bomb(tmp_path / "bomb.fbx")
    assert bomb.stat().st_size < 2 ** 20
    with pytest.raises(UnreadableFileError, match="MB budget"):
        check_interchange(bomb)


def test_a_library_of_hostile_files_ranks_its_good_clips(hostile, separate, tmp_path):
    """The command line over the folder: exit 0, the good clips ranked (the glTF with its own buffer, the BVH),
    one line per hostile file, the process tree under 1 GB, nothing left in the temp folder."""
    lib = tmp_path / "lib"
    lib.mkdir()
    for f in ["w.gltf", "w.bin", "link.bin"] + [p.name for p in hostile.values()]:
        src = separate / f
        if src.is_symlink():
            os.symlink(os.readlink(src), lib / f)
        else:
            shutil.copy(src, lib / f)
    os.mkfifo(lib / "pipe.bin")
    for d in ("outside",):
        shutil.copytree(separate.parent / d, tmp_path / d)
    fbx_bomb(lib / "bomb.fbx")
    shutil.copy(BVH / "07_01.bvh", lib / "07_01.bvh")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    code, out, err, rss_mb = run_cli(["rank", BVH / "09_02.bvh", lib, "--no-cache", "--json", "--no-progress",
                                      "--metric", "sim3"], tmp, timeout=300)
    assert code == 0, err
    ranked = sorted(r["clip"] for r in json.loads(out)["results"])
    assert ranked == ["07_01", "w"], (ranked, err)
    for case in HOSTILE_BUFFERS:
        assert sum(f"b_{case}.gltf" in ln for ln in err.splitlines()) == 1, (case, err)
    assert sum("bomb.fbx" in ln for ln in err.splitlines()) == 1 and "Traceback" not in err
    assert rss_mb < 1024, rss_mb
    assert left_in(tmp) == []


def _children(pid):
    kids = []
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/children") as fh:
            kids += [int(k) for k in fh.read().split()]
    return kids


def _gone(pid, wait=20.0):
    end = time.monotonic() + wait
    while time.monotonic() < end:
        try:
            with open(f"/proc/{pid}/stat") as fh:
                if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                    return True
        except FileNotFoundError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT, signal.SIGKILL])
def test_a_signal_ends_the_reading_child_and_leaves_no_temp_folder(separate, tmp_path, sig):
    lib = tmp_path / "lib"
    lib.mkdir()
    for i in range(6):  # enough files that the child is busy when the signal comes
        shutil.copy(separate / "w.gltf", lib / f"w{i}.gltf")
    shutil.copy(separate / "w.bin", lib / "w.bin")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, TMPDIR=str(tmp), PYTHONPATH=str(ROOT))
    cli = subprocess.Popen([sys.executable, "-m", "blender_shapesig", "rank", str(BVH / "09_02.bvh"), str(lib),
                            "--no-cache", "--no-progress"], cwd=str(ROOT), env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE)
    kids = []
    end = time.monotonic() + 120
    while not kids and cli.poll() is None and time.monotonic() < end:
        kids = _children(cli.pid)
        time.sleep(0.05)
    assert kids, "the command line started no reading child"
    cli.send_signal(sig)
    cli.wait(timeout=60)
    assert cli.returncode in (128 + sig, -sig), cli.stderr.read()
    assert all(_gone(k) for k in kids)
    if sig == signal.SIGKILL:  # nothing of the command line ran: its folders go at the next run's first child
        assert guard.sweep(str(tmp)) >= 1
    assert left_in(tmp) == []


def test_animation_keys_over_the_budget_are_refused_from_the_accessors(separate):
    doc = json.loads((separate / "w.gltf").read_text())
    sampler = doc["animations"][0]["samplers"][0]
    doc["accessors"][sampler["output"]]["count"] = 30_000_000  # 480 MB of quaternions claimed
    path = separate / "keys.gltf"
    path.write_text(json.dumps(doc))
    with pytest.raises(UnreadableFileError, match="animation keys .* MB budget"):
        check_interchange(path)
