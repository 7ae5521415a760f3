"""The duration-ratio guard of blends (issue 31): sources lasting more than 8 times as long as each other are
refused in one line naming both durations, unless asked (``allow_long``; the CLI's ``--allow-long``, whose line
names the flag; the panel's line names none)."""

import pathlib
import subprocess
import sys

import pytest

from blender_shapesig.core.blend.make import MAX_DURATION_RATIO, check_durations
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.bvh import load_bvh

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def test_long_against_short_is_refused_unless_asked():
    walk = load_bvh(DATA / "acclaim" / "16_15.bvh")            # 471 frames at 120 fps: 3.9 s
    run = load_bvh(DATA / "bvh" / "09_02.bvh").crop(10, 40)   # 31 frames: 0.25 s
    ratio = ((walk.frames - 1) / walk.fps) / ((run.frames - 1) / run.fps)
    assert ratio > MAX_DURATION_RATIO
    with pytest.raises(ShapeSigError) as err:
        check_durations([walk, run])
    line = str(err.value)
    assert "\n" not in line and "3.9 s" in line and "0.2 s" in line and f"{ratio:.0f} times" in line
    assert "--" not in line and "allow long blends" in line
    check_durations([walk, run], allow_long=True)
    check_durations([walk, load_bvh(DATA / "bvh" / "09_02.bvh")])  # 3.9 s against 1.1 s: blended


def test_the_command_line_names_its_flag(tmp_path):
    out = subprocess.run([sys.executable, "-m", "blender_shapesig", "blend", str(DATA / "acclaim" / "16_15.bvh"),
                          str(DATA / "bvh" / "09_02.bvh"), "--range-b", "10:40", "--weight", "0.5",
                          "--out", str(tmp_path / "x.blend")], capture_output=True, text=True, timeout=600)
    assert out.returncode == 2 and "(--allow-long)" in out.stderr and len(out.stderr.strip().splitlines()) == 1
