"""Tests of core.blend on real CMU clips (walk 07_01, run 09_02): identities, symmetry, the geodesic
property of eq. 5.14 (Fig. 9.6's reference line), the blended timing, bone matching and root motion."""

import functools
import pathlib

import numpy as np
import pytest

from blender_shapesig.core import CurveError, ShapeSigError
from blender_shapesig.core.io.acclaim import load_acclaim
from blender_shapesig.core.blend import (
    blend_clip_series,
    blend_clips,
    blend_name,
    blend_weights,
    default_frames,
    geodesic_blend,
)
from blender_shapesig.core.clip.clip import Clip
from blender_shapesig.core.clip.skeleton import estimate_up_axis
from blender_shapesig.core.geometry.curves import geodesic_interpolate, l2_distance, uniform_times
from blender_shapesig.core.elastic.elastic import elastic_align

ACC = pathlib.Path(__file__).resolve().parents[2] / "data" / "acclaim"


@functools.lru_cache(maxsize=None)
def _clip(amc, asf):
    return load_acclaim(str(ACC / amc), str(ACC / asf))


@pytest.fixture(scope="module")
def walk():
    return _clip("07_01.amc", "07-walk.asf")


@pytest.fixture(scope="module")
def walk2():
    return _clip("07_02.amc", "07-walk.asf")


@pytest.fixture(scope="module")
def run():
    return _clip("09_02.amc", "09-run.asf")


def _angle(Ra, Rb):
    """Largest rotation angle between corresponding rotation matrices (radians).

    From the Frobenius distance |Ra - Rb| = 2 sqrt(2) sin(angle / 2), accurate for small angles
    (arccos of the trace is not: its round-off floor is ~1e-8)."""
    Ra, Rb = np.broadcast_arrays(Ra, Rb)
    fro = np.sqrt(np.sum((Ra - Rb) ** 2, axis=(-2, -1)))
    return float((2.0 * np.arcsin(np.clip(fro / (2.0 * np.sqrt(2.0)), 0.0, 1.0))).max())


# ------------------------------------------------------------------------------------------------
# curves


@pytest.mark.parametrize("align", [False, True])
def test_weight_zero_and_one_reproduce_the_inputs(walk, run, align):
    R0, R1 = walk.rotations, run.rotations
    out0 = geodesic_blend(R0, R1, 0.0, align=align)
    out1 = geodesic_blend(R0, R1, 1.0, align=align)
    assert out0.shape == R0.shape and out1.shape == R1.shape
    # Round-off only: the curve is rebuilt by exp/log steps.
    assert np.abs(out0 - R0).max() < 1e-10
    assert np.abs(out1 - R1).max() < 1e-10


def test_weight_zero_with_a_set_length_is_r0_resampled(walk, run):
    out = geodesic_blend(walk.rotations, run.rotations, 0.0, frames=101)
    expected = geodesic_interpolate(walk.rotations, None, uniform_times(101))
    assert out.shape[0] == 101
    assert _angle(out, expected) < 1e-9


def test_swap_without_alignment_agrees_to_round_off(walk, run):
    for w in (0.2, 0.5, 0.7):
        x = geodesic_blend(walk.rotations, run.rotations, w, align=False)
        y = geodesic_blend(run.rotations, walk.rotations, 1.0 - w, align=False)
        assert x.shape == y.shape
        assert np.abs(x - y).max() < 1e-10


def test_swap_with_alignment(walk, run):
    """With alignment blend(a, b, w) and blend(b, a, 1 - w) use two separately computed warps (b onto
    a, a onto b). The DP energy of a piecewise-linear warp equals that of its inverse (exact
    integrals, a symmetric step set), so for these clips the second warp is the transpose of the
    first and the blends agree to round-off; we assert that the warps are transposes to 1e-12 and
    that the blends agree to 1e-8 rad. (If the DP had ties, the sense would be the looser one:
    equal elastic distance to both inputs.)"""
    wab, _ = elastic_align(walk.rotations, run.rotations)
    wba, _ = elastic_align(run.rotations, walk.rotations)
    assert wab.shape == wba.shape
    assert np.abs(wab - wba[:, ::-1]).max() < 1e-12
    for w in (0.25, 0.6):
        x = geodesic_blend(walk.rotations, run.rotations, w)
        y = geodesic_blend(run.rotations, walk.rotations, 1.0 - w)
        assert x.shape == y.shape
        assert _angle(x, y) < 1e-8


