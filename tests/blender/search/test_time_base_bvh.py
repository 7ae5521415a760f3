"""Time base on the Daz-friendly CMU BVH files (read through Blender's importer): automatic trimming of the rest
pose and ramp, the same walk at 120 / 60 / 30 fps, a 30 fps query ranked against 120 fps clips."""

import pathlib
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("bpy")

from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.search import rank_clips  # noqa: E402
from blender_shapesig.core.metrics import clip_distance  # noqa: E402
from blender_shapesig.core.clip.prepare import decimate_clip  # noqa: E402
from blender_shapesig.core.clip.trim import START_RATIO, step_ratios  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"

# frames kept by --trim auto (inclusive): the rest pose (frame 1) and the 5-frame ramp, and on 07_01 three
# frames that still move all joints at 1.5-2.1 times their median speed
KEPT = {"07_01": (9, 317), "07_02": (6, 330), "08_01": (6, 278), "09_02": (6, 131), "09_03": (6, 129),
        "13_32": (6, 337)}


def _read(name, **options):
    return sources.read_one(DATA / "bvh" / f"{name}.bvh", **options)


@pytest.fixture(scope="module")
def clips(addon):
    return {name: _read(name) for name in KEPT}


@pytest.mark.parametrize("name", sorted(KEPT))
def test_the_rest_pose_and_ramp_are_trimmed(clips, name):
    clip = clips[name]
    raw = _read(name, trim="none")
    assert raw.frame_start == 1 and raw.fps == 120.0
    assert clip.meta["trim"] == {"kept": KEPT[name], "read": (1, raw.frames)}
    assert (clip.frame_start, clip.frame_end) == KEPT[name]
    # the raw file starts with ramp steps far above the motion's; what is kept has none left
    assert step_ratios(raw.rotations)[0] > START_RATIO
    assert step_ratios(clip.rotations)[:8].max() < START_RATIO
    # an explicit start wins over the trimming
    assert _read(name, start=2).frame_start == 2


def _same_span(clip, step=4):
    n = (clip.frames - 1) // step * step + 1
    return replace(clip, rotations=clip.rotations[:n], root_translation=clip.root_translation[:n])


@pytest.mark.parametrize("metric,bound", [("sim3", 0.05), ("elastic", 0.15)])
def test_bvh_walks_and_their_decimated_copies(clips, metric, bound):
    runs = [clips["09_02"], clips["09_03"]]
    for name in ("07_01", "07_02", "08_01"):
        walk = _same_span(clips[name])
        near = min(clip_distance(walk, r, metric) for r in runs)
        for step in (2, 4):
            ratio = clip_distance(walk, decimate_clip(walk, step), metric) / near
            assert ratio < bound, (name, step, ratio)


@pytest.mark.parametrize("rerank", [0, 3])
def test_a_30_fps_walk_ranks_walks_first(clips, rerank):
    query = decimate_clip(clips["07_01"], 4)
    assert query.fps == 30.0
    library = [clips[n] for n in ("07_02", "08_01", "09_02", "09_03", "13_32")]
    ranked = rank_clips(query, library, metric="sim3", rerank=rerank)
    assert {r.name for r in ranked[:2]} == {"07_02", "08_01"}
    assert np.isfinite([r.distance for r in ranked]).all()
