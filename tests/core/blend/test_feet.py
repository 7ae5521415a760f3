"""core.clip.skeleton forward kinematics and core.blend.feet (planted feet) on real CMU clips from tests/data."""

import pathlib
from dataclasses import replace

import numpy as np
import pytest

from blender_shapesig.core.blend import feet
from blender_shapesig.core.blend import blend_clips
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.io.acclaim import ASF_TO_BLENDER, forward_kinematics as acclaim_fk, load_acclaim
from blender_shapesig.core.io.amc import parse_amc
from blender_shapesig.core.io.asf import parse_asf
from blender_shapesig.core.io.bvh import load_bvh
from blender_shapesig.core.clip.skeleton import forward_kinematics, rest_of, unit_meters

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"
BVH = pathlib.Path(__file__).resolve().parents[2] / "data" / "bvh"


def walk():  # one stride of 07_01, right heel strike to right heel strike
    return load_acclaim(ACC / "07_01.amc", ACC / "07-walk.asf", axes="blender").crop(125, 253)


def run():  # one stride of 09_02
    return load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf", axes="blender").crop(36, 126)


def test_fk_equals_the_acclaim_formula_in_both_axes():
    sk = parse_asf(ACC / "09-run.asf")
    heads0, tails0 = acclaim_fk(parse_amc(ACC / "09_02.amc", sk))
    clip = load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf")
    heads, tails, _W = forward_kinematics(clip)
    assert np.abs(heads - heads0).max() < 1e-9 and np.abs(tails - tails0).max() < 1e-9
    blender = load_acclaim(ACC / "09_02.amc", ACC / "09-run.asf", axes="blender")
    assert np.abs(forward_kinematics(blender)[0] - sk.meters_per_unit * heads0 @ ASF_TO_BLENDER.T).max() < 1e-12


def test_units_known_for_acclaim_and_guessed_for_daz_bvh():
    assert unit_meters(walk()) == 1.0
    clip = load_bvh(BVH / "07_01.bvh")
    legs = feet.legs_of(clip)
    assert sorted(legs) == ["L", "R"]
    assert unit_meters(clip, [(t, f) for t, _s, f in legs.values()]) == 0.01  # the Daz conversion is in cm


def test_contacts_on_a_walk_where_the_foot_is_still():
    clip = walk()
    contacts = feet.find_contacts(clip)
    pos = feet.feet_positions(clip)
    runs = feet._runs(contacts["R"]["ball"])
    assert len(runs) == 1
    a, b = runs[0]
    assert 0.4 < (b - a) / clip.fps < 0.8  # the right stance of a 1.07 s stride
    still = pos["R"]["ball"][a:b + 1]
    assert np.linalg.norm(still.max(axis=0) - still.min(axis=0)) < 0.06  # the ball stays put (m)
    swing = pos["R"]["ball"][b + 10:]
    assert np.linalg.norm(swing[-1] - swing[0]) > 0.5  # and then swings forward
    for side in "LR":  # every frame has a foot on the ground in a walk
        assert np.all(contacts["L"]["heel"] | contacts["L"]["ball"] | contacts["R"]["heel"] | contacts["R"]["ball"])


def _drifts(report, key):
    return [d for f in report["feet"] for d in f[key]]


