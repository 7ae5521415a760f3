"""Hostile files in a clip library (core.io.files, core.io.sources.discover, the command line): a FIFO, a link to
/dev/zero, a dangling and a self-looping link named *.bvh are never opened, skipped and reported once; files over
the size, line and frame caps are refused with one line before they are read whole.

In-process reads of the hostile files run under an alarm (a reader that opened the FIFO would wait forever: the
alarm turns that into a failure); the command-line runs use a subprocess timeout as the same guard. The
assertions are on the outcome (what is ranked, what is skipped, the one line)."""

import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys

import pytest

from blender_shapesig.core.io import files, sources
from blender_shapesig.core.errors import ParseError, ShapeSigError, UnreadableFileError
from tests.helpers.hostile import hostile_library

ROOT = pathlib.Path(__file__).resolve().parents[3]
BVH = ROOT / "tests" / "data" / "bvh"
ACC = ROOT / "tests" / "data" / "acclaim"
REAL = ("07_01", "07_02", "09_02")
HOSTILE = ("d.bvh", "l.bvh", "x.bvh", "z.bvh")
GUARD = 120  # seconds: only a hang reaches it


@pytest.fixture
def alarm():
    """Fail instead of hanging: SIGALRM after GUARD seconds raises in the blocked call."""

    def ring(_sig, _frame):
        raise TimeoutError("hung on a hostile file")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(GUARD)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture
def library(tmp_path):
    """Three real CMU takes, a FIFO x.bvh, a link to /dev/zero z.bvh, a dangling link d.bvh, a looping l.bvh."""
    return hostile_library(tmp_path / "lib", REAL)


def _one_line(exc):
    text = str(exc)
    assert "\n" not in text and text
    return text


def test_discover_takes_regular_files_only_and_lists_the_others(library, alarm):
    skipped = []
    found = sources.discover(library, skipped=skipped)
    assert [pathlib.Path(p).stem for p in found] == list(REAL)
    reasons = {pathlib.Path(e.path).name: _one_line(e) for e in skipped}
    assert sorted(reasons) == list(HOSTILE)
    assert all(isinstance(e, UnreadableFileError) for e in skipped)
    assert "named pipe (FIFO)" in reasons["x.bvh"] and "device" in reasons["z.bvh"]
    assert "link to a missing file" in reasons["d.bvh"] and "loops" in reasons["l.bvh"]
    assert files.skipped_line(skipped) == ("skipped 4 files that are not regular files or cannot be read: "
                                           "d.bvh, l.bvh, x.bvh, z.bvh")
    # a link to a regular file is a clip like any other
    os.symlink(library / "07_01.bvh", library / "link.bvh")
    assert str(library / "link.bvh") in sources.discover(library)


@pytest.mark.parametrize("name", HOSTILE)
def test_reading_or_keying_a_hostile_file_is_one_line(library, alarm, name):
    path = library / name
    for call in (lambda: sources.read(path), lambda: sources.file_key(path), lambda: sources.ClipSpec(str(path)).check(),
                 lambda: files.read_bytes(path, "BVH")):
        with pytest.raises(UnreadableFileError) as err:
            call()
        assert _one_line(err.value).startswith(str(path))


def test_library_items_skip_them(library, alarm):
    items = sources.library(library)
    assert [it.name for it in items] == list(REAL)


def _bvh_header(frames):
    head = (BVH / "09_02.bvh").read_text().split("MOTION")[0]
    return head + f"MOTION\nFrames: {frames}\nFrame Time: 0.008333\n"


def test_a_500_mb_bvh_is_refused_by_its_size_before_reading(tmp_path):
    path = tmp_path / "huge.bvh"
    path.write_text(_bvh_header(5_000_000))
    os.truncate(path, 500 * 2 ** 20)  # sparse: no disk used
    with pytest.raises(UnreadableFileError) as err:
        sources.read(path)
    assert "500 MB, over the 128 MB limit" in _one_line(err.value) and files.MAX_FILE_MB_ENV in str(err.value)
    skipped = []
    assert sources.discover(tmp_path, skipped=skipped) == [] and len(skipped) == 1


