"""The file's library across rigs (issue 31), on the mixed file of ``mixed_scene`` saved and reopened, with the
scene at 24 fps and the source files' rates found: actions join the library through their rig's canonical joints
and are read with the armature that plays them, so Find Similar from each rig (Acclaim 07_01 and 16_15, the Daz
07_01 and 02_03, the iClone 002_03, the MotionBuilder 16_15) finds the same take on the other rig first; Moments
with a one-frame pose in the file give results and no traceback."""

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import frame_rates  # noqa: E402
from blender_shapesig.search import rig_library  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from tests.helpers.mixed_scene import DATA, activate, build, one_frame_pose, save_reopen  # noqa: E402

# query action -> (its armature, the same take on another rig)
SAME = {"07_01": ("07-walk", "07_01.001"), "07_01.001": ("07_01", "07_01"), "002_03": ("002_03", "02_03"),
        "02_03": ("02_03", "002_03"), "16_15": ("16", "16_15.001"), "16_15.001": ("16_15", "16_15")}


@pytest.fixture(scope="module")
def mixed_path(tmp_path_factory, addon):
    path = tmp_path_factory.mktemp("mixed") / "mixed.blend"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    frame_rates.forget()
    build(amc=(("07_01", "07-walk"), ("16_15", "16")))
    one_frame_pose(bpy.data.objects["07-walk"])
    bpy.context.scene.shapesig.folders = str(DATA)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


@pytest.fixture
def mixed(mixed_path, monkeypatch, tmp_path):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path.parent / "mixed-index"))
    frame_rates.forget()
    bpy.ops.wm.open_mainfile(filepath=str(mixed_path))
    yield bpy.data
    frame_rates.forget()


def _rank(query):
    arm_name, _same = SAME[query]
    activate(bpy.data.objects[arm_name])
    assert bpy.data.objects[arm_name].animation_data.action.name == query
    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    return [r for r in bpy.context.window_manager.shapesig_results.results]


def test_the_library_of_the_iclone_rig_holds_the_daz_take(mixed):
    listed = [a.name for a in rig_library.library_actions(bpy.data.objects["002_03"])]
    assert "02_03" in listed and "07_01" in listed, listed
    # the pose no armature plays fits both Acclaim rigs: its slot tells whose it is (4.4+); without slots (4.2)
    # it cannot be told and the library leaves it out rather than guess
    assert ("pose" in listed) == compat.is_layered(bpy.data.actions["pose"]), listed
    rows = _rank("002_03")
    assert "02_03" in [r.source for r in rows]


@pytest.mark.parametrize("similarity", ["local", "sim"])
@pytest.mark.parametrize("query", sorted(SAME))
def test_find_similar_from_each_rig_finds_the_same_take_first(mixed, query, similarity):
    # both Similarity choices: the default (the local search; its twin rule puts the same take in another file
    # first) and "Motion only (signatures)"
    assert bpy.context.scene.shapesig.similarity == "local"
    bpy.context.scene.shapesig.similarity = similarity
    rows = _rank(query)
    assert rows[0].source == SAME[query][1], [(r.source, round(r.distance, 3), r.partial) for r in rows]


def test_moments_with_a_one_frame_pose(mixed):
    bpy.context.scene.shapesig.use_windows = True
    rows = _rank("07_01")
    assert rows and "pose" not in [r.source for r in rows[:1]]
    msg = bpy.context.window_manager.shapesig_results.message
    assert "Error" not in msg and "Traceback" not in msg
    # a clip sharing few of the query's moving joints is marked partial and ranked after the others
    partial = [r.partial for r in rows]
    assert partial == sorted(partial)


def test_one_pass_players_equal_asking_each_armature(mixed):
    """``owners.playing_map`` (one pass over the armatures, what the library asks per click) gives every action
    the armatures ``owners.players`` finds by asking each armature and each slot's users: here with an action in
    an NLA strip of another armature, one action played by two armatures and one played by none."""
    from blender_shapesig.actions import owners

    arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    walk, run = bpy.data.objects["07-walk"], bpy.data.objects["09_02"]
    track = run.animation_data.nla_tracks.new()
    track.strips.new("walk", 1, bpy.data.actions["07_01"])  # 07_01 is 07-walk's active action too
    played = owners.playing_map(arms)
    assert {o.name for o in played[bpy.data.actions["07_01"].as_pointer()]} == {walk.name, run.name}
    for action in bpy.data.actions:
        want = owners.players(action, arms)
        assert played.get(action.as_pointer(), []) == want, action.name
    assert owners.players(bpy.data.actions["pose"], arms) == []