def test_lock_reduces_stance_drift_and_leaves_the_rest():
    a, b = walk(), run()
    blend = blend_clips(a, b, 0.25, align=True)
    out, report = feet.lock_feet(blend, [a, b])
    before, after = _drifts(report, "drift_before"), _drifts(report, "drift_after")
    assert np.median(after) < 0.5 * np.median(before)
    assert max(after) < max(before)
    # only the legs (with the toes under each foot) and the root height change
    legs = feet.legs_of(a)
    rest = rest_of(a)
    toes = {int(c) for leg in legs.values() for c in np.flatnonzero(rest.ancestor == leg[2])}
    leg_bones = sorted({j for leg in legs.values() for j in leg} | toes)
    others = [j for j in range(len(a.bones)) if j not in leg_bones]
    assert np.array_equal(out.rotations[:, others], blend.rotations[:, others])
    moved = out.root_translation - blend.root_translation
    assert np.abs(moved[:, :2]).max() < 1e-12 and np.all(moved[:, 2] <= 1e-12)
    # frames far from every contact of a leg keep that foot where it was (the knee may bend where the root is
    # lowered); every foot keeps its world orientation on every frame
    ramp = int(round(feet.RAMP * blend.fps)) + 1
    h0, _t0, W0 = forward_kinematics(feet._working_clip(blend, [a, b]))
    h1, _t1, W1 = forward_kinematics(feet._working_clip(out, [a, b]))
    for side, (thigh, shin, foot) in legs.items():
        near = np.zeros(blend.frames, bool)
        for row in report["contacts"]:
            if row["clip"] == blend.name and row["side"] == side:
                for iv in row["intervals"]:
                    s, e = (f - blend.frame_start for f in iv["frames"])
                    near[max(0, s - ramp):e + ramp + 1] = True
        assert (~near).sum() > 5
        assert np.abs(h1[~near, foot] - h0[~near, foot]).max() < 1e-9
        assert np.abs(h1[near, foot] - h0[near, foot]).max() > 0.01
        assert np.abs(W1[:, foot] - W0[:, foot]).max() < 1e-9
    # no pops: the legs' per-frame rotation steps stay of the order of the blend's own
    from blender_shapesig.core.geometry import so3

    for leg in legs.values():
        for j in leg:
            step = so3.angle(out.rotations[1:, j] @ np.swapaxes(out.rotations[:-1, j], -1, -2)).max()
            own = so3.angle(blend.rotations[1:, j] @ np.swapaxes(blend.rotations[:-1, j], -1, -2)).max()
            assert step < 2.5 * own
    # the report names contacts per source and in the blend, in frames and seconds
    clips = {row["clip"] for row in report["contacts"]}
    assert clips == {a.name, b.name, blend.name}
    assert report["contacts"][0]["intervals"][0]["seconds"][1] >= 0


def test_weight_zero_leaves_the_first_source_feet():
    a, b = walk(), run()
    blend = blend_clips(a, b, 0.0, align=True)
    out, report = feet.lock_feet(blend, [a, b])
    h0, t0, W0 = forward_kinematics(feet._working_clip(blend, [a, b]))
    h1, t1, W1 = forward_kinematics(feet._working_clip(out, [a, b]))
    for side, (_thigh, _shin, foot) in feet.legs_of(a).items():
        assert np.abs(h1[:, foot] - h0[:, foot]).max() < 1e-9 and np.abs(t1[:, foot] - t0[:, foot]).max() < 1e-9
        assert np.abs(W1[:, foot] - W0[:, foot]).max() < 1e-9
    # a knee within 2% of the leg of the hip-ankle line may turn about that line (the forward bias); others stay
    assert np.abs(out.rotations - blend.rotations).max() < 1e-2
    assert np.abs(out.root_translation - blend.root_translation).max() < 1e-12
    assert report["root_lowered"] == 0.0
    assert _drifts(report, "drift_before") == _drifts(report, "drift_after")


def test_source_times_from_time_map_and_warp_or_given():
    a, b = walk(), run()
    blend = blend_clips(a, b, 0.5, align=True)
    ta, tb = feet.source_times(blend, [a, b])
    assert ta[0] == 0 and tb[0] == 0
    assert ta[-1] == pytest.approx((a.frames - 1) / a.fps) and tb[-1] == pytest.approx((b.frames - 1) / b.fps)
    assert np.all(np.diff(ta) >= 0) and np.all(np.diff(tb) >= 0)
    blend.meta["source_times"] = [ta * 0.5, tb]
    assert np.array_equal(feet.source_times(blend, [a, b])[0], ta * 0.5)
    blend.meta.pop("source_times")
    blend.meta.pop("warp")
    with pytest.raises(ShapeSigError):
        feet.source_times(blend, [a, b])


