"""Action fingerprints that outlive the Blender session (``action_changes``, stored with the index): each test runs
real headless Blender sessions one after another, as separate processes, on one saved .blend of 12 actions. A
fresh session on the unchanged file reuses every stored fingerprint and ranks exactly as the session that stored
them; an edited key, an undo, a rename, a new action make that action (only) read again; a file changed on disk
trusts nothing. Every session ends by checking each action's fingerprint against ``read_hash`` of the action as it
is then (the independent truth)."""

import json
import os
import pathlib
import subprocess
import sys

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.core import search as search  # noqa: E402

ROOT = str(pathlib.Path(__file__).resolve().parents[3])

_SESSION = r"""
import dataclasses, json, sys
sys.path.insert(0, sys.argv[1])
import bpy
import blender_shapesig
from blender_shapesig import compat
from blender_shapesig.actions import action_changes, action_io
from blender_shapesig.search import library
from blender_shapesig.core.io.bvh import load_bvh
from blender_shapesig.readers.bvh import import_armature

blend, steps = sys.argv[2], json.loads(sys.argv[3])
blender_shapesig.register()
computed = []
real = action_changes.read_hash
def counting(action, *a, **k):
    computed.append(action.name)
    return real(action, *a, **k)
action_changes.read_hash = counting
out = {"clicks": []}

def key_of(action):
    fc = next(iter(compat.all_action_fcurves(action)))
    return fc.keyframe_points[3]

for step in steps:
    if step == "build":
        bpy.ops.wm.read_factory_settings(use_empty=True)
        arm, _ = import_armature(sys.argv[1] + "/tests/data/bvh/07_01.bvh")
        arm.name = "Rig"
        bpy.data.actions.remove(arm.animation_data.action)
        clips = [load_bvh(f"{sys.argv[1]}/tests/data/bvh/{n}.bvh") for n in ("07_01", "09_02", "13_32")]
        for n in range(12):
            c = clips[n % 3]
            c = dataclasses.replace(c, rotations=c.rotations[::8], root_translation=c.root_translation[::8], fps=15.0)
            a = action_io.write_action(c.crop(2 + n // 3, c.frame_end - n), armature=arm, name=f"act{n:02d}")
            if n == 0:
                action_io.assign_action(arm, a)
        bpy.ops.wm.save_as_mainfile(filepath=blend)
    elif step == "open":
        bpy.ops.wm.open_mainfile(filepath=blend)
        bpy.ops.ed.undo_push(message="opened")
    elif step == "edit":  # a key of the played action, as the Graph Editor changes it
        key_of(bpy.data.actions["act00"]).co.y += 0.25
        bpy.context.view_layer.update()
    elif step == "undo":
        bpy.ops.ed.undo_push(message="edited")
        bpy.ops.ed.undo()
    elif step == "rename":  # two names swapped: each name now holds the other's keys
        a, b = bpy.data.actions["act03"], bpy.data.actions["act04"]
        a.name, b.name, a.name = "tmp", "act03", "act04"
    elif step == "add":
        bpy.data.actions["act05"].copy().name = "act_new"
    elif step == "click":
        computed.clear()
        bpy.context.view_layer.objects.active = bpy.data.objects["Rig"]
        s = library.settings_of(bpy.context)
        s.use_file_actions, s.use_folders, s.top = True, False, 0
        assert bpy.ops.shapesig.rank() == {"FINISHED"}
        res = library.results_of(bpy.context)
        out["clicks"].append({"computed": sorted(computed), "stats": action_changes.store_stats(),
                              "rows": [(r.name, round(r.distance, 9)) for r in res.results]})
    elif step == "save":
        bpy.ops.wm.save_mainfile()
out["true"] = all(action_changes.action_fingerprint(a) == real(a) for a in bpy.data.actions)
print("RESULT" + json.dumps(out))
"""


@pytest.fixture
def session(tmp_path):
    """Run one fresh Blender session (a new process) doing ``steps`` on tmp_path/shots.blend; its report."""
    env = dict(os.environ, **{search.CACHE_ENV: str(tmp_path / "index")})
    blend = str(tmp_path / "shots.blend")

    def run(*steps):
        done = subprocess.run([sys.executable, "-c", _SESSION, ROOT, blend, json.dumps(steps)], env=env,
                              capture_output=True, text=True, timeout=600, cwd=ROOT)
        line = [ln for ln in done.stdout.splitlines() if ln.startswith("RESULT")]
        assert line, done.stderr[-3000:]
        report = json.loads(line[-1][len("RESULT"):])
        assert report["true"]  # every fingerprint is the action's read_hash as it is now
        return report

    run.blend = blend
    return run


ALL = [f"act{n:02d}" for n in range(12)]


def test_a_fresh_session_reuses_them_and_ranks_the_same(session):
    first = session("build", "open", "click")["clicks"][0]
    assert first["computed"] == ALL and first["stats"]["writes"] == 1
    again = session("open", "click", "click")["clicks"]
    assert again[0]["computed"] == [] and again[0]["stats"]["stored"] == 12
    assert again[0]["rows"] == first["rows"] and len(first["rows"]) == 11
    assert again[1]["computed"] == [] and again[1]["stats"]["writes"] == 0  # nothing new: not written again


@pytest.mark.parametrize("change, read", [("edit", ["act00"]), ("rename", ["act03", "act04"]),
                                          ("add", ["act_new"]), ("undo", ["act00"])])
def test_a_changed_action_is_read_again(session, change, read):
    session("build", "open", "click")
    steps = ["edit", "undo"] if change == "undo" else [change]
    click = session("open", *steps, "click")["clicks"][0]
    assert click["computed"] == read and click["stats"]["stored"] == 12 - len(read) + (change == "add")


def test_a_saved_edit_is_stored_and_an_edited_file_trusts_nothing(session):
    session("build", "open", "click")
    edited = session("open", "edit", "click", "save")["clicks"][0]
    assert edited["computed"] == ["act00"]
    reopened = session("open", "click")["clicks"][0]
    assert reopened["computed"] == [] and reopened["rows"] == edited["rows"]  # the file as saved
    st = os.stat(session.blend)
    os.utime(session.blend, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))  # written by something else
    assert session("open", "click")["clicks"][0]["computed"] == ALL
