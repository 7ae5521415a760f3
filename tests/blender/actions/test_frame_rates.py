"""Frame rates known or visibly assumed (issue 31), on the mixed file of ``mixed_scene`` saved and reopened: the
Acclaim import's 120 fps is known; Blender's BVH importer records none, so each action's rate is the scene's and
flagged as assumed until its source file is found in the library folders (then the file's Frame Time: 120 or 60);
Set Frame Rate records a rate (one undo step); a blend of the AMC walk with the Daz run lasts the weighted average
of the true durations in seconds when the rates are found, and its report names the assumed rate when not."""

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import frame_rates  # noqa: E402
from tests.helpers.mixed_scene import DATA, TRUE_FPS, activate, build, save_reopen  # noqa: E402


@pytest.fixture
def mixed(empty_file, tmp_path):
    frame_rates.forget()
    build(names=("07_01.001", "09_02", "002_03"))
    save_reopen(tmp_path / "mixed.blend")
    yield bpy.data
    frame_rates.forget()


def _true_seconds(name):
    first, last = bpy.data.actions[name].frame_range
    return (last - first) / TRUE_FPS[name]


def test_rates_known_or_assumed(mixed):
    assert frame_rates.rate_of(bpy.data.actions["07_01"])[:2] == (120.0, True)
    for name in ("07_01.001", "09_02", "002_03"):
        assert frame_rates.rate_of(bpy.data.actions[name])[:2] == (24.0, False), name
    bpy.context.scene.shapesig.folders = str(DATA)
    frame_rates.forget()
    for name in ("07_01.001", "09_02", "002_03"):
        fps, known, how = frame_rates.rate_of(bpy.data.actions[name])
        assert (fps, known) == (TRUE_FPS[name], True) and how.startswith("file "), (name, how)


def test_set_frame_rate_records_and_undoes(mixed):
    act = bpy.data.actions["09_02"]
    assert bpy.ops.shapesig.set_frame_rate(action="09_02", fps=120.0) == {"FINISHED"}
    assert act[frame_rates.RATE] == 120.0 and act[frame_rates.HOW] == "user"
    assert frame_rates.rate_of(act)[:2] == (120.0, True)
    with pytest.raises(RuntimeError, match="no source file of '09_02' found"):  # one line, nothing set
        bpy.ops.shapesig.set_frame_rate(action="09_02", fps=0.0)
    with pytest.raises(RuntimeError, match="not a plausible frame rate"):
        bpy.ops.shapesig.set_frame_rate(action="09_02", fps=5000.0)
    assert act[frame_rates.RATE] == 120.0


def _blend(reports):
    activate(bpy.data.objects["07-walk"])
    before = set(bpy.data.actions.keys())
    assert bpy.ops.shapesig.blend_actions(action_a="07_01", action_b="09_02", weight=0.5, feet="NONE",
                                          assign=False) == {"FINISHED"}
    new = [bpy.data.actions[n] for n in set(bpy.data.actions.keys()) - before]
    assert len(new) == 1
    first, last = new[0].frame_range
    return (last - first) / new[0]["shapesig_fps"]


def test_blend_lasts_the_weighted_average_in_seconds_when_rates_are_found(mixed):
    bpy.context.scene.shapesig.folders = str(DATA / "bvh")
    seconds = _blend(None)
    truth = 0.5 * _true_seconds("07_01") + 0.5 * _true_seconds("09_02")
    assert abs(seconds - truth) <= 0.05 * truth, (seconds, truth)


def test_blend_with_an_assumed_rate_says_so(mixed, capsys):
    from blender_shapesig.blend.blend_actions import blend_actions

    arm = bpy.data.objects["07-walk"]
    result = blend_actions(arm, bpy.data.actions["07_01"], bpy.data.actions["09_02"], [0.5])
    note = result.info["rate_note"]
    assert "'09_02'" in note and "24 fps" in note and "assumed" in note and "--" not in note
    # the operator reports it (a warning line) and the override field makes it known
    seconds = _blend(None)
    assert seconds > 1.5 * (0.5 * _true_seconds("07_01") + 0.5 * _true_seconds("09_02"))  # 24 fps assumed: long
    result = blend_actions(arm, bpy.data.actions["07_01"], bpy.data.actions["09_02"], [0.5], rates=[None, 120.0])
    assert result.info["rate_note"] is None
    clip = result.clips[0]
    truth = 0.5 * _true_seconds("07_01") + 0.5 * _true_seconds("09_02")
    assert abs((clip.frames - 1) / clip.fps - truth) <= 0.05 * truth
    for act in result.actions:
        bpy.data.actions.remove(act)


def _shown_rates():
    """{action: the 'Frame rate: ...' line the search panel shows with that action as the query, and the Blend
    dialog's rate label for it}: every action of the file, each with its armature active (the pose as the chosen
    Query Action)."""
    from types import SimpleNamespace

    from blender_shapesig.operators.blend import _draw_rate
    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d
    from tests.helpers.fake_layout import FakeLayout

    s = bpy.context.scene.shapesig
    out = {}
    for act in bpy.data.actions:
        arm = next((o for o in bpy.data.objects if o.animation_data and o.animation_data.action == act),
                   bpy.data.objects["07-walk"])
        activate(arm)
        s.query_action = "" if arm.animation_data.action == act else act.name
        lay = FakeLayout()
        SHAPESIG_PT_search_view3d.draw(SimpleNamespace(layout=lay), bpy.context)
        panel = [e[2]["text"] for e in lay.log if e[0] == "label" and e[2].get("text", "").startswith("Frame rate")]
        dialog = FakeLayout()
        _draw_rate(dialog, SimpleNamespace(fps_a=0.0), act.name, "fps_a")
        out[act.name] = (panel, dialog.labels())
    s.query_action = ""
    return out


def test_the_rates_shown_are_the_true_ones_or_flagged_as_assumed(mixed):
    """Done when (issue 31): in the panel and the Blend dialog, each action's rate is its true one (the Acclaim
    import's 120; the BVH files' Frame Time once their folder is known) or shown as assumed (the scene's 24, the
    one-frame pose always)."""
    from tests.helpers.mixed_scene import one_frame_pose

    one_frame_pose(bpy.data.objects["07-walk"])
    shown = _shown_rates()
    assert set(shown) == {"07_01", "07_01.001", "09_02", "002_03", "pose"}
    assert shown["07_01"] == (["Frame rate: 120 fps"], "120 fps")
    for name in ("07_01.001", "09_02", "002_03", "pose"):
        assert shown[name] == (["Frame rate: 24 fps (assumed: the scene's)"], "24 fps (assumed)"), name
    bpy.context.scene.shapesig.folders = str(DATA)
    frame_rates.forget()
    shown = _shown_rates()
    for name in ("07_01", "07_01.001", "09_02", "002_03"):
        fps = f"{TRUE_FPS[name]:.0f} fps"
        assert shown[name] == ([f"Frame rate: {fps}"], fps), name
    assert "assumed" in shown["pose"][0][0] and "assumed" in shown["pose"][1]