@pytest.mark.parametrize("align", [False, True])
def test_blend_lies_on_the_dP_geodesic(walk, run, align):
    """Before resampling: d_P*(blend(w), b o phi) = (1 - w) d_P*(a, b o phi) and d_P*(blend(w), a)
    = w d_P*(a, b o phi), the straight reference line of Fig. 9.6. The distances are computed from
    the curves (SRVT of the rebuilt blend), not from the blended q."""
    for w in (0.1, 0.35, 0.5, 0.9):
        _, info = geodesic_blend(walk.rotations, run.rotations, w, align=align, return_info=True)
        G = info["grid"]
        d = l2_distance(info["curve0"], info["curve1"], G, G)
        assert d > 1.0
        to_b = l2_distance(info["curve"], info["curve1"], G, G)
        to_a = l2_distance(info["curve"], info["curve0"], G, G)
        assert to_b == pytest.approx((1.0 - w) * d, rel=1e-8)
        assert to_a == pytest.approx(w * d, rel=1e-8)
        # The blend starts at the identity (P*) before the start pose is applied.
        assert np.abs(info["curve"][0] - np.eye(3)).max() == 0.0


def test_aligned_distance_is_the_elastic_distance(walk, run):
    """d_P*(a, b o phi) on the merged grid equals the DP minimum of elastic_align (sec. 6.2 step 4)
    and is below the unaligned d_P*."""
    _, info = geodesic_blend(walk.rotations, run.rotations, 0.5, return_info=True)
    assert info["distance"] == pytest.approx(info["elastic_distance"], rel=1e-8)
    assert info["distance"] < l2_distance(walk.rotations, run.rotations)


def test_start_pose_is_the_geodesic_between_the_start_poses(walk, run):
    out = geodesic_blend(walk.rotations, run.rotations, 0.5, align=False)
    # Midpoint: equal angle to both start poses, half the angle between them.
    full = _angle(walk.rotations[0], run.rotations[0])
    half_a = np.array([_angle(out[0, j], walk.rotations[0, j]) for j in range(31)])
    half_b = np.array([_angle(out[0, j], run.rotations[0, j]) for j in range(31)])
    assert np.abs(half_a - half_b).max() < 1e-9
    assert half_a.max() == pytest.approx(full / 2, rel=1e-9)


def test_default_length_interpolates_the_durations(walk, run):
    n0, n1 = walk.frames, run.frames  # 316, 130
    for w in (0.0, 0.25, 0.5, 0.75, 1.0):
        out = geodesic_blend(walk.rotations, run.rotations, w)
        assert out.shape[0] == int(np.floor((1 - w) * n0 + w * n1 + 0.5))
    assert default_frames(316, 130, 0.5) == 223
    assert geodesic_blend(walk.rotations, run.rotations, 0.5, frames=50).shape[0] == 50


def test_blended_timing_follows_the_warp(walk, run):
    """The output frame at clip time v has the parameter u with
    ((1 - w) D0 u + w D1 phi(u)) / ((1 - w) D0 + w D1) = v: checked on the returned time map
    against the warp itself, and the blend at each frame equals the grid curve there."""
    w = 0.4
    out, info = geodesic_blend(walk.rotations, run.rotations, w, return_info=True)
    warp = info["warp"]
    u = info["time_map"]
    d0, d1 = walk.frames - 1, run.frames - 1
    phi_u = np.interp(u, warp[:, 0], warp[:, 1])
    v = ((1 - w) * d0 * u + w * d1 * phi_u) / ((1 - w) * d0 + w * d1)
    assert np.abs(v - uniform_times(out.shape[0])).max() < 1e-12
    assert np.all(np.diff(u) > 0)
    # The output is the grid curve at u, right-translated by the start pose.
    again = geodesic_interpolate(info["curve"], info["grid"], u) @ info["start"][None]
    assert _angle(out, again) < 1e-9


def test_blend_of_a_curve_with_itself_is_itself(walk):
    R = walk.rotations[:120]
    out = geodesic_blend(R, R, 0.37)
    assert np.abs(out - R).max() < 1e-10


