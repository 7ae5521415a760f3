"""Why Different on long takes: the per-step split of a DP path takes steps of any size (a 31-interval query
against a 5,000-interval take), ``fit_intervals`` finds a size the DP can take (the shorter curve denser for the
frame ratio, both sparser for the memory), and ``explain_clips`` resamples automatically and says so in one line.
Truths: the split sums to the DP energy; a clip against itself resampled alike costs nothing; a denser query (the
same curve) costs about what the comparison rate does."""

import pathlib
from dataclasses import replace

import numpy as np
import pytest

from blender_shapesig.core.clip.prepare import SMOOTH_SECONDS, prepare_clip
from blender_shapesig.core.elastic import elastic, explain
from blender_shapesig.core.elastic.elastic import DP_BYTES_PER_NODE, dp_problem, elastic_align
from blender_shapesig.core.elastic.explain import explain_clips, fit_intervals
from blender_shapesig.core.elastic.subsequence import path_costs
from blender_shapesig.core.errors import CurveError
from blender_shapesig.core.io import sources

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"


def _read(name, asf):
    return sources.read_one(sources.ClipSpec(str(ACC / f"{name}.amc"), asf=str(ACC / asf)))


@pytest.fixture(scope="module")
def clips():
    walk, run = _read("07_01", "07-walk.asf"), _read("09_02", "09-run.asf")
    n = 20000
    reps = -(-n // walk.frames)
    long = replace(walk, name="long", rotations=np.concatenate([walk.rotations] * reps)[:n],
                   root_translation=np.concatenate([walk.root_translation] * reps)[:n])
    return {"walk": walk, "run": run, "long": long}


def test_path_costs_split_a_path_with_long_steps(clips):
    """A 130-frame run against the 20,000-frame take: steps of up to 9 x 160 (the square table of the longest
    step, 160 x 160, was refused before); the pieces sum to the DP energy."""
    a = prepare_clip(clips["run"], smooth=SMOOTH_SECONDS)
    b = prepare_clip(clips["long"].select(clips["run"].bones), smooth=SMOOTH_SECONDS)
    _, _, info = elastic_align(a.rotations, b.rotations, return_info=True)
    assert info["max_step"][1] > 150
    costs = path_costs(a.rotations, b.rotations, info["nodes"], same_spacing=False)
    assert costs.min() >= -1e-12
    assert costs.sum() == pytest.approx(info["energy"], rel=1e-9)


def test_fit_intervals():
    # the ratio: the shorter curve denser, the longer one kept
    assert dp_problem(2, 4999) == "steps"
    m0, m1 = fit_intervals(2, 4999)
    assert m1 == 4999 and m0 > 2 and dp_problem(m0, m1) is None
    # the memory: both sparser by one factor
    cap = 100 * 2**20
    assert dp_problem(5000, 4000, max_bytes=cap) == "memory"
    m0, m1 = fit_intervals(5000, 4000, max_bytes=cap)
    assert DP_BYTES_PER_NODE * m0 * m1 <= cap and m0 * m1 > 0.7 * cap / DP_BYTES_PER_NODE
    assert m0 / m1 == pytest.approx(5000 / 4000, rel=0.01)
    # what fits stays
    assert fit_intervals(31, 300) == (31, 300)
    with pytest.raises(CurveError):
        dp_problem(0, 10)


def test_a_short_query_against_a_long_take_is_resampled_and_says_so(clips):
    query = clips["run"].crop(clips["run"].frame_start + 40, clips["run"].frame_start + 51)  # 12 frames
    out = explain_clips(query, clips["long"])
    assert sum(out["joints"].values()) == pytest.approx(1.0, abs=1e-12)
    assert sum(out["cost_over_time"]) == pytest.approx(out["energy"])
    assert out["fps"] > 30  # the query sampled more densely
    line = out["resampled"]
    assert "\n" not in line and line.startswith("Resampled to fit") and "09_02 at" in line and "long" not in line
    # the 130-frame run against the take fits at the comparison rate: nothing said
    assert "resampled" not in explain_clips(clips["run"], clips["long"])


def test_a_denser_query_costs_about_the_same(clips, monkeypatch):
    """Depth 2 and a step table capped at 30 weights: the 40-frame excerpt (9 intervals) against the walk (78) needs
    steps of 2 x 9 (56 weights), so the query is sampled more densely; the same curve, so the energy is within 10 %
    of the one at the comparison rate."""
    query = clips["run"].crop(clips["run"].frame_start, clips["run"].frame_start + 39)
    base = explain_clips(query, clips["walk"], depth=2)
    monkeypatch.setattr(elastic, "MAX_TABLE_ENTRIES", 30)
    out = explain_clips(query, clips["walk"], depth=2)
    assert "resampled" not in base and "09_02" in out["resampled"]
    assert len(out["cost_over_time"]) > len(base["cost_over_time"])
    assert out["energy"] == pytest.approx(base["energy"], rel=0.1)


def test_two_long_takes_resampled_alike_cost_nothing(clips, monkeypatch):
    """The walk against a copy of itself with a DP budget of 20 kB: both sampled sparser by one factor, the same
    curve on the same grid, so the energy is zero and both are named."""
    monkeypatch.setattr(explain, "EXPLAIN_MAX_BYTES", 20000)
    walk = clips["walk"]
    out = explain_clips(walk, replace(walk, name="copy"))
    assert len(out["cost_over_time"]) < 40 and out["energy"] == pytest.approx(0.0, abs=1e-9)
    assert "07_01 at" in out["resampled"] and "copy at" in out["resampled"]
