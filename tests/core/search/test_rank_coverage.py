"""Rank rows tell the truth about coverage (issue 30): joints compared / canonical joints both rigs have, the joints
left out named in ``unmapped``, and the limb-chain rule (below half of the arms and legs both rigs have: refused with
one warning, or kept as partial and ranked last when partial matches are allowed). Rigs are BVH text written by the
test (tests/helpers/rig_skeletons.py), read through the front door; maps that leave joints out are saved maps."""

import json

import pytest

from blender_shapesig import cli
from blender_shapesig.core import rigs
from blender_shapesig.core.search import rank_clips
from blender_shapesig.core.search.store import SignatureCache
from blender_shapesig.core.io import sources
from tests.helpers.rig_skeletons import BIOVISION, BLENDER_LR, UNITY, write_bvh

UNITY_HAS = tuple(j for j in rigs.JOINTS if j != "spine_mid")  # the Unity rig has every joint but spine_mid


def _read(path, **kw):
    return sources.read_one(sources.ClipSpec(str(path), trim="none", **kw))


def _map_without(tmp_path, name, left_out):
    """A saved map of the Unity rig naming every joint it has but ``left_out``."""
    path = tmp_path / name
    path.write_text(json.dumps({UNITY[j]: j for j in UNITY_HAS if j not in left_out}))
    return str(path)


@pytest.fixture
def unity(tmp_path):
    query = _read(write_bvh(tmp_path / "query.bvh", UNITY, root="joint_Root", frames=40))
    other = write_bvh(tmp_path / "other.bvh", UNITY, root="joint_Root", frames=48)
    return tmp_path, query, other


def _row(results, name):
    return next(r for r in results if r.name == name)


@pytest.mark.parametrize("metric", ["sim3", "elastic"])
def test_joint_coverage_and_unmapped_in_rows(unity, metric):
    """A torso-only map compares 4 of the 21 joints both rigs have: refused with one warning naming the coverage
    and the unmapped joints; with partial matches allowed it is kept, partial, ranked last, its unmapped joints
    listed. Full maps of the same rig (the index path) and of another rig (shared-bones path) cover 1.0."""
    tmp, query, other = unity
    full = _read(other)
    bio = _read(write_bvh(tmp / "bio.bvh", BIOVISION, frames=44))
    four = ("hips", "spine", "neck", "head")
    torso = _read(write_bvh(tmp / "torso.bvh", UNITY, root="joint_Root", frames=44),
                  bone_map=_map_without(tmp, "torso.json", set(UNITY_HAS) - set(four)))
    library = [full, bio, torso]
    got = rank_clips(query, library, metric=metric, allow_partial=False)
    assert sorted(r.name for r in got) == ["bio", "other"] and got.skipped == ["torso"]
    (line,) = [w for w in got.warnings if w.startswith("torso:")]
    assert "coverage 0.19 < 0.5" in line and "(unmapped: chest, clavicle.L, upper_arm.L" in line
    for r in got:
        assert r.coverage == 1.0 and r.unmapped == () and not r.partial
        assert r.as_dict()["unmapped"] == [] and r.as_dict()["partial"] is False
    kept = rank_clips(query, library, metric=metric, allow_partial=True)
    assert [r.name for r in kept][-1] == "torso" and [r.partial for r in kept] == [False, False, True]
    assert kept[-1].coverage == pytest.approx(4 / 21)
    assert list(kept[-1].unmapped) == [j for j in UNITY_HAS if j not in four]
    assert kept[-1].as_dict()["unmapped"] == list(kept[-1].unmapped)


def test_the_limb_chain_rule_refuses_most_joints_without_the_limbs(unity):
    """18 of 21 joints mapped (coverage 0.86) but neither upper arm nor the left thigh: 1 of the 4 arms and legs
    both rigs have is compared, below half: refused naming the chains, or partial when allowed."""
    tmp, query, other = unity
    gap = _read(other, bone_map=_map_without(tmp, "gap.json", {"upper_arm.L", "upper_arm.R", "thigh.L"}))
    got = rank_clips(query, [gap], metric="sim3", allow_partial=False)
    assert list(got) == [] and got.skipped == ["other"]
    (line,) = got.warnings
    assert line.startswith("other: 1 of the 4 arms and legs both rigs have compared (unmapped: upper_arm.L, ")
    (r,) = rank_clips(query, [gap], metric="sim3", allow_partial=True)
    assert r.partial and r.coverage == pytest.approx(18 / 21)
    assert list(r.unmapped) == [j for j in rigs.JOINTS if j in ("upper_arm.L", "upper_arm.R", "thigh.L")]