def test_blend_with_a_retimed_copy_follows_the_blended_timing(walk):
    """b = a with its first half played at half speed: b's 241 frames are a's 161 knots plus the
    midpoints of the first 80 intervals, so b = a o psi exactly with psi piecewise linear. The DP
    finds the warp (zero energy), the blend at w = 0.5 has a's shape, and its timing is the
    average of both clips' timings: 200 v = 0.5 * 160 u + 0.5 * 240 phi(u), which works out by hand
    to u = j / 240 for output frames j <= 120 and u = (j - 40) / 160 after."""
    a = walk.rotations[:161]
    t_b = np.concatenate([np.arange(0, 160) / 2.0, 80.0 + np.arange(0, 81)]) / 160.0
    b = geodesic_interpolate(a, None, t_b)
    assert b.shape[0] == 241
    out, info = geodesic_blend(a, b, 0.5, return_info=True)
    assert info["elastic_distance"] < 1e-6
    assert out.shape[0] == 201
    j = np.arange(201)
    u = np.where(j <= 120, j / 240.0, (j - 40) / 160.0)
    assert np.abs(info["time_map"] - u).max() < 1e-12
    assert _angle(out, geodesic_interpolate(a, None, u)) < 1e-9
    # Weight 1 gives b itself (b's own timing).
    assert _angle(geodesic_blend(a, b, 1.0), b) < 1e-9


def test_curve_errors(walk, run):
    R0, R1 = walk.rotations, run.rotations
    with pytest.raises(ShapeSigError, match="weight"):
        geodesic_blend(R0, R1, 1.5)
    with pytest.raises(ShapeSigError, match="weight"):
        geodesic_blend(R0, R1, float("nan"))
    with pytest.raises(CurveError, match="joints"):
        geodesic_blend(R0, R1[:, :30], 0.5)
    with pytest.raises(CurveError, match="two frames"):
        geodesic_blend(R0[:1], R1, 0.5)
    with pytest.raises(ShapeSigError, match="frames"):
        geodesic_blend(R0, R1, 0.5, frames=1)
    with pytest.raises(CurveError, match="warp"):
        geodesic_blend(R0, R1, 0.5, warp=[[0, 0], [0.5, 0.7], [0.4, 0.8], [1, 1]])


def test_weights_and_names():
    assert blend_weights(1, 0.3) == [0.3]
    assert blend_weights(3) == [0.25, 0.5, 0.75]
    assert blend_name("walk", "run", 0.5) == "walk_x_run_0.50"
    with pytest.raises(ShapeSigError):
        blend_weights(0)


# ------------------------------------------------------------------------------------------------
# clips


def test_clip_blend_identities_with_root(walk, run):
    c0 = blend_clips(walk, run, 0.0)
    c1 = blend_clips(walk, run, 1.0)
    assert c0.frames == walk.frames and c1.frames == run.frames
    assert np.abs(c0.rotations - walk.rotations).max() < 1e-10
    assert np.abs(c1.rotations - run.rotations).max() < 1e-10
    assert np.abs(c0.root_translation - walk.root_translation).max() < 1e-9
    assert np.abs(c1.root_translation - run.root_translation).max() < 1e-9
    assert c0.name == "07_01_x_09_02_0.00"
    assert c0.bones == walk.bones and c0.fps == walk.fps


def test_clip_swap_without_alignment(walk, run):
    x = blend_clips(walk, run, 0.3, align=False)
    y = blend_clips(run, walk, 0.7, align=False)
    assert np.abs(x.rotations - y.rotations).max() < 1e-10
    assert np.abs(x.root_translation - y.root_translation).max() < 1e-9


def test_blended_locomotion_moves_forward(walk, run):
    """Both clips travel along +Z of the ASF world (Y up). The blend travels between the two,
    monotonically in w, never moves backwards over a quarter second, and its height stays within
    the two clips' height range."""
    travel = {}
    for w in (0.0, 0.25, 0.5, 0.75, 1.0):
        c = blend_clips(walk, run, w)
        p = c.root_translation
        travel[w] = p[-1, 2] - p[0, 2]
        window = 30  # 0.25 s at 120 fps
        assert np.all(p[window:, 2] - p[:-window, 2] > 0), w
        lo = min(walk.root_translation[:, 1].min(), run.root_translation[:, 1].min())
        hi = max(walk.root_translation[:, 1].max(), run.root_translation[:, 1].max())
        assert lo - 1e-9 <= p[:, 1].min() and p[:, 1].max() <= hi + 1e-9
        assert c.meta["up_axis"] == (0.0, 1.0, 0.0)
    values = [travel[w] for w in sorted(travel)]
    assert np.all(np.diff(values) > 0)
    # Per-frame speed: the run covers 67 units in 130 frames, the walk 63 in 316; the blend's
    # mean speed lies in between.
    speeds = [travel[w] / (blend_clips(walk, run, w).frames - 1) for w in (0.0, 0.5, 1.0)]
    assert speeds[0] < speeds[1] < speeds[2]


def test_root_a_keeps_the_path_of_a(walk, run):
    c = blend_clips(walk, run, 0.5, root="a")
    u = c.meta["time_map"]
    expected = np.stack([np.interp(u, uniform_times(walk.frames), walk.root_translation[:, i])
                         for i in range(3)], axis=1)
    assert np.abs(c.root_translation - expected).max() < 1e-12
    assert c.meta["root_mode"] == "a"