def test_the_peak_memory_of_refusing_a_500_mb_bvh_is_small(tmp_path):
    path = tmp_path / "huge.bvh"
    path.write_text(_bvh_header(5_000_000))
    os.truncate(path, 500 * 2 ** 20)
    # the peak of this process image: /proc's VmHWM (ru_maxrss would count the forking pytest's size too)
    code = ("import sys\nfrom blender_shapesig.core.io import sources\n"
            "try:\n    sources.read(sys.argv[1])\nexcept Exception as exc:\n    print(type(exc).__name__)\n"
            "print(next(ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM')))\n")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, cwd=ROOT,
                         timeout=GUARD, check=True).stdout.split()
    assert out[0] == "UnreadableFileError"
    assert int(out[1]) < 400 * 1024  # kB: the interpreter with numpy, not the file (reading it costs ~6 GB)


def test_size_cap_is_overridable_and_checked(tmp_path, monkeypatch):
    path = tmp_path / "a.bvh"
    shutil.copy(BVH / "09_02.bvh", path)
    monkeypatch.setenv(files.MAX_FILE_MB_ENV, "0.1")  # 09_02.bvh is 171 kB
    with pytest.raises(UnreadableFileError, match="is 0.17 MB, over the 0.1 MB limit"):
        sources.read(path)
    monkeypatch.setenv(files.MAX_FILE_MB_ENV, "1")
    assert sources.read_one(path).frames > 100
    monkeypatch.setenv(files.MAX_FILE_MB_ENV, "lots")
    with pytest.raises(ShapeSigError, match="SHAPESIG_MAX_FILE_MB must be a positive number"):
        sources.read(path)
    monkeypatch.delenv(files.MAX_FILE_MB_ENV)
    monkeypatch.setenv(files.MAX_BLEND_MB_ENV, "0.001")
    blend = tmp_path / "b.blend"
    blend.write_bytes(b"BLENDER" + bytes(2000))
    assert "over the 0.001 MB limit for .blend files" in files.file_problem(blend)
    assert files.file_problem(path) is None  # the .blend cap is the .blend files' only


def test_one_huge_line_is_refused_after_one_block(tmp_path):
    path = tmp_path / "line.bvh"
    path.write_text(_bvh_header(10))
    with open(path, "a") as fh:
        fh.write("1 " * (3 * 2 ** 20))  # one 6 MB line
    with pytest.raises(UnreadableFileError, match="a line longer than 1,048,576 bytes") as err:
        sources.read(path)
    _one_line(err.value)
    # lines ended by CR alone are lines too (a CR-only file of short lines is read)
    cr = tmp_path / "cr.bvh"
    cr.write_bytes((BVH / "09_02.bvh").read_bytes().replace(b"\r\n", b"\n").replace(b"\n", b"\r"))
    assert sources.read_one(cr, trim="none").frames == sources.read_one(BVH / "09_02.bvh", trim="none").frames


def test_frame_cap_from_the_bvh_header_and_its_lines(tmp_path, monkeypatch):
    data = (BVH / "09_02.bvh").read_text().split("MOTION")[1].strip().splitlines()[2:]
    claims = tmp_path / "claims.bvh"
    claims.write_text(_bvh_header(5_000_000) + "\n".join(data) + "\n")
    with pytest.raises(ParseError, match="5,000,000 frames, over the 1,000,000-frame limit") as err:
        sources.read(claims)
    assert ":" + str(_bvh_header(5_000_000).count("\n") - 1) + ":" in _one_line(err.value)  # the Frames line
    monkeypatch.setenv(files.MAX_FRAMES_ENV, "100")
    holds = tmp_path / "holds.bvh"  # the header says 10, but every data line is a frame (as Blender reads it)
    holds.write_text(_bvh_header(10) + "\n".join(data) + "\n")
    with pytest.raises(ParseError, match=f"{len(data):,} frames, over the 100-frame limit"):
        sources.read(holds)
    monkeypatch.setenv(files.MAX_FRAMES_ENV, str(len(data)))
    assert sources.read_one(holds, trim="none").frames == len(data)


