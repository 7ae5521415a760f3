"""What happens in a clip (issue 41, ``local.description``): nine numbers of leg lengths (the body's travel from the
pelvis' path and from the ground under the lower foot, the pelvis' rise, the lower foot's clearance, the pelvis'
vertical speed), a term of the shortlist's final score. Checked in closed form on a body whose pelvis and ankle move
at known rates; on a real walk, where the ground seen from the body moves as the pelvis does (a planted foot does not
slide), also when the walk plays in place or backward (the clip reversed in time); and in the ranking: a walk played
in place finds forward walks before backward ones only with the term (docs/evaluation.md, "Short actions")."""

import numpy as np
import pytest

from blender_shapesig.core import rigs
from blender_shapesig.core.io import sources
from blender_shapesig.core.rigs.body import POINTS
from blender_shapesig.core.search.local import action, description, features as local

TIME = action.TIME


def _features(path):
    raw = sources.read_one(sources.ClipSpec(str(path), bone_map="none"))
    return local.features(rigs.apply_bone_map(raw, "auto"))


def _in_place(feat):
    """The clip played in place: the pelvis' horizontal path removed (as a game's in-place export)."""
    motion = np.array(feat["motion"], float)
    motion[:, :2] = 0.0
    return {**feat, "motion": motion}


def _backward(feat):
    """The clip reversed in time: the same steps taken backward (the path from the new first sample)."""
    motion = np.array(feat["motion"], float)[::-1]
    return {**feat, "pose": np.array(feat["pose"], float)[::-1], "motion": motion - motion[0]}


def test_closed_form_on_a_body_moving_at_known_rates():
    rate, n, H = 30.0, 61, 0.6  # 2 s; the pelvis rises H linearly
    t = np.arange(n) / rate
    side, back, u = -0.3, 1.2, 0.8  # leg lengths per second: sideways (x), backward (+y), the left ankle's backward
    motion = np.column_stack([side * t, back * t, H * t / t[-1], np.zeros(n)])
    pose = np.zeros((n, len(POINTS), 3))
    left, right = POINTS.index("ankle.L"), POINTS.index("ankle.R")
    pose[:, left, 2], pose[:, right, 2] = -1.0, -0.9  # the left foot is the lower one throughout
    pose[:, left, 1] = u * t  # it moves backward relative to the pelvis: the ground goes by forward at u
    got = description.describe({"pose": pose.reshape(n, -1), "motion": motion, "rate": np.float64(rate)})
    want = [TIME * np.hypot(side, back), -TIME * back, TIME * abs(side),  # the pelvis walks backward
            TIME * u, TIME * u, 0.0,  # the ground under the lower foot
            0.7 * H,  # percentiles 85 - 15 of a linear ramp
            0.35 * H,  # the lower ankle above its median height: the ramp's 85th percentile minus its middle
            TIME * H / t[-1]]  # the pelvis' vertical speed
    assert dict(zip(description.PARTS, got)) == pytest.approx(dict(zip(description.PARTS, want)), abs=1e-6)


def test_a_real_walk_travels_as_its_feet_say_also_in_place_and_backward(data_dir):
    walk = _features(data_dir / "bvh" / "07_01.bvh")
    d = dict(zip(description.PARTS, description.describe(walk)))
    # a planted foot does not slide: the ground goes by as fast as the pelvis goes (the median, over the stance
    # phases); forward on average, less than the pelvis (the lower foot changes as the steps change)
    assert d["ground_speed"] == pytest.approx(d["speed"], rel=0.1)
    assert d["forward"] > 0.3 and 0.5 * d["forward"] < d["ground_forward"] < d["forward"]
    assert d["rise"] < 0.1 and d["clearance"] < 0.05  # a walk stays on the ground
    p = dict(zip(description.PARTS, description.describe(_in_place(walk))))
    assert p["speed"] == p["forward"] == p["sideways"] == 0.0  # no root motion ...
    assert p["ground_forward"] == pytest.approx(d["ground_forward"])  # ... the feet still say where the body goes
    b = dict(zip(description.PARTS, description.describe(_backward(walk))))
    assert b["forward"] == pytest.approx(-d["forward"], rel=1e-5)
    assert b["ground_forward"] == pytest.approx(-d["ground_forward"], rel=1e-5)


def test_a_walk_in_place_finds_forward_walks_before_backward_ones_only_with_the_term(data_dir, monkeypatch):
    names = ("07_01", "07_02", "09_02", "09_03", "13_32")
    clips = {n: _features(data_dir / "bvh" / f"{n}.bvh") for n in names}
    clips["16_15"] = _features(data_dir / "acclaim" / "16_15.bvh")
    library = {}
    for n, f in clips.items():
        library[n] = f
        library[n + " backward"] = _backward(f)
        library[n + " backward in place"] = _in_place(_backward(f))
    entries = [local.entry_from_features(f) for f in library.values()]
    query = local.entry_from_features(_in_place(_features(data_dir / "bvh" / "08_01.bvh")))
    forward_walks = {"07_01", "07_02", "16_15"}

    def first_three(weight):
        monkeypatch.setattr(description, "WEIGHT", weight)
        return [list(library)[i] for i in local.search(query, entries)][:3]

    assert set(first_three(description.WEIGHT)) == forward_walks
    without = first_three(0.0)
    assert set(without) != forward_walks and any("backward" in n for n in without)