def test_unmatched_and_subset_bones(walk, run):
    # B without 'head' and with a renamed 'lfingers': both A bones keep A's motion.
    keep = [i for i, b in enumerate(run.bones) if b != "head"]
    bones_b = tuple("other" if run.bones[i] == "lfingers" else run.bones[i] for i in keep)
    b = Clip(name="run", bones=bones_b, rotations=run.rotations[:, keep], fps=run.fps,
             root_translation=run.root_translation, root_bone=run.root_bone, meta=run.meta)
    c = blend_clips(walk, b, 0.5)
    assert set(c.meta["unmatched_bones"]) == {"head", "lfingers", "other"}
    assert c.bones == walk.bones
    u = c.meta["time_map"]
    for name in ("head", "lfingers"):
        j = walk.bones.index(name)
        assert _angle(c.rotations[:, j], geodesic_interpolate(walk.rotations[:, j], None, u)[:, 0]) < 1e-9

    # Upper-body subset: blended bones equal geodesic_blend of the subset with the same warp;
    # the rest is A's motion in the blended timing.
    upper = ["lowerback", "upperback", "thorax", "lhumerus", "rhumerus", "lradius", "rradius"]
    s = blend_clips(walk, run, 0.5, bones=",".join(upper))
    full = blend_clips(walk, run, 0.5)
    assert np.array_equal(s.meta["warp"], full.meta["warp"])
    assert s.meta["blended_bones"] == tuple(b for b in walk.bones if b in upper)
    ia = [walk.bones.index(x) for x in s.meta["blended_bones"]]
    ib = [run.bones.index(x) for x in s.meta["blended_bones"]]
    ref = geodesic_blend(walk.rotations[:, ia], run.rotations[:, ib], 0.5, warp=s.meta["warp"],
                         durations=((walk.frames - 1) / walk.fps, (run.frames - 1) / run.fps),
                         frames=s.frames)
    assert _angle(s.rotations[:, ia], ref) < 1e-9
    j = walk.bones.index("lfemur")
    u = s.meta["time_map"]
    assert _angle(s.rotations[:, j], geodesic_interpolate(walk.rotations[:, j], None, u)[:, 0]) < 1e-9
    # The root is not in the subset: its rotation is A's, and its path still blends.
    assert s.meta["root_mode"] == "blend"


def test_series_uses_one_warp(walk, run):
    calls = []
    series = blend_clip_series(walk, run, blend_weights(3), progress=lambda i, n: calls.append((i, n)))
    assert [c.name for c in series] == ["07_01_x_09_02_0.25", "07_01_x_09_02_0.50", "07_01_x_09_02_0.75"]
    assert calls == [(1, 3), (2, 3), (3, 3)]
    single = blend_clips(walk, run, 0.5)
    assert np.abs(series[1].rotations - single.rotations).max() < 1e-12
    assert [c.frames for c in series] == [270, 223, 177]


def test_up_axis_estimate_on_real_clips(walk, walk2, run):
    def root(c):
        return c.rotations[:, c.bones.index(c.root_bone)]

    for clips in ((walk,), (run,), (walk, run), (walk2, run)):
        up = estimate_up_axis([root(c) for c in clips], [c.root_translation for c in clips])
        assert np.array_equal(up, [0.0, 1.0, 0.0])


def test_clip_errors(walk, run):
    other = Clip(name="x", bones=("a", "b"), rotations=np.broadcast_to(np.eye(3), (5, 2, 3, 3)))
    with pytest.raises(ShapeSigError, match="share no bones"):
        blend_clips(walk, other, 0.5)
    with pytest.raises(ShapeSigError, match="not in both clips"):
        blend_clips(walk, run, 0.5, bones=["thorax", "tail"])
    with pytest.raises(ShapeSigError, match="root"):
        blend_clips(walk, run, 0.5, root="b")
    with pytest.raises(ShapeSigError, match="weight"):
        blend_clips(walk, run, -0.1)
    with pytest.raises(ShapeSigError, match="up_axis"):
        blend_clips(walk, run, 0.5, up_axis="W")
    with pytest.raises(ShapeSigError, match="two frames"):
        blend_clips(walk.crop(1, 1), run, 0.5)


