"""Transitions (core.blend.transition) against independent truth: a real take split in two overlapping parts is
rejoined at its true cut; a cut is the same after B is turned and moved on the ground, and the ground fit gives back
that turn; a constant-velocity motion is in-betweened exactly (the geodesic with its velocities); a bridge from a
library holding the take gives back the take's own frames, and a bridge carries the context's velocity into a
segment at rest; the joined clip keeps A and B's own motion and has no
root or joint jump beyond the sources' at its seams, also across rigs and frame rates."""

import pathlib
from dataclasses import replace

import numpy as np
import pytest

from blender_shapesig.core.blend.body import Body
from blender_shapesig.core.blend.cuts import ground_fit
from blender_shapesig.core.blend.contacts import legs_of
from blender_shapesig.core.blend.transition import best_cuts, inbetween, transition
from blender_shapesig.core.clip.skeleton import forward_kinematics
from blender_shapesig.core.errors import ShapeSigError
from blender_shapesig.core.geometry import so3
from blender_shapesig.core.io.sources import read_one

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def _read(name, asf=None):
    return read_one(str(DATA / name), asf=None if asf is None else str(DATA / asf), bone_map="none")


@pytest.fixture(scope="module")
def walk():
    return _read("bvh/07_01.bvh")


@pytest.fixture(scope="module")
def run():
    return _read("bvh/09_02.bvh")


def _split(clip, k, m):
    return clip.crop(clip.frame_start, clip.frame_start + k + m), clip.crop(clip.frame_start + k, None)


def _turned(clip, angle, shift):
    """The clip turned about Z by ``angle`` and moved by ``shift`` (armature space: the root's world rotation)."""
    T = so3.exp(np.array([0.0, 0.0, angle]))
    R = clip.rotations.copy()
    r = clip.bones.index(clip.root_bone)
    R[:, r] = T[None] @ R[:, r]
    return replace(clip, rotations=R, root_translation=clip.root_translation @ T.T + np.asarray(shift))


@pytest.mark.parametrize("name,k,m", [("bvh/07_01.bvh", 97, 70), ("bvh/13_32.bvh", 150, 60),
                                      ("bvh/08_01.bvh", 61, 90), ("bvh/09_02.bvh", 43, 50)])
def test_split_take_rejoins_at_its_true_cut(name, k, m):
    a, b = _split(_read(name), k, m)
    first = best_cuts(a, b)[0]
    assert abs((first.a_frame - first.b_frame) - k) <= 2
    assert k <= first.a_frame <= k + m


def test_cuts_do_not_see_where_b_stands(walk):
    a, b = _split(walk, 97, 70)
    moved = _turned(b, 1.1, (40.0, -25.0, 0.0))
    assert [(c.a_frame, c.b_frame) for c in best_cuts(a, b, top=3)] == \
        [(c.a_frame, c.b_frame) for c in best_cuts(a, moved, top=3)]
    angle, _shift = ground_fit(Body(a), Body(moved), 120, 23)
    assert angle == pytest.approx(-1.1, abs=1e-6)


def test_constant_velocity_gap_is_exact(walk):
    """Every joint turning at a constant body velocity and the root moving on a straight line: the generated
    frames are the motion's own."""
    rng = np.random.default_rng(3)
    n, frames = 40, 12
    w = rng.normal(scale=1.5, size=(len(walk.bones), 3))
    R0 = so3.exp(rng.normal(scale=0.4, size=(len(walk.bones), 3)))
    t = np.arange(n) / walk.fps
    R = R0[None] @ so3.exp(t[:, None, None] * w[None])
    root = np.outer(t, [30.0, -12.0, 2.0]) + [1.0, 2.0, 35.0]
    take = replace(walk, rotations=R, root_translation=root, frame_start=1)
    before, after = take.crop(1, 10), take.crop(11 + frames, None)
    gap = inbetween(before, after, frames)
    assert gap.frames == frames and gap.fps == walk.fps and gap.bones == walk.bones
    np.testing.assert_allclose(gap.rotations, R[10:10 + frames], atol=1e-9)
    np.testing.assert_allclose(gap.root_translation, root[10:10 + frames], atol=1e-9)
    assert gap.frame_start == 11


