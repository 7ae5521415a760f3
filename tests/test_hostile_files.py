"""One bad file in a library is a skipped file (one line naming it), never the whole library; a small file that
would unpack to a huge clip is refused from its headers before any allocation (the memory budget,
``$SHAPESIG_MAX_FILE_MB``), so the process tree stays under 1 GB; any failure of a reader is one of our errors."""

import json
import shutil

import numpy as np
import pytest

from blender_shapesig.core.errors import ParseError, UnreadableFileError
from blender_shapesig.core.io import registry, sources
from blender_shapesig.core.io.smpl import load_smpl
from tests.helpers.hostile import BVH, left_in, run_cli

GOOD = ("07_01", "09_03")


def _library(folder):
    folder.mkdir()
    for name in GOOD:
        shutil.copy(BVH / f"{name}.bvh", folder / f"{name}.bvh")
    return folder


def _string_poses(path):
    np.savez(path, poses=np.array([["a"] * 72] * 10), mocap_framerate=120.0, trans=np.zeros((10, 3)))


def _million_frames(path):
    """1,000,000 frames of zeros (within the frame cap): about 0.6 MB compressed, 3.6 GB as float64 rotations."""
    np.savez_compressed(path, poses=np.zeros((1_000_000, 72)), mocap_framerate=120.0, trans=np.zeros((1_000_000, 3)))


@pytest.mark.parametrize("make", [_string_poses, _million_frames])
@pytest.mark.parametrize("command", ["rank", "index", "dedupe"])
def test_a_bad_npz_is_skipped_and_every_good_clip_ranked(tmp_path, command, make):
    lib = _library(tmp_path / "lib")
    make(lib / "bad.npz")
    assert (lib / "bad.npz").stat().st_size < 10 * 2 ** 20
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    args = {"rank": ["rank", BVH / "09_02.bvh", lib, "--no-cache"], "index": ["index", lib, "--cache", tmp_path / "c"],
            "dedupe": ["dedupe", lib, "--no-cache", "--out", tmp_path / "report", "--no-plots"]}[command]
    code, out, err, rss_mb = run_cli(args + ["--json", "--no-progress"], tmp)
    assert code == 0, err
    bad_lines = [ln for ln in err.splitlines() if "bad.npz" in ln]
    assert len(bad_lines) == 1 and "internal error" not in err and "Traceback" not in err, err
    assert ("not numbers" if make is _string_poses else "MB budget") in bad_lines[0]
    got = json.loads(out)
    if command == "rank":
        assert sorted(r["clip"] for r in got["results"]) == sorted(GOOD)
    elif command == "index":
        assert got["clips"] == len(GOOD)
    assert rss_mb < 1024, rss_mb
    assert left_in(tmp) == []


def test_the_budget_is_read_from_the_headers(tmp_path):
    """Refused from the .npy headers in the zip (no array loaded), and read when the budget allows it: the
    same file, the same rotations as a small copy of its first frames."""
    path = tmp_path / "long.npz"
    rng = np.random.default_rng(3)
    poses = np.zeros((20_000, 72))
    poses[:, :66] = rng.normal(scale=0.4, size=(20_000, 66))
    np.savez_compressed(path, poses=poses, mocap_framerate=60.0, trans=np.zeros((20_000, 3)))
    np.savez(tmp_path / "short.npz", poses=poses[:50], mocap_framerate=60.0, trans=np.zeros((50, 3)))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SHAPESIG_MAX_FILE_MB", "50")  # 20,000 x 22 x 72 x 2 bytes = 63 MB of rotations
        with pytest.raises(UnreadableFileError, match="over the 50 MB budget") as info:
            load_smpl(path)
        assert "\n" not in str(info.value)
    long, short = load_smpl(path), load_smpl(tmp_path / "short.npz")
    np.testing.assert_allclose(long.rotations[:50], short.rotations, atol=1e-12)
    R = long.rotations[::997]
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-9)


def test_any_failure_of_a_reader_is_one_parse_error(tmp_path, monkeypatch):
    path = tmp_path / "x.npz"
    _string_poses(path)

    def broken(spec):
        raise TypeError("ufunc 'isfinite' not supported\nfor the input types")

    monkeypatch.setitem(registry._READERS, ".npz", broken)
    with pytest.raises(ParseError) as info:
        sources.read(str(path))
    assert "\n" not in str(info.value) and str(path) in str(info.value) and "isfinite" in str(info.value)
