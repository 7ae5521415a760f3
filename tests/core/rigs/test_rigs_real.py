"""Across rigs on real clips: the same CMU take in other formats / skeletons ranks first both ways,
coverage and refusals on the command line, unmappable bones, saved maps, a blend onto A's rig.

Crops (explicit until automatic trimming lands): the Daz BVH files from frame 7 (rest frame and the converter's
ramp, which replaced the first 5 AMC frames: the 07/09 AMC takes start at frame 6), the iClone file from frame 2
(its T-pose frame); 16_15 uncropped."""

import json
import pathlib
import re

import numpy as np
import pytest

from blender_shapesig import cli
from blender_shapesig.core import search as index, rigs
from blender_shapesig.core.io import sources

pytest.importorskip("bpy", reason="BVH files are read with Blender's importer")

ROOT = pathlib.Path(__file__).resolve().parents[3]
D = ROOT / "tests" / "data"
ACC, BVH = D / "acclaim", D / "bvh"

# (name, path, asf, start)
TAKES = [
    ("amc:07_01", ACC / "07_01.amc", ACC / "07-walk.asf", 6), ("daz:07_01", BVH / "07_01.bvh", None, 7),
    ("amc:07_02", ACC / "07_02.amc", ACC / "07-walk.asf", 6), ("daz:07_02", BVH / "07_02.bvh", None, 7),
    ("amc:09_02", ACC / "09_02.amc", ACC / "09-run.asf", 6), ("daz:09_02", BVH / "09_02.bvh", None, 7),
    ("amc:09_03", ACC / "09_03.amc", ACC / "09-run.asf", 6), ("daz:09_03", BVH / "09_03.bvh", None, 7),
    ("amc:16_15", ACC / "16_15.amc", ACC / "16.asf", None), ("mb:16_15", ACC / "16_15.bvh", None, None),
    ("iclone:02_03", D / "cross_rig" / "002_03.bvh", None, 2), ("daz:02_03", D / "cross_rig" / "02_03.bvh", None, 7),
]


@pytest.fixture(scope="module")
def clips():
    out = {}
    for name, path, asf, start in TAKES:
        c = sources.read_one(sources.ClipSpec(str(path), asf=None if asf is None else str(asf), start=start))
        c.name = name
        out[name] = c
    return out


def test_same_take_in_another_format_ranks_first_both_ways(clips):
    names = list(clips)
    for name in names:
        res = index.rank_clips(clips[name], [clips[n] for n in names if n != name], allow_partial=False, metric="sim")
        assert not res.skipped
        first = res[0]
        assert first.name.split(":")[1] == name.split(":")[1], (name, [(r.name, round(r.distance, 3)) for r in res[:3]])
        assert first.coverage == 1.0


def test_every_format_maps_through_its_table(clips):
    fams = {n: rigs.detect_family(clips[n].meta["bone_map"].values())[0] for n in clips}
    assert fams["amc:07_01"] == fams["mb:16_15"] == "cmu_asf"
    assert fams["daz:07_01"] == "daz" and fams["iclone:02_03"] == "cc"
    assert clips["iclone:02_03"].fps == pytest.approx(60.0, abs=0.01) and len(clips["iclone:02_03"].bones) == 22