def test_frame_cap_while_parsing_an_amc(tmp_path, monkeypatch):
    for name in ("09-run.asf", "09_02.amc"):
        shutil.copy(ACC / name, tmp_path / name)
    frames = sources.read_one(tmp_path / "09_02.amc", trim="none").frames
    monkeypatch.setenv(files.MAX_FRAMES_ENV, str(frames - 1))
    with pytest.raises(ParseError, match=f"more than {frames - 1:,} frames, over the") as err:
        sources.read(tmp_path / "09_02.amc")
    _one_line(err.value)
    # and before the text is split: more lines than 2 frames (and a header) can take
    monkeypatch.setenv(files.MAX_FRAMES_ENV, "2")
    padded = tmp_path / "padded.amc"
    padded.write_text("#\n" * 20_000 + (tmp_path / "09_02.amc").read_text())
    with pytest.raises(ParseError, match="lines, more than the frame limit allows") as err:
        sources.read(padded, asf=tmp_path / "09-run.asf")
    _one_line(err.value)


# ---------------------------------------------------------------------------------------- command line

def _cli(*args, cache):
    env = dict(os.environ, SHAPESIG_CACHE_DIR=str(cache))
    return subprocess.run([sys.executable, "-m", "blender_shapesig", *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=GUARD)


def _skip_line(stderr):
    lines = [ln for ln in stderr.splitlines() if "skipped" in ln]
    assert len(lines) == 1, stderr
    return lines[0]


def test_cli_rank_ranks_the_real_clips_and_reports_four_skipped(library, tmp_path):
    clips = sorted(library.iterdir())  # what a shell's *.bvh gives
    got = _cli("rank", library / "07_01.bvh", *clips, "--json", "--no-progress", cache=tmp_path / "c")
    assert got.returncode == 0, got.stderr
    out = json.loads(got.stdout)
    assert [r["clip"] for r in out["results"]][0] == "07_01"
    assert sorted(r["clip"] for r in out["results"]) == sorted(REAL)
    assert len(out["skipped"]) == 4 and all(s.startswith(str(library)) for s in out["skipped"])
    assert _skip_line(got.stderr).endswith("skipped 4 files that are not regular files or cannot be read: "
                                           "d.bvh, l.bvh, x.bvh, z.bvh")


def test_cli_dedupe_finishes_and_reports_four_skipped(library, tmp_path):
    got = _cli("dedupe", library, "--out", tmp_path / "report", "--no-plots", "--json", "--no-progress",
               "--k", "2", cache=tmp_path / "c")
    assert got.returncode == 0, got.stderr
    out = json.loads(got.stdout)
    assert out["clips"] == 3
    assert sorted(pathlib.Path(s.split(":")[0]).name for s in out["skipped"]) == list(HOSTILE)
    assert "skipped 4 files" in _skip_line(got.stderr)


def test_cli_matrix_and_evaluate_skip_them(library, tmp_path):
    got = _cli("matrix", *sorted(library.iterdir()), "--out", tmp_path / "m", "--no-figures", "--json",
               "--no-progress", "--workers", "1", cache=tmp_path / "c")
    assert got.returncode == 0, got.stderr
    out = json.loads(got.stdout)
    assert len(out["clips"]) == 3 and len(out["skipped"]) == 4 and "skipped 4 files" in _skip_line(got.stderr)
    index = tmp_path / "index.csv"
    index.write_text("file,label\n07_01.bvh,walk\n07_02.bvh,walk\n09_02.bvh,run\nx.bvh,run\nz.bvh,walk\n")
    shutil.copy(BVH / "09_03.bvh", library / "09_03.bvh")
    index.write_text(index.read_text() + "09_03.bvh,run\n")
    got = _cli("evaluate", "--index", index, "--data", library, "--out", tmp_path / "e", "--metrics", "sim3",
               "--workers", "1", "--no-figures", "--json", "--no-progress", cache=tmp_path / "c")
    assert got.returncode == 0, got.stderr
    out = json.loads(got.stdout)
    assert out["clips"] == 4 and len(out["skipped"]) == 2 and "skipped 2 files" in _skip_line(got.stderr)


def test_cli_a_single_named_hostile_clip_is_exit_2_with_one_line(library, tmp_path):
    for name in HOSTILE:
        got = _cli("distance", library / name, library / "07_01.bvh", cache=tmp_path / "c")
        assert got.returncode == 2 and got.stdout == ""
        assert len(got.stderr.strip().splitlines()) == 1
        assert "not a regular file" in got.stderr or "symbolic link" in got.stderr
        got = _cli("rank", library / name, library / "07_01.bvh", cache=tmp_path / "c")
        assert got.returncode == 2 and got.stderr.startswith(f"blender_shapesig: error: {library / name}: ")
