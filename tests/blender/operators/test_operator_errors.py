"""Every operator's failure is one line: whatever escapes an operator (OSError, MemoryError, a removed
data-block's ReferenceError) is reported as one ERROR line with CANCELLED, its traceback on the console, and no
state stays set (``running``, ``index_running``, timers); a query action removed during a modal rank ends it
cleanly."""

import time
from types import SimpleNamespace

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig import errors_ui, operators  # noqa: E402
from blender_shapesig.search import library  # noqa: E402
from tests.helpers.stand_in import stand_in  # noqa: E402
from tests.helpers.operator_scene import cache_env, operator_error, rig  # noqa: E402,F401 - fixtures

FAILURES = (OSError(28, "No space left on device", "/index/x.npz"), MemoryError(),
            ReferenceError("StructRNA of type Action has been removed"), ValueError("cannot reshape array"))
LINES = ("/index/x.npz: No space left on device", "out of memory", "data it was using was removed meanwhile",
         "internal error (cannot reshape array); the console has the details")


def test_every_operator_method_is_guarded(addon):
    seen = 0
    for cls in operators.classes:
        for name in ("execute", "invoke", "modal"):
            method = getattr(cls, name, None)
            if method is not None:
                assert getattr(method, errors_ui.GUARDED, False), f"{cls.__name__}.{name}"
                seen += 1
    assert seen >= len(operators.classes)


@pytest.mark.parametrize("exc, line", list(zip(FAILURES, LINES)), ids=["OSError", "MemoryError", "ReferenceError", "bug"])
def test_search_operators_report_any_failure_in_one_line(rig, monkeypatch, capfd, exc, line):
    def fail(*_args, **_kw):
        raise exc

    monkeypatch.setattr(library, "search_library", fail)
    res, settings = library.results_of(bpy.context), bpy.context.scene.shapesig
    for op, label in ((bpy.ops.shapesig.rank, "Find Similar"), (bpy.ops.shapesig.build_index, "Build Index")):
        for mode in ("EXEC_DEFAULT", "INVOKE_DEFAULT"):
            msg = operator_error(op, **{}) if mode == "EXEC_DEFAULT" else _invoke_error(op)
            assert f"{label}: {line}" in msg and type(exc).__name__ not in msg, msg
            assert not res.running and not settings.index_running
    assert "Traceback" in capfd.readouterr().err  # the console keeps it


def _invoke_error(op):
    with pytest.raises(RuntimeError) as info:
        op("INVOKE_DEFAULT")
    msg = str(info.value).strip()
    assert "\n" not in msg and "Traceback" not in msg, msg
    return msg


def test_result_and_blend_operators_report_any_failure_in_one_line(rig, monkeypatch):
    from blender_shapesig.blend import blend_actions
    from blender_shapesig.search import results

    assert bpy.ops.shapesig.rank() == {"FINISHED"}
    actions = sorted(a.name for a in bpy.data.actions)
    monkeypatch.setattr(results, "read_hash", lambda action: (_ for _ in ()).throw(MemoryError()))
    assert operator_error(bpy.ops.shapesig.assign_result) == "Error: Assign Result: out of memory"
    monkeypatch.setattr(blend_actions, "make_blends", lambda *a, **k: (_ for _ in ()).throw(OSError(5, "I/O")))
    assert operator_error(bpy.ops.shapesig.blend_actions, action_a="walk", action_b="run") == "Error: Blend Actions: I/O"
    assert sorted(a.name for a in bpy.data.actions) == actions


def _stand():
    """An object with the rank operator's modal methods (a window is needed to start it for real)."""
    from blender_shapesig.operators.search import SHAPESIG_OT_rank as Op

    return stand_in(Op)


@pytest.mark.parametrize("indexed", [False, True], ids=["while indexing", "after indexing"])
def test_removing_the_query_during_a_modal_rank_ends_cleanly(rig, indexed):
    ctx = bpy.context
    res = library.results_of(ctx)
    if indexed:
        assert bpy.ops.shapesig.build_index() == {"FINISHED"}
    op = _stand()
    op.t0 = time.perf_counter()
    op._start(ctx)
    res.running = True  # as invoke sets it
    bpy.data.actions.remove(rig.animation_data.action)
    timer = SimpleNamespace(type="TIMER")
    for _ in range(1000):
        got = op.modal(ctx, timer)
        if got != {"RUNNING_MODAL"}:
            break
    assert got in ({"FINISHED"}, {"CANCELLED"}) and not res.running and op._timer is None
    kind, msg = op.reports[-1]
    assert "\n" not in msg and "Traceback" not in msg
    if got == {"FINISHED"}:
        assert res.query_name == "walk" and len(res.results) == 3
    else:
        assert kind == {"ERROR"} and "removed" in msg