def test_bridge_from_a_library_holding_the_take_gives_its_frames(walk, run):
    frames = 15
    before = walk.crop(walk.frame_start, walk.frame_start + 119)
    after = walk.crop(walk.frame_start + 120 + frames, None)
    truth = walk.rotations[120:120 + frames]
    gap = inbetween(before, after, frames, library=[walk])
    assert gap.meta["inbetween"]["generator"] == "bridge" and gap.meta["inbetween"]["start"] == 119
    err = np.degrees(so3.angle(np.swapaxes(gap.rotations, -1, -2) @ truth)).max(axis=0)
    legs = [i for leg in legs_of(walk).values() for i in leg]
    assert np.delete(err, legs).max() < 0.5  # the legs: the heels held where the take lets them slide a little
    assert err.max() < 5.0
    np.testing.assert_allclose(gap.root_translation, walk.root_translation[120:120 + frames], atol=0.05)
    # among other clips the take is found first and weighs the most (segments and the geodesic averaged by
    # 1 / (cost + floor))
    gap = inbetween(before, after, frames, library=[run, walk])
    assert gap.meta["inbetween"]["clip"] == walk.name and gap.meta["inbetween"]["segments"] == 2
    err = np.degrees(so3.angle(np.swapaxes(gap.rotations, -1, -2) @ truth)).max(axis=0)
    assert np.delete(err, legs).max() < 2.0 and err.max() < 5.0


def test_bridge_carries_the_context_velocity_into_a_segment_at_rest(walk):
    """The context turns its joints at constant body velocities w and moves its root at v into a pose the only
    library clip holds still: the bridge's segment (and the geodesic it is averaged with) start with the context's
    velocity (carry factor f0(t) = t (1 - t/T)^2, f0'(0) = 1), not at rest."""
    rng = np.random.default_rng(5)
    r = walk.bones.index(walk.root_bone)
    moved = [i for i in range(len(walk.bones)) if i != r and i not in sum(legs_of(walk).values(), ())]
    w = np.zeros((len(walk.bones), 3))
    w[moved] = rng.normal(scale=1.0, size=(len(moved), 3))
    v = np.array([40.0, -15.0, 0.0])
    P, p = walk.rotations[0], walk.root_translation[0]
    t = (np.arange(30) - 29) / walk.fps  # the context's last frame at t = 0, on the still pose
    still = replace(walk, rotations=np.repeat(P[None], 200, axis=0), root_translation=np.repeat(p[None], 200, axis=0),
                    frame_start=1, name="still")
    before = replace(walk, rotations=P[None] @ so3.exp(t[:, None, None] * w[None]),
                     root_translation=p + t[:, None] * v, frame_start=1, name="context")
    frames = 60
    gap = inbetween(before, still.crop(1, 20), frames, library=[still])
    assert gap.meta["inbetween"]["generator"] == "bridge"
    dt = 1.0 / walk.fps
    a1, a2 = (so3.log(np.swapaxes(P, -1, -2) @ gap.rotations[k]) for k in (0, 1))
    p1, p2 = gap.root_translation[0] - p, gap.root_translation[1] - p
    # the velocity at the seam from the first two generated frames, second order (exact for a quadratic)
    np.testing.assert_allclose(((4 * a1 - a2) / (2 * dt))[moved], w[moved], rtol=0, atol=0.02 * np.abs(w).max())
    np.testing.assert_allclose((4 * p1 - p2) / (2 * dt), v, rtol=0, atol=0.02 * np.abs(v).max())
    # and the gap ends on the still pose
    np.testing.assert_allclose(gap.rotations[-1][moved], P[moved], atol=1e-3)


def _steps(clip):
    heads, _t, _w = forward_kinematics(clip)
    r = clip.bones.index(clip.root_bone)
    root = np.linalg.norm(np.diff(heads[:, r], axis=0), axis=1)
    joints = np.degrees(np.linalg.norm(so3.relative_rotvecs(clip.rotations), axis=-1)).max(axis=1)
    return root, joints


@pytest.mark.parametrize("b_name,b_asf", [("bvh/09_02.bvh", None), ("cross_rig/002_03.bvh", None),
                                          ("acclaim/09_02.amc", "acclaim/09-run.asf")])
def test_walk_into_run_has_no_snap_and_no_pop(walk, b_name, b_asf):
    b = _read(b_name, b_asf)
    joined = transition(walk, b, frames=20)
    info = joined.meta["transition"]
    i, n = info["cut"]["a_frame"], info["frames"]
    assert joined.bones == walk.bones and joined.fps == walk.fps
    assert joined.frames == i + 1 + n + info["b_frames"]
    # A is kept as it is up to its cut
    np.testing.assert_allclose(joined.rotations[:i + 1], walk.rotations[:i + 1], atol=1e-12)
    np.testing.assert_allclose(joined.root_translation[:i + 1], walk.root_translation[:i + 1], atol=1e-12)
    root, joints = _steps(joined)
    src_root = max(_steps(walk)[0].max(), _steps(transition(walk, b, cut=(i, info["cut"]["b_frame"]),
                                                            frames=20))[0][i + n + 1:].max())
    seams = slice(i - 1, i + n + 3)
    assert root[seams].max() <= 1.5 * src_root
    assert joints[seams].max() <= max(_steps(walk)[1].max(), joints[i + n + 2:].max()) + 5.0