def _json(capsys, args):
    code = cli.main(args + ["--json", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def _error(capsys, args):
    code = cli.main(args + ["--no-progress"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_distance_reports_bones_and_coverage_and_refuses_partial(capsys):
    args = ["distance", str(ACC / "09_03.amc"), str(BVH / "09_03.bvh"), "--asf", str(ACC / "09-run.asf"),
            "--start", "7"]
    out = _json(capsys, args)
    assert out["bones"] == 19 and out["coverage"] == 1.0 and out["distance"] < 0.6
    line = _error(capsys, args + ["--bone-map", "none"])
    assert re.search(r"share 1 moving joints, coverage 0\.06 < 0\.5", line) and "--allow-partial" in line
    partial = _json(capsys, args + ["--bone-map", "none", "--allow-partial"])
    assert partial["bones"] == 1 and partial["coverage"] == pytest.approx(1 / 17)


def _renamed_bvh(tmp_path):
    """09_03.bvh with every joint renamed bone0, bone1, ... (no table knows them)."""
    text = (BVH / "09_03.bvh").read_text()
    head, motion = text.split("MOTION", 1)
    names = re.findall(r"(?:ROOT|JOINT)\s+(\S+)", head)
    for i, n in enumerate(names):
        head = re.sub(rf"((?:ROOT|JOINT)\s+){re.escape(n)}(\s)", rf"\g<1>bone{i}\g<2>", head)
    path = tmp_path / "custom.bvh"
    path.write_text(head + "MOTION" + motion)
    return path, {f"bone{i}": n for i, n in enumerate(names)}


def test_unmappable_bones_one_line_and_nothing_created(capsys, tmp_path):
    custom, _ = _renamed_bvh(tmp_path)
    line = _error(capsys, ["distance", str(BVH / "09_02.bvh"), str(custom)])
    assert line.startswith("blender_shapesig: error: clips '09_02' and 'custom' share no bones: no bone of 'custom' "
                           "maps to a canonical joint (unmapped bones: bone0, bone1, bone2")
    out = tmp_path / "never.blend"
    line = _error(capsys, ["blend", str(BVH / "09_02.bvh"), str(custom), "--weight", "0.5", "--out", str(out)])
    assert "maps to a canonical joint (unmapped bones: bone0" in line and not out.exists()


def test_saved_map_file_maps_a_custom_rig(capsys, tmp_path):
    custom, original = _renamed_bvh(tmp_path)
    daz = rigs.detect_map(list(original.values()))
    path = rigs.save_map(tmp_path / "custom_map.json", {b: daz[n] for b, n in original.items() if n in daz})
    mapped = _json(capsys, ["distance", str(BVH / "09_03.bvh"), str(custom), "--bone-map", path])
    assert mapped["coverage"] == 1.0 and mapped["distance"] < 1e-6  # the same file under other names


def test_blend_across_rigs_writes_onto_a_rig(capsys, tmp_path):
    """weight 0 gives A back: the blend in the comparison space written onto A's (Acclaim) rig equals A."""
    out = tmp_path / "x.blend"
    got = _json(capsys, ["blend", str(ACC / "09_02.amc"), str(BVH / "09_02.bvh"), "--asf", str(ACC / "09-run.asf"),
                         "--start", "7", "--weight", "0", "--out", str(out)])
    assert out.exists() and "lwrist" in got["kept_bones"] and "lfemur" not in got["kept_bones"]
    back = sources.read_one(sources.ClipSpec.parse(f"{out}#{got['actions'][0]}", bone_map="none"))
    a = sources.read_one(sources.ClipSpec(str(ACC / "09_02.amc"), asf=str(ACC / "09-run.asf"), start=7,
                                          bone_map="none"))
    idx = [a.bones.index(b) for b in back.bones]
    # float32 keys; the Acclaim rig's rest frames
    np.testing.assert_allclose(back.rotations, a.rotations[:, idx], atol=1e-4)
    # the root too: A's hips in leg lengths (rigs.hips_path) and back onto A's root (rigs.onto_rig), in metres
    np.testing.assert_allclose(back.root_translation, a.root_translation, atol=1e-4)


def _hips_in_legs(clip):
    """(median hips height, horizontal hips speed per second), both in leg lengths of the clip's own rig: the
    clip read as the user reads it (armature axes, rest skeleton), forward kinematics to its mapped hips."""
    by_joint = {j: b for b, j in rigs.resolve_map("auto", clip).items()}
    path, _leg = rigs.hips_path(clip, by_joint, rigs.world_rotations(clip))
    travel = np.linalg.norm(np.diff(path[:, :2], axis=0), axis=1).sum()
    return float(np.median(path[:, 2])), float(travel * clip.fps / (clip.frames - 1))


@pytest.mark.parametrize("a, b, asf", [
    (ACC / "09_02.amc", BVH / "07_01.bvh", ACC / "09-run.asf"),  # metres (Acclaim) x centimetres (Daz BVH)
    (D / "cross_rig" / "002_03.bvh", D / "cross_rig" / "02_03.bvh", None),  # CC rig: the root bone on the floor
])
def test_blend_across_rigs_keeps_the_hips_between_the_sources(capsys, tmp_path, a, b, asf):
    """Rigs translate other bones in other units for bodies of other sizes: the blend's hips (read back from the
    saved .blend, through A's rig) stay between the sources' hips in height and speed, each measured in leg
    lengths of its own rig. (Before: A's root path was averaged with B's as numbers, 40 m up in metres.)"""
    out = tmp_path / "x.blend"
    args = ["blend", str(a), str(b), "--weight", "0.5", "--feet", "none", "--out", str(out)]
    got = _json(capsys, args + (["--asf", str(asf)] if asf else []))
    blend = sources.read_one(sources.ClipSpec.parse(f"{out}#{got['actions'][0]}", bone_map="none"))
    src = [sources.read_one(sources.ClipSpec(str(p), asf=str(asf) if asf and p.suffix == ".amc" else None,
                                             bone_map="none")) for p in (a, b)]
    (ha, va), (hb, vb), (h, v) = (_hips_in_legs(c) for c in src + [blend])
    assert min(ha, hb) - 0.03 <= h <= max(ha, hb) + 0.03, (ha, hb, h)
    assert min(va, vb) * 0.85 <= v <= max(va, vb) * 1.15, (va, vb, v)


def test_blend_onto_a_rig_with_many_unmapped_bones_notes_them_in_one_short_line(capsys, tmp_path):
    """A Character Creator rig (101 bones: fingers, twist, face) onto which a Daz run is blended: the note names
    the count and a few bones in one line; the JSON lists every kept bone."""
    out = tmp_path / "cc.blend"
    code = cli.main(["blend", str(D / "cross_rig" / "002_03.bvh"), str(D / "cross_rig" / "02_03.bvh"),
                     "--weight", "0.5", "--out", str(out), "--json", "--no-progress"])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    kept = json.loads(stdout)["kept_bones"]
    notes = [ln for ln in err.splitlines() if "keep A's motion" in ln]
    assert len(kept) > 60 and len(notes) == 1
    assert notes[0].count(",") < 12 and f"{len(kept)} bone(s)" in notes[0] and f"{len(kept) - 8} more" in notes[0]
    assert "CC_Base_L_Thigh" not in kept and "CC_Base_L_Index1" in kept


def _joint_angles(a, b):
    """{joint: mean angle in degrees} between two comparison-space clips over normalized time."""
    from blender_shapesig.core.geometry import so3
    from blender_shapesig.core.geometry.curves import geodesic_interpolate, uniform_times

    u = np.linspace(0.0, 1.0, 80)
    Ra = geodesic_interpolate(a.rotations, uniform_times(a.frames), u)
    Rb = geodesic_interpolate(b.rotations, uniform_times(b.frames), u)
    return {j: float(np.degrees(np.linalg.norm(so3.log(np.swapaxes(Ra[:, a.bones.index(j)], -1, -2)
                                                              @ Rb[:, b.bones.index(j)]), axis=-1)).mean())
            for j in a.bones if j in b.bones}


def test_rest_retarget_brings_the_same_take_on_two_rigs_together():
    """The iClone (Character Creator: its BVH rest lies along -Y, other bone conventions) and Daz files of take
    02_03: relative to their own rests the legs are half a turn apart; relative to one rest
    (rigs.rest_retarget) every joint agrees to within what the conversions differ (< 30 degrees)."""
    a = sources.read_one(sources.ClipSpec(str(D / "cross_rig" / "002_03.bvh"), start=2))
    b = sources.read_one(sources.ClipSpec(str(D / "cross_rig" / "02_03.bvh"), start=7))
    before, after = _joint_angles(a, b), _joint_angles(a, rigs.rest_retarget(b, a))
    assert before["thigh.L"] > 150 and before["shin.R"] > 150
    assert max(after.values()) < 30, after
    assert _joint_angles(a, rigs.rest_retarget(a, a)) == pytest.approx({j: 0.0 for j in a.bones}, abs=1e-3)


def _relative_feet(clip):
    """Per frame, each foot's head relative to the hips in the clip's heading frame (x: left), in leg lengths."""
    from blender_shapesig.core.clip import skeleton

    by_joint = {j: b for b, j in rigs.resolve_map("auto", clip).items()}
    heads, _tails, W = skeleton.forward_kinematics(clip)
    H = rigs.clip_heading(clip, by_joint)
    at = lambda j: heads[:, clip.bones.index(by_joint[j])]  # noqa: E731
    leg = rigs.leg_length(clip, by_joint)
    return {s: ((at(f"foot.{s}") - at("hips")) @ H) / leg for s in "LR"}


def test_blend_of_a_cc_walk_and_a_daz_run_keeps_its_legs_apart(capsys, tmp_path):
    """A Character Creator run (A) blended with a Daz walk at 0.5: before rest_retarget the legs crossed (the
    right foot 0.9 leg lengths left of the hips, 0.8 left of the left foot). Now the left foot stays left of the
    right one and both stay under the hips, as in both sources."""
    out = tmp_path / "x.blend"
    got = _json(capsys, ["blend", str(D / "cross_rig" / "002_03.bvh"), str(BVH / "07_01.bvh"), "--weight", "0.5",
                         "--feet", "none", "--out", str(out)])
    blend = sources.read_one(sources.ClipSpec.parse(f"{out}#{got['actions'][0]}", bone_map="none"))
    feet = _relative_feet(blend)
    assert np.mean(feet["L"][:, 0] - feet["R"][:, 0]) > 0.0
    assert max(abs(feet[s][:, 0]).mean() for s in "LR") < 0.15
    assert max(feet[s][:, 2].max() for s in "LR") < -0.5