def test_across_rigs_daz_bvh_walk_and_acclaim_run():
    """A blend through the canonical joints written back on the Daz BVH rig (rigs.onto_rig keeps the timing)."""
    from blender_shapesig.core.rigs import apply_bone_map, onto_rig

    a = load_bvh(BVH / "07_01.bvh").crop(126, 254)  # the AMC stride (the BVH has one more frame first)
    b = run()
    ma, mb = apply_bone_map(a), apply_bone_map(b)
    blend = onto_rig(blend_clips(ma, mb, 0.5, align=True), a, ma)
    assert "time_map" in blend.meta and "warp" in blend.meta
    out, report = feet.lock_feet(blend, [a, b])
    assert report["unit_meters"] == 0.01
    before, after = _drifts(report, "drift_before"), _drifts(report, "drift_after")
    assert len(after) >= 3 and np.median(after) < 0.5 * np.median(before)
    with pytest.raises(ShapeSigError, match="rest skeleton"):
        feet.lock_feet(blend_clips(ma, mb, 0.5, align=True), [ma, mb])  # comparison space: no FK


def test_pose_space_gives_the_same_planted_feet():
    """Rotations written back in the clip's space: a pose-space copy (random bone rest frames B, P = B^T X B, the
    root's location in its rest frame) is planted exactly like the armature-space clip."""
    from dataclasses import replace

    from blender_shapesig.core.geometry import so3

    a, b = walk(), run()
    blend = blend_clips(a, b, 0.25, align=True)
    planted, _ = feet.lock_feet(blend, [a, b])
    B = so3.exp(np.random.default_rng(3).normal(size=(len(a.bones), 3)))
    r = a.bones.index(a.root_bone)
    head = np.array(a.meta["rest_heads"][a.root_bone])

    def to_pose(clip):
        P = np.swapaxes(B, -1, -2)[None] @ clip.rotations @ B[None]
        meta = dict(clip.meta, rotation_space="pose", rest_rotations=B)
        return replace(clip, rotations=P, root_translation=(clip.root_translation - head) @ B[r], meta=meta)

    pose_planted, _ = feet.lock_feet(to_pose(blend), [to_pose(a), to_pose(b)])
    assert np.abs(pose_planted.rotations - to_pose(planted).rotations).max() < 1e-9
    assert np.abs(pose_planted.root_translation - to_pose(planted).root_translation).max() < 1e-9


# ------------------------------------------------------------------------------------------------ no pops

def _whole(name, asf):
    return load_acclaim(ACC / name, ACC / asf, axes="blender")


@pytest.mark.parametrize("w", [0.25, 0.5, 0.75])
def test_whole_takes_locked_without_pops(w):
    """Issue 31: AMC 07_01 x 09_02 whole takes at 0.5 threw the left femur 36.5 and 60.7 degrees in a frame."""
    from blender_shapesig.core.blend import make_blends

    a, b = _whole("07_01.amc", "07-walk.asf"), _whole("09_02.amc", "09-run.asf")
    (locked,), info = make_blends([a, b], [[1 - w, w]], feet="lock")
    step, source = feet.rotation_steps(locked, [a, b])
    assert 5.0 < source < 30.0
    assert step <= source + 5.0
    # and the lock still plants: the stance drifts after are below those before
    before, after = _drifts(info["feet"][0], "drift_before"), _drifts(info["feet"][0], "drift_after")
    assert np.median(after) < np.median(before)


def test_rotation_steps_of_a_clip_against_itself_are_equal():
    a = walk()
    blend = blend_clips(a, a, 0.5, align=False)
    step, source = feet.rotation_steps(blend, [a, a])
    assert abs(step - source) < 1e-6
    # a quarter turn of one bone in one frame is 90 degrees
    R = blend.rotations.copy()
    R[40:, 3] = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]) @ R[40:, 3]
    from dataclasses import replace

    assert abs(feet.rotation_steps(replace(blend, rotations=R), [a, a])[0] - 90.0) < source + 1e-6


