"""core.local_search (issue 29): its pieces against independent computations (the level-2 log-signature of the
package's tensor code, a plain DTW recursion, a brute-force Chamfer distance), its invariances (heading, body size)
and what it is for on the bundled clips: the same take in another format is nearest, a clip cut by 10 % at either end
finds its source first."""

import dataclasses
import itertools

import numpy as np
import pytest

from blender_shapesig.core.search.local import features as ls
from blender_shapesig.core.search.local import dtw as local_dtw
from blender_shapesig.core import rigs
from blender_shapesig.core.signatures import signatures
from tests.helpers.local_entries import entry
from blender_shapesig.core.io import sources
from blender_shapesig.core.errors import ShapeSigError


def _reference_dtw(a, b, free_a=0, free_b=0):
    """Every warping path's cost by the textbook recursion on a full matrix, open ends by explicit minima."""
    n, m = len(a), len(b)
    C = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    best = np.inf
    for i0, j0 in itertools.product(range(free_a + 1), range(free_b + 1)):
        if i0 and j0:
            continue  # a path skips the start of one sequence only
        D = np.full((n + 1, m + 1), np.inf)
        D[i0, j0] = 0.0
        for i in range(i0 + 1, n + 1):
            for j in range(j0 + 1, m + 1):
                D[i, j] = C[i - 1, j - 1] + min(D[i - 1, j], D[i, j - 1], D[i - 1, j - 1])
        ends = [D[n, j] for j in range(m - free_b, m + 1)] + [D[i, m] for i in range(n - free_a, n + 1)]
        best = min(best, min(ends))
    return np.sqrt(best)


@pytest.mark.parametrize("n,m,free_a,free_b", [(12, 12, 0, 0), (9, 15, 0, 0), (14, 10, 2, 3), (11, 13, 0, 4)])
def test_dtw_matches_the_textbook_recursion(n, m, free_a, free_b):
    rng = np.random.default_rng(n * 100 + m)
    a, b = rng.standard_normal((n, 4)), rng.standard_normal((m, 4))
    want = _reference_dtw(a, b, free_a, free_b)
    assert ls.dtw(a, b, None, free_a, free_b) == pytest.approx(want, rel=1e-12)
    assert local_dtw._dtw_numpy(a, b, -1, free_a, free_b) == pytest.approx(want, rel=1e-12)
    # the compiled kernel's code, run by Python
    assert local_dtw._dtw_loops(a, b, -1, free_a, free_b) == pytest.approx(want, rel=1e-12)
    band = ls._band(n, m)
    want_band = local_dtw._dtw_numpy(a, b, band, free_a, free_b)
    assert local_dtw._dtw_loops(a, b, band, free_a, free_b) == pytest.approx(want_band, rel=1e-12)


def test_dtw_band_only_removes_paths():
    rng = np.random.default_rng(3)
    a, b = rng.standard_normal((30, 3)), rng.standard_normal((40, 3))
    free = ls.dtw(a, b)
    banded = [ls.dtw(a, b, w) for w in (1, 3, 8, 40)]
    assert all(x >= free - 1e-12 for x in banded)
    assert banded == sorted(banded, reverse=True)
    assert banded[-1] == pytest.approx(free, rel=1e-12)
    assert ls.dtw(a, a, 1) == 0.0


def test_the_shortlist_at_once_equals_one_dtw_at_a_time():
    """``_dtw_many`` (every candidate's anti-diagonals together) gives ``_dtw_numpy``'s numbers exactly, and both
    agree with the textbook recursion: lengths from 1 to 40, bands, no band, open ends."""
    rng = np.random.default_rng(11)
    for trial in range(25):
        n = int(rng.integers(1, 30))
        bs = [rng.standard_normal((int(rng.integers(1, 40)), 3)) for _ in range(6)]
        a = rng.standard_normal((n, 3))
        bands = [-1 if trial % 3 == 0 else ls._band(n, len(b)) for b in bs]
        fa = min(int(rng.integers(0, 5)), n - 1)
        fbs = [min(int(rng.integers(0, 5)), len(b) - 1) for b in bs]
        got = local_dtw._dtw_many(a, bs, bands, [fa] * len(bs), fbs)
        want = [local_dtw._dtw_numpy(a, b, w, fa, fb) for b, w, fb in zip(bs, bands, fbs)]
        assert np.array_equal(got, want)
        if trial % 3 == 0:
            assert got[0] == pytest.approx(_reference_dtw(a, bs[0], fa, fbs[0]), rel=1e-12)