def test_same_rig_b_keeps_its_local_motion_and_timing(walk):
    b = _read("bvh/07_02.bvh")
    joined = transition(walk, b, cut=(150, 40), frames=10)
    kept = joined.rotations[150 + 1 + 10:]
    r = walk.bones.index(walk.root_bone)
    others = [k for k in range(len(walk.bones)) if k != r]
    np.testing.assert_allclose(kept[:, others], b.rotations[40:, others], atol=1e-12)
    # the root only turned about up, by one angle for every frame
    yaw = np.angle(np.exp(1j * (so3.heading(kept[:, r], np.eye(3)[2]) - so3.heading(b.rotations[40:, r],
                                                                                     np.eye(3)[2]))))
    assert np.ptp(yaw) < 1e-6


def test_b_without_root_translation_stands_where_a_goes(walk, run):
    """B with no root channels (an in-place clip): the joined clip still has A's root translation throughout, and
    B's part stands at the root where A's travel leads (its height B's rest height)."""
    still = replace(run, root_translation=None)
    joined = transition(walk, still, cut=(200, 40), frames=10)
    assert joined.root_translation is not None and joined.root_translation.shape == (joined.frames, 3)
    tail = joined.root_translation[200 + 11:]
    assert np.ptp(tail[:, :2], axis=0).max() < 1e-9  # B does not move: its root stays put on the ground
    assert np.linalg.norm(tail[0, :2] - walk.root_translation[200, :2]) < 5 * np.linalg.norm(
        walk.root_translation[201, :2] - walk.root_translation[200, :2]) * 11


def test_bad_requests_are_refused(walk, run):
    with pytest.raises(ShapeSigError, match="outside clip"):
        transition(walk, run, cut=(10, run.frames + 5))
    with pytest.raises(ShapeSigError, match="frames"):
        inbetween(walk, run, 0)
    with pytest.raises(ShapeSigError, match="too short"):
        best_cuts(walk.crop(walk.frame_start, walk.frame_start + 5), run)


def test_a_heel_down_across_the_gap_stays_put(walk):
    """A gap inside a stance of the real walk: the generated frames keep the heel on the ground path from its last
    known spot to its spot at the target (within 0.5 cm of that segment, never beyond its ends), as planted."""
    from blender_shapesig.core.blend.contacts import find_contacts
    from blender_shapesig.core.clip.skeleton import unit_meters

    legs = legs_of(walk)
    contacts = find_contacts(walk, legs)
    side, mask = next((s, c["heel"]) for s, c in contacts.items())
    runs = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    a, b = max(((s, e) for s, e in zip(runs[::2], runs[1::2] - 1)), key=lambda r: r[1] - r[0])
    frames = min(12, b - a - 6)
    assert frames >= 6
    k = a + 2
    before = walk.crop(walk.frame_start, walk.frame_start + k)
    after = walk.crop(walk.frame_start + k + frames + 1, None)
    gap = inbetween(before, after, frames)
    joined = replace(walk, rotations=np.concatenate([before.rotations, gap.rotations, after.rotations]),
                     root_translation=np.concatenate([before.root_translation, gap.root_translation,
                                                      after.root_translation]))
    heel = forward_kinematics(joined)[0][:, legs[side][2]]
    unit = unit_meters(walk, [(t, f) for t, _s, f in legs.values()])
    p = (heel[k + 1:k + 1 + frames] - heel[k])[:, :2] * unit
    d = (heel[k + 1 + frames] - heel[k])[:2] * unit
    along = p @ d / (d @ d)
    across = np.linalg.norm(p - np.outer(along, d), axis=1)
    assert across.max() < 0.005 and along.min() > -0.1 and along.max() < 1.1