def test_overlapping_ramps_give_a_continuous_offset():
    """Two contacts closer than two ramps: the offset is their weighted mean, never a switch from one to the other."""
    n, fps = 60, 120.0
    mask = np.zeros(n, bool)
    mask[5:15] = mask[25:40] = True
    pos = {p: np.zeros((n, 3)) for p in feet.POINTS}
    pos["heel"][:, 0] = pos["ball"][:, 0] = np.linspace(0.0, 0.6, n)  # a sliding foot: each run pins elsewhere

    def slide(point, a, b):
        return np.zeros((b - a + 1, 3))

    offset, weight = feet._ankle_offsets({"heel": mask, "ball": mask}, pos, fps, slide)
    target = pos["heel"] + weight[:, None] * offset
    jumps = np.linalg.norm(np.diff(target, axis=0), axis=1)
    assert jumps.max() < 3 * 0.6 / n  # at most a few times the foot's own step (the old switch jumped ~0.1 m)
    # each run holds its pin (its last frames lean a few mm to the next run's ramp, continuous by design)
    assert np.allclose(target[5:13, 0], target[5, 0]) and np.allclose(target[27:40, 0], target[39, 0])
    assert np.abs(target[5:15, 0] - target[5, 0]).max() < 0.005
    assert weight[0] > 0 and weight[20] > 0 and np.all(weight[5:15] == 1)


def test_held_keeps_one_footprint():
    p = np.zeros((100, 3))
    p[:, 0] = np.arange(100.0)
    mask = np.zeros(100, bool)
    mask[10:20] = mask[60:80] = True
    held = feet._held(p, mask, np.linspace(15.0, 50.0, 30))  # overlaps the first footprint only
    assert np.allclose(held[:, 0], np.clip(np.linspace(15.0, 50.0, 30), 10, 19))
    assert feet._held(p, mask, np.linspace(30.0, 50.0, 5)) is None  # no contact of its own there: no slide


def test_reach_fade_lets_go_beyond_the_leg():
    n = 40
    hip = np.zeros((n, 3))
    current = np.tile([0.0, 0.0, -0.8], (n, 1))
    desired = current.copy()
    desired[20:, 2] = -1.2  # half a metre beyond a 0.9 m leg
    fade = feet._reach_fade(hip, desired, current, 0.9, 120.0)
    assert np.allclose(fade[:5], 1.0) and np.allclose(fade[-5:], 0.0)
    assert np.abs(np.diff(fade)).max() < 0.2  # eased over several frames


def test_lock_keeps_feet_and_toes_above_the_floor_of_the_rigs_own_sources():
    """A blend written onto A's rig whose feet sink (the root 5 cm lower and both feet pitched 25 degrees toes-down,
    as a blend with a rig of lower ankles brings): after the lock no ankle, ball or toe tip is lower than the
    lowest of A's own (forward kinematics, independent of the lock), within FLOOR_TOLERANCE; no bone steps faster
    than the blend's own + 5 degrees (the corrections ease in and out)."""
    from blender_shapesig.core.geometry import so3

    a, b = walk(), run()
    blend = blend_clips(a, b, 0.25, align=True)
    legs = feet.legs_of(a)
    rest = rest_of(a)
    up = np.array([0.0, 0.0, 1.0])
    R = blend.rotations.copy()
    for _thigh, _shin, foot in legs.values():
        across = np.cross(rest.tails[foot] - rest.heads[foot], up)
        across /= np.linalg.norm(across)
        R[:, foot] = so3.exp(-np.radians(25.0) * across) @ R[:, foot]  # toes down, in the foot's own frame
    sunk = replace(blend, rotations=R, root_translation=blend.root_translation - 0.05 * up)
    points = sorted({f for _t, _s, f in legs.values()}
                    | {int(c) for leg in legs.values() for c in np.flatnonzero(rest.ancestor == leg[2])})

    def lowest(clip):  # per bone of `points`: the lowest of its head and tail
        heads, tails, _W = forward_kinematics(feet._working_clip(clip, [a, b]))
        return np.minimum(heads[:, points, 2], tails[:, points, 2]).min(axis=0)

    floor = lowest(a)
    assert (lowest(sunk) < floor - 0.03).any()  # the sunk blend goes through the floor
    out, _report = feet.lock_feet(sunk, [a, b])
    assert (lowest(out) >= floor - feet.FLOOR_TOLERANCE - 1e-6).all(), (lowest(out) - floor)
    step = so3.angle(out.rotations[1:] @ np.swapaxes(out.rotations[:-1], -1, -2)).max()
    own = so3.angle(sunk.rotations[1:] @ np.swapaxes(sunk.rotations[:-1], -1, -2)).max()
    assert np.degrees(step) <= np.degrees(own) + 5.0