# a map the default search can still pose (legs, arms, head) that compares 10 of the 21 joints
POSABLE = ("hips", "head", "thigh.L", "thigh.R", "foot.L", "foot.R", "upper_arm.L", "upper_arm.R", "forearm.L",
           "forearm.R")


def test_default_search_rows_follow_the_rule_and_survive_the_cache(unity):
    """The default (local) search: a clip it can pose but that compares 10 of the 21 joints both rigs have is
    refused with one line, or (allowed) a local row marked partial after the whole-body rows although it is
    closer; read again from the disk cache by a new store (no entry computed), the rows are the same: entries
    keep their rigs' joints."""
    tmp, query, other = unity
    bio = _read(write_bvh(tmp / "bio.bvh", BIOVISION, frames=44))
    lr = _read(write_bvh(tmp / "lr.bvh", BLENDER_LR, frames=36))
    part = _read(other, bone_map=_map_without(tmp, "posable.json", set(UNITY_HAS) - set(POSABLE)))
    got = rank_clips(query, [bio, lr, part], allow_partial=False, cache=SignatureCache(tmp / "cache"))
    assert [r.name for r in got] == ["bio", "lr"] and got.skipped == ["other"]
    assert [w for w in got.warnings if w.startswith("other: coverage 0.48 < 0.5 (unmapped: spine, chest, ")]
    rows = []
    for _ in range(2):
        cache = SignatureCache(tmp / "cache")
        kept = rank_clips(query, [bio, lr, part], allow_partial=True, cache=cache)
        rows.append([r.as_dict() for r in kept])
    assert cache.stats["misses"] == 0 and cache.stats["hits"] > 0
    assert rows[0] == rows[1]
    assert [(r["clip"], r["metric"], r["partial"]) for r in rows[1]] == [
        ("bio", "local", False), ("lr", "local", False), ("other", "local", True)]
    assert rows[1][2]["distance"] < rows[1][0]["distance"]  # closer, yet after the whole-body rows
    assert rows[1][2]["coverage"] == pytest.approx(10 / 21)
    assert rows[1][2]["unmapped"] == [j for j in UNITY_HAS if j not in POSABLE]
    assert [r["unmapped"] for r in rows[1][:2]] == [[], []]


def test_cli_rank_json_rows_name_what_is_unmapped(unity, capsys):
    """``rank --json``: every row has "coverage" and "unmapped"; a Unity clip whose saved map names only a few of
    its bones is refused with one warning line (exit 0, the other rows kept) or, with --allow-partial, listed with
    "partial": true and its unmapped joints."""
    tmp, _, _ = unity
    lib = tmp / "lib"
    lib.mkdir()
    query = write_bvh(tmp / "bio_query.bvh", BIOVISION, frames=40)
    write_bvh(lib / "lr.bvh", BLENDER_LR, frames=36)
    write_bvh(lib / "bio.bvh", BIOVISION, frames=44)
    write_bvh(lib / "unity.bvh", UNITY, root="joint_Root", frames=48)
    few = tmp / "few.json"  # names Unity bones only: the Biovision and .L/.R rigs keep their automatic maps
    few.write_text(json.dumps({"Spine": "spine", "Shoulder_L": "clavicle.L", "Shoulder_R": "clavicle.R"}))
    args = ["rank", str(query), str(lib), "--bone-map", str(few), "--json", "--no-cache", "--no-progress"]
    assert cli.main(args) == 0
    out = capsys.readouterr()
    rows = json.loads(out.out)["results"]
    assert sorted(r["clip"] for r in rows) == ["bio", "lr"]
    assert all(r["unmapped"] == [] and r["coverage"] == 1.0 and r["partial"] is False for r in rows)
    (line,) = [x for x in out.err.splitlines() if "unity: coverage" in x]  # (the default search cannot pose it:
    assert "coverage 0.16 < 0.5 (unmapped: hips, chest, " in line and "skipped" in line  # one more line says so)
    assert cli.main(args + ["--allow-partial"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert [r["clip"] for r in rows][-1] == "unity" and rows[-1]["partial"] is True
    both = [j for j in rigs.JOINTS if j not in ("spine_mid", "toe.L", "toe.R")]  # Biovision has no toes
    assert rows[-1]["coverage"] == pytest.approx(3 / len(both))
    assert rows[-1]["unmapped"] == [j for j in both if j not in ("spine", "clavicle.L", "clavicle.R")]