def test_different_frame_rates_blend_durations_in_seconds(walk, run):
    """B at 60 fps lasts 129/60 s: the default length is the blended duration at A's 120 fps, and
    w = 1 gives B's motion resampled to A's frame rate."""
    slow = Clip(name="run60", bones=run.bones, rotations=run.rotations, fps=60.0,
                root_translation=run.root_translation, root_bone=run.root_bone, meta=run.meta)
    half = blend_clips(walk, slow, 0.5)
    assert half.frames == int(np.floor((0.5 * 315 / 120 + 0.5 * 129 / 60) * 120 + 0.5)) + 1 == 288
    one = blend_clips(walk, slow, 1.0)
    assert one.frames == 259 and one.fps == 120.0
    assert _angle(one.rotations, geodesic_interpolate(run.rotations, None, uniform_times(259))) < 1e-9


def _turned(clip, degrees):
    """The clip turned about the vertical (ASF +Y) by ``degrees``: root rotation and path."""
    from scipy.spatial.transform import Rotation

    Q = Rotation.from_euler("y", degrees, degrees=True).as_matrix()
    rot = clip.rotations.copy()
    j = clip.bones.index(clip.root_bone)
    rot[:, j] = Q @ rot[:, j]
    return Clip(name=clip.name + "_turned", bones=clip.bones, rotations=rot, fps=clip.fps,
                root_translation=clip.root_translation @ Q.T, root_bone=clip.root_bone,
                meta=clip.meta), Q


def test_root_displacements_follow_the_blended_heading(walk, run):
    """B turned by 90 degrees walks along +X instead of +Z. Displacements blended in the heading
    frame keep the full forward travel (between A's and B's, not the ~0.7x of averaging two
    perpendicular world displacements) and head off at about 45 degrees, the blended heading."""
    b, _ = _turned(run, 90.0)
    c = blend_clips(walk, b, 0.5)
    d = c.root_translation[-1] - c.root_translation[0]
    horiz = np.hypot(d[0], d[2])
    da = walk.root_translation[-1] - walk.root_translation[0]
    db = b.root_translation[-1] - b.root_translation[0]
    lo, hi = sorted([np.hypot(da[0], da[2]), np.hypot(db[0], db[2])])
    assert lo * 0.97 <= horiz <= hi * 1.03
    direction = np.degrees(np.arctan2(d[0], d[2]))
    assert 35.0 < direction < 55.0


def test_turning_both_clips_turns_the_blend(walk, run):
    """Equivariance: blending two clips turned by the same yaw gives the turned blend."""
    a2, Q = _turned(walk, 30.0)
    b2, _ = _turned(run, 30.0)
    c = blend_clips(walk, run, 0.4)
    c2 = blend_clips(a2, b2, 0.4)
    j = walk.bones.index("root")
    assert np.abs(c2.root_translation - c.root_translation @ Q.T).max() < 1e-8
    assert _angle(c2.rotations[:, j], Q @ c.rotations[:, j]) < 1e-9
    others = [i for i in range(len(walk.bones)) if i != j]
    assert _angle(c2.rotations[:, others], c.rotations[:, others]) < 1e-9


def test_quaternion_input_gives_the_same_blend(walk, run):
    from scipy.spatial.transform import Rotation

    def quats(R):
        f, j = R.shape[:2]
        return Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat().reshape(f, j, 4)

    R = geodesic_blend(walk.rotations[:150], run.rotations, 0.3)
    Q = geodesic_blend(quats(walk.rotations[:150]), quats(run.rotations), 0.3)
    assert _angle(R, Q) < 1e-9


def test_clip_blend_keeps_the_rotation_space_and_refuses_mixed_spaces(data_dir):
    acc = data_dir / "acclaim"
    a = load_acclaim(acc / "07_01.amc", acc / "07-walk.asf", axes="blender").crop(1, 120)
    b = load_acclaim(acc / "07_02.amc", acc / "07-walk.asf", axes="blender").crop(1, 120)
    out = blend_clips(a, b, 0.5, align=False)
    assert out.meta["rotation_space"] == "armature"
    # the same blend in ASF axes is the armature-space blend conjugated by the axis change
    a_asf = load_acclaim(acc / "07_01.amc", acc / "07-walk.asf").crop(1, 120)
    b_asf = load_acclaim(acc / "07_02.amc", acc / "07-walk.asf").crop(1, 120)
    out_asf = blend_clips(a_asf, b_asf, 0.5, align=False)
    from blender_shapesig.core.io.acclaim import ASF_TO_BLENDER as A

    np.testing.assert_allclose(out.rotations, A @ out_asf.rotations @ A.T, atol=1e-10)
    with pytest.raises(ShapeSigError, match="different spaces"):
        blend_clips(a, b_asf, 0.5, align=False)