def _heels(clip):
    """{side: (frames, 3)} heel positions in metres (``feet.feet_positions``; the rig's up is Z or Y)."""
    from blender_shapesig.core.blend.contacts import feet_positions
    from blender_shapesig.core.clip.skeleton import unit_meters, up_vector

    legs = legs_of(clip)
    unit = unit_meters(clip, [(t, f) for t, _s, f in legs.values()])
    up = up_vector(clip)
    basis = Body(clip).basis  # ground x, ground y, up
    return {s: (p["heel"] * unit) @ basis.T for s, p in feet_positions(clip, legs).items()}, up


@pytest.mark.parametrize("a_name,b_name", [("bvh/07_01.bvh", "bvh/09_02.bvh"), ("bvh/09_02.bvh", "bvh/07_01.bvh")])
def test_a_heel_the_gap_would_drag_over_the_floor_steps(a_name, b_name):
    """Walk into run and back at the best cut, 0.3 s between: the geodesic keeps both stance poses' heels low while
    the root travels on, which drags a heel over the floor (60-70 cm before the step was made); now no heel moves
    more than 5 cm on the ground while it stays within 2 cm of its floor (its lowest over the transition's frames
    and half a second either side), and a heel down at both seams is lifted in between."""
    a, b = _read(a_name), _read(b_name)
    joined = transition(a, b)
    info = joined.meta["transition"]
    i, n = info["cut"]["a_frame"], info["frames"]
    heels, _up = _heels(joined)
    lifted = False
    for side, p in heels.items():
        span = p[i:i + n + 2]
        half = int(round(0.5 * joined.fps))  # the floor: the heel's lowest over the span and 0.5 s either side
        low = span[:, 2] < p[max(i - half, 0):i + n + 2 + half, 2].min() + 0.02
        edges = np.flatnonzero(np.diff(np.concatenate([[0], low.astype(int), [0]])))
        for s, e in zip(edges[::2], edges[1::2]):  # each stretch of frames the heel stays low
            flat = span[s:e, :2]
            assert np.linalg.norm(flat[:, None] - flat[None], axis=-1).max() < 0.05
        lifted |= bool(span[:, 2].max() > span[:, 2].min() + 0.03 and low[0] and low[-1])
    assert lifted


def test_from_standing_b_is_placed_on_the_planted_heel():
    """Standing (13_32's end, the root still) into a walk whose first frames stand on the same heel: B is placed
    so that heel is down on A's spot, and it stays there through the generated frames (before, B's placement by
    the whole body's fit and the root's travel put it 22 cm away and the heel slid over the floor)."""
    a, b = _read("bvh/13_32.bvh"), _read("bvh/07_01.bvh")
    joined = transition(a, b)
    info = joined.meta["transition"]
    i, n = info["cut"]["a_frame"], info["frames"]
    ba, bb = Body(a), Body(_read("bvh/07_01.bvh"))
    shared = [s for s, col in (("L", 0), ("R", 2)) if ba.contacts[i, col] and bb.contacts[info["cut"]["b_frame"], col]]
    assert shared
    heels, _up = _heels(joined)
    for side in shared:
        span = heels[side][i:i + n + 2, :2]
        assert np.linalg.norm(span - span[0], axis=1).max() < 0.02


@pytest.mark.parametrize("b_name", ["bvh/07_02.bvh", "bvh/08_01.bvh"])
def test_from_standing_b_is_placed_on_the_planted_foot_with_its_heading(b_name):
    """Standing (13_32's end) into a walk that starts on the same foot: B's planted foot, heel *and* ball, comes down
    on A's (a rigid fit on the ground of both points, ``transition._planted_shift``), so the foot need not turn
    over the gap, where its ball would slide (before: the heel fitted alone, the ball 1.2 and 2.3 cm off)."""
    from blender_shapesig.core.blend.contacts import feet_positions
    from blender_shapesig.core.clip.skeleton import unit_meters, up_vector

    a, b = _read("bvh/13_32.bvh"), _read(b_name)
    joined = transition(a, b)
    info = joined.meta["transition"]
    i, n, j = info["cut"]["a_frame"], info["frames"], info["cut"]["b_frame"]
    ba, bb = Body(a), Body(b)
    shared = [s for s, col in (("L", 0), ("R", 2)) if ba.contacts[i, col] and bb.contacts[j, col]]
    assert shared
    legs = legs_of(joined)
    unit = unit_meters(joined, [(t, f) for t, _s, f in legs.values()])
    up = up_vector(joined)
    feet = feet_positions(joined, legs)
    for side in shared:
        for point in ("heel", "ball"):
            d = feet[side][point][i + n + 1] - feet[side][point][i]  # B's first frame against A's cut frame
            assert np.linalg.norm(d - (d @ up) * up) * unit < 0.005, (side, point)
