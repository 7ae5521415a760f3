"""a blend of a 120 fps and a 30 fps clip lasts the weighted average of its sources' durations in
seconds, through the real command line (``blend`` writes a .blend; the actions are read back in a fresh process).

The 30 fps clip is a real one: the Daz BVH run 09_02 with every 4th frame kept and ``Frame Time`` 1/30 s (what a
30 fps export of the take holds). Both sources are trimmed automatically (``--trim auto``, the default): the
durations are those of the clips the command blends, read here through the same front door (``core.io.sources``).
"""

import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BVH = ROOT / "tests" / "data" / "bvh"
WEIGHTS = (0.25, 0.5, 0.75)  # --inbetweens 3


def decimated_bvh(src, dst, step):
    """A copy of the BVH file ``src`` keeping every ``step``-th frame from the first, its Frame Time times step."""
    lines = pathlib.Path(src).read_text().splitlines()
    m = next(i for i, line in enumerate(lines) if line.strip() == "MOTION")
    frame_time = float(lines[m + 2].split(":")[1])
    motion = [line for line in lines[m + 3:] if line.strip()][::step]
    head = lines[:m + 1] + [f"Frames: {len(motion)}", f"Frame Time: {frame_time * step:.8f}"]
    pathlib.Path(dst).write_text("\n".join(head + motion) + "\n")
    return dst


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _python(*args, timeout=600):
    p = subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, env=_env(),
                       cwd=str(ROOT), timeout=timeout)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout


_READ_BACK = """
import json, sys
from blender_shapesig.core.io.sources import read
out = []
for name in sys.argv[2:]:
    clip = read(sys.argv[1] + "#" + name, bone_map="none", trim="none")[0]
    out.append({"name": name, "frames": clip.frames, "fps": clip.fps})
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def blended(tmp_path_factory):
    pytest.importorskip("bpy")
    from blender_shapesig.core.io.sources import read

    tmp = tmp_path_factory.mktemp("blend_rates")
    walk = BVH / "07_01.bvh"  # 120 fps
    run = decimated_bvh(BVH / "09_02.bvh", tmp / "09_02_30fps.bvh", 4)  # 30 fps
    a, b = read(str(walk))[0], read(str(run))[0]  # trimmed as the command trims them (--trim auto)
    out = tmp / "walk_run.blend"
    report = json.loads(_python("-m", "blender_shapesig", "blend", walk, run, "--inbetweens", "3", "--out", out,
                                "--json", "--no-progress"))
    back = json.loads(_python("-c", _READ_BACK, out, *report["actions"]))
    return a, b, report, back


def test_the_sources_have_their_own_rates(blended):
    a, b, _, _ = blended
    assert (a.fps, b.fps) == (120.0, pytest.approx(30.0))
    assert a.meta["trim"]["kept"][0] > 1  # the Daz rest pose and ramp were trimmed, as the command does


def test_a_120_and_30_fps_blend_lasts_the_weighted_average_in_seconds(blended):
    a, b, report, back = blended
    da, db = (a.frames - 1) / a.fps, (b.frames - 1) / b.fps
    assert abs(da - db) > 0.5  # a walk and a run of clearly different lengths: the weights show
    assert report["weights"] == pytest.approx(list(WEIGHTS))
    for w, seconds, fps, frames, got in zip(WEIGHTS, report["seconds"], report["fps"], report["frames"], back):
        want = (1 - w) * da + w * db
        assert fps == 120.0  # the higher of the sources' rates
        assert seconds == pytest.approx(want, abs=0.5 / fps)
        # the action as saved, read back in a fresh process: its frames at its recorded rate
        assert (got["frames"], got["fps"]) == (frames, pytest.approx(fps))
        assert (got["frames"] - 1) / got["fps"] == pytest.approx(want, abs=0.5 / fps)