def test_rerank_is_the_same_with_and_without_the_compiled_kernel(monkeypatch):
    rng = np.random.default_rng(12)
    q = entry(sequence=rng.standard_normal((20, 6)).astype(np.float16))
    cands = [entry(sequence=rng.standard_normal((int(rng.integers(5, 30)), 6)).astype(np.float16)) for _ in range(7)]
    monkeypatch.setattr(local_dtw, "_kernel", lambda: None)
    batch = ls.rerank(q, cands)
    monkeypatch.setattr(local_dtw, "_kernel", lambda: local_dtw._dtw_loops)  # the compiled kernel's code, run by Python
    monkeypatch.setattr(local_dtw, "kernel_ready", lambda: True)
    one_by_one = ls.rerank(q, cands)
    assert np.allclose(batch, one_by_one, rtol=1e-12, atol=0)


def test_a_shortlist_does_not_load_the_compiled_kernel():
    """In a fresh process with numba imported (as in Blender), a shortlist's DTW runs by numpy until the compiled
    kernel has run for something else (its first call loads numba's machinery: most of a first click)."""
    pytest.importorskip("numba")
    import subprocess
    import sys

    code = """
import numba, numpy as np
from blender_shapesig.core.search.local import features as ls, dtw as local_dtw
from blender_shapesig.core.search.local.entry import LocalEntry
rng = np.random.default_rng(1)
entry = lambda sequence: LocalEntry(np.zeros((1, 1)), sequence, np.zeros(10))
q = entry(rng.standard_normal((20, 6)))
cands = [entry(rng.standard_normal((25, 6))) for _ in range(5)]
before = ls.rerank(q, cands)
assert not local_dtw.kernel_ready()
local_dtw.dtw(q.sequence, cands[0].sequence, 5)
assert local_dtw.kernel_ready()
assert np.allclose(ls.rerank(q, cands), before, rtol=1e-12, atol=0)
print("ok")
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.stdout.strip() == "ok", out.stderr[-2000:]


def test_levy_areas_are_level_two_of_the_log_signature():
    rng = np.random.default_rng(5)
    X = np.cumsum(rng.standard_normal((40, 4)), axis=0)
    starts, w = np.array([0, 7, 20]), 15
    areas = ls._levy_areas(X, starts, w)
    for k, s in enumerate(starts):
        want = signatures.path_log_signature(X[s:s + w], 2, method="numpy")  # Lyndon basis: 4 letters, then [i,j]
        assert np.allclose(want[:4], X[s + w - 1] - X[s], atol=1e-12)
        assert np.allclose(areas[k], want[4:], atol=1e-12)


def test_first_stage_is_the_symmetric_mean_of_nearest_window_distances():
    rng = np.random.default_rng(7)
    q = entry(windows=rng.standard_normal((5, 6)).astype(np.float16))
    lib = [entry(windows=rng.standard_normal((k, 6)).astype(np.float16)) for k in (1, 4, 9)] + [q]
    got = ls.first_stage(q, lib)
    A = q.windows.astype(np.float64)
    for e, d in zip(lib, got):
        B = e.windows.astype(np.float64)
        D = np.sqrt(((A[:, None] - B[None]) ** 2).sum(-1))
        assert d == pytest.approx(0.5 * (D.min(1).mean() + D.min(0).mean()), abs=1e-5)
    assert got[-1] == pytest.approx(0.0, abs=1e-5)
    assert np.allclose(ls.first_stage(q, ls.stack(lib)), got)


# ------------------------------------------------------------------------------------------------- real clips

def _raw(path, asf=None):
    return sources.read_one(sources.ClipSpec(str(path), asf=None if asf is None else str(asf), bone_map="none"))


def _entry(raw, crop=None):
    c = raw
    if crop is not None:
        cut = int(round(0.1 * c.frames))
        c = c.crop(c.frame_start + cut, None) if crop == "start" else c.crop(None, c.frame_end - cut)
    return ls.index_entry(rigs.apply_bone_map(c, "auto"))


@pytest.fixture(scope="module")
def library(data_dir):
    a = data_dir / "acclaim"
    clips = {
        "16_15.amc": _raw(a / "16_15.amc", a / "16.asf"), "16_15.bvh": _raw(a / "16_15.bvh"),
        "07_01.amc": _raw(a / "07_01.amc", a / "07-walk.asf"), "07_02.amc": _raw(a / "07_02.amc", a / "07-walk.asf"),
        "09_02.amc": _raw(a / "09_02.amc", a / "09-run.asf"), "09_03.amc": _raw(a / "09_03.amc", a / "09-run.asf"),
        "07_01.bvh": _raw(data_dir / "bvh" / "07_01.bvh"), "07_02.bvh": _raw(data_dir / "bvh" / "07_02.bvh"),
        "08_01.bvh": _raw(data_dir / "bvh" / "08_01.bvh"),
        "09_02.bvh": _raw(data_dir / "bvh" / "09_02.bvh"), "13_32.bvh": _raw(data_dir / "bvh" / "13_32.bvh"),
        "02_03.bvh": _raw(data_dir / "cross_rig" / "02_03.bvh"), "002_03.bvh": _raw(data_dir / "cross_rig" / "002_03.bvh"),
    }
    return clips, {n: _entry(c) for n, c in clips.items()}


def test_heading_and_body_size_do_not_matter(library):
    raw = library[0]["07_01.amc"]
    base = ls.features(rigs.apply_bone_map(raw, "auto"))
    # the whole take turned 70 degrees about the vertical and played by a body 1.8 times as large
    c, s = np.cos(1.2), np.sin(1.2)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    root = raw.meta.get("rest_heads")
    meta = dict(raw.meta, rest_heads={b: tuple(1.8 * np.asarray(h)) for b, h in root.items()},
                rest_tails={b: tuple(1.8 * np.asarray(t)) for b, t in raw.meta["rest_tails"].items()})
    R = raw.rotations.copy()
    root_index = raw.bones.index(raw.root_bone)
    R[:, root_index] = turn[None] @ R[:, root_index]
    other = dataclasses.replace(raw, rotations=R, root_translation=1.8 * raw.root_translation @ turn.T, meta=meta)
    moved = ls.features(rigs.apply_bone_map(other, "auto"))
    assert np.allclose(moved["pose"], base["pose"], atol=1e-9)
    assert np.allclose(moved["motion"], base["motion"], atol=1e-9)


def test_same_take_in_another_format_or_rig_is_nearest(library):
    names = list(library[1])
    entries = [library[1][n] for n in names]
    for a, b in (("16_15.amc", "16_15.bvh"), ("02_03.bvh", "002_03.bvh"), ("002_03.bvh", "02_03.bvh")):
        d = ls.first_stage(library[1][a], entries)
        d[names.index(a)] = np.inf
        assert names[int(np.argmin(d))] == b, (a, dict(zip(names, np.round(d, 3))))
    assert ls.first_stage(library[1]["16_15.amc"], [library[1]["16_15.bvh"]])[0] < 0.05
    # the Daz conversion of walk 07_01 is nearer than every run and jump (a walk of the same subject, 07_02, may be
    # nearer still: RESULTS.md, "same take across formats")
    d = dict(zip(names, ls.first_stage(library[1]["07_01.amc"], entries)))
    assert d["07_01.bvh"] < min(d[n] for n in ("09_02.amc", "09_03.amc", "09_02.bvh", "13_32.bvh", "02_03.bvh"))


def test_the_search_puts_the_same_take_in_another_format_first(library):
    """Walks 07_01 and 07_02 of one subject, each as the CMU original (AMC) and its Daz BVH conversion: the
    conversion's posture differs more from the original than the subject's other walk does (RESULTS.md), so the
    two stages alone rank the other walk of the same format first; the twin rule (``take.twin_first``) ranks the
    same take first. The runs 09_02/09_03 of the Daz conversion are not asked (the converter's artefact)."""
    pairs = (("07_01.amc", "07_01.bvh"), ("07_02.amc", "07_02.bvh"), ("16_15.amc", "16_15.bvh"),
             ("02_03.bvh", "002_03.bvh"), ("09_02.amc", "09_02.bvh"))
    for a, b in pairs + tuple((y, x) for x, y in pairs if x != "09_02.amc"):
        others = [n for n in library[1] if n != a]
        entries = [library[1][n] for n in others]
        order = ls.search(library[1][a], entries)
        assert others[order[0]] == b, (a, [others[k] for k in order[:3]])
    # without the twin rule, the other walk of the same format is first (what the rule is for)
    others = [n for n in library[1] if n != "07_01.amc"]
    entries = [library[1][n] for n in others]
    q = library[1]["07_01.amc"]
    d1 = ls.first_stage(q, entries)
    head = list(np.argsort(d1, kind="stable")[:ls.SHORTLIST])
    score = ls.combine(d1[head], ls.rerank(q, [entries[k] for k in head]))
    assert others[head[int(np.argmin(score))]] == "07_02.amc"


@pytest.mark.parametrize("crop", ["start", "end"])
def test_a_clip_cut_by_a_tenth_finds_its_source_first(library, crop):
    clips, full = library
    names = list(full)
    entries = [full[n] for n in names]
    stacked = ls.stack(entries)
    for n in ("07_01.amc", "07_02.amc", "09_02.amc", "09_03.amc", "08_01.bvh", "13_32.bvh", "02_03.bvh"):
        order = ls.search(_entry(clips[n], crop), entries, library=stacked)
        assert names[order[0]] == n, (n, crop, [names[i] for i in order[:3]])


def test_index_entry_is_compact_and_refuses_clips_outside_the_comparison_space(library):
    clips, full = library
    assert all(ls.entry_bytes(e) <= 50 * 1024 for e in full.values())
    assert all(e.windows.dtype == np.float16 and e.windows.shape[1] == ls.DIM for e in full.values())
    with pytest.raises(ShapeSigError, match="not mapped to body joints .map its bones in the Bone Map panel"):
        ls.features(clips["07_01.amc"])
    # a long clip keeps its entry under the cap (a longer hop, a lower rate for the sequence)
    T = 60 * int(ls.RATE)
    feat = {"pose": np.zeros((T, 3 * len(ls.POINTS))), "motion": np.zeros((T, 4)), "rate": np.float64(ls.RATE)}
    assert ls.entry_bytes(ls.entry_from_features(feat)) <= 50 * 1024


def test_a_rig_without_foot_bones_measures_its_leg_to_the_shin_tail(data_dir):
    """A stylised rig whose feet are IK controls (Blender's godotman: no foot in the leg chain) still has legs:
    hip to ankle is the thigh's head to the shin's tail. On the Acclaim 07_01 rig (the shin's tail is the foot's
    head) the joints above the feet land where the whole rig puts them, and the leg length is the same."""
    spec = sources.ClipSpec(str(data_dir / "acclaim" / "07_01.amc"), asf=str(data_dir / "acclaim" / "07-walk.asf"))
    whole = sources.read_one(spec)
    raw = sources.read_one(dataclasses.replace(spec, bone_map="none"))
    no_feet = [j for j in whole.bones if not j.startswith(("foot.", "toe."))]
    part = whole.select(no_feet)
    part.meta = dict(whole.meta, bone_map={j: b for j, b in whole.meta["bone_map"].items() if j in no_feet})
    a, b = ls.rig_positions(whole)[0], ls.rig_positions(part)[0]
    assert set(b) == set(no_feet)
    for j in b:
        np.testing.assert_allclose(b[j], a[j], atol=1e-9)
    by_joint = whole.meta["bone_map"]
    assert rigs.leg_length(raw, {j: by_joint[j] for j in no_feet}) == pytest.approx(rigs.leg_length(raw, by_joint))


def test_held_distance_is_the_query_side_of_the_first_stage(library):
    full = library[1]
    q = full["07_01.amc"]
    cands = [full["07_01.bvh"], full["09_02.amc"], full["07_01.amc"]]
    got = ls.held_distances(q, cands)
    A = np.asarray(q.windows, np.float64)
    for c, h in zip(cands, got):
        B = np.asarray(c.windows, np.float64)
        near = [min(np.linalg.norm(a - b) for b in B) for a in A]
        assert h == pytest.approx(np.mean(near), rel=1e-3, abs=1e-3)
        # the first stage is the mean of both sides
        back = ls.held_distances(c, [q])[0]
        assert ls.first_stage(q, [c])[0] == pytest.approx(0.5 * (h + back), rel=1e-3, abs=1e-3)
    assert got[2] == pytest.approx(0.0, abs=1e-3)
