"""Every text the panel and the operators show after a real session holds no thesis symbol and no Python exception
name (issue 38). On the mixed file of ``mixed_scene`` (CMU clips of tests/data on four rigs, the scene at 24 fps):
Find Similar (Motion and pose, Motion only with the timing check), Moments, Why Different, Assign and Preview of a
result of another rig, Blend with and without a loop, and refusals (a one-frame query, an out-of-range detail, a
loop of a pose, a result deleted since the search), and the Bone Map operators (Detect, Clear, Export, a bad map
file). Collected: every ``text`` the Motion Search and Bone Map panels
draw (walked with a recording stand-in for ``layout``, each result row's list item included), every operator report
(Blender prints them to stdout in background mode), the status line and the poll messages. The words come from one
place (``core.measure_words``): the column headers, the status line and the settings' names are those."""

import re

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.actions import frame_rates  # noqa: E402
from blender_shapesig.search import library  # noqa: E402
from blender_shapesig.core import search as search  # noqa: E402
from blender_shapesig.core.measure_words import ENGINES, MEASURES, OPTIONS, PANEL_NAME, THESIS_SYMBOLS  # noqa: E402
from tests.helpers.mixed_scene import activate, build, one_frame_pose  # noqa: E402

SYMBOL = re.compile("|".join(THESIS_SYMBOLS))
EXCEPTION_NAME = re.compile(r"\w*Error\b|\w*Exception\b|Traceback|NoneType|\bErrno\b")
REPORT = re.compile(r"^(Info|Warning|Error|Operator): (.*)$")


class Recorder:
    """A stand-in for ``UILayout``: every call's ``text`` (labels, props, operators, progress bars) goes to
    ``texts``; sub-layouts share the list; an operator's properties are a plain namespace."""

    def __init__(self, texts):
        self.texts = texts

    def __getattr__(self, name):
        def call(*args, **kwargs):
            if isinstance(kwargs.get("text"), str):
                self.texts.append(kwargs["text"])
            if name == "operator":
                return type("Props", (), {})()
            return Recorder(self.texts)

        return call

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)


class Session:
    """What a person read during the test: ``texts`` (panel, status line, poll messages) and ``reports``."""

    def __init__(self, capfd):
        self.capfd, self.texts, self.reports = capfd, [], []

    def panel(self):
        """Draw both panels and every result row; returns this drawing's texts."""
        from blender_shapesig.panels.rigmap import draw_bone_map
        from blender_shapesig.panels.search import SHAPESIG_UL_results, draw_search

        got = []
        draw_search(Recorder(got), bpy.context)
        draw_bone_map(Recorder(got), bpy.context)
        res = library.results_of(bpy.context)
        s = bpy.context.scene.shapesig
        item_list = type("List", (), {"layout_type": "DEFAULT"})()
        for row in res.results:
            SHAPESIG_UL_results.draw_item(item_list, bpy.context, Recorder(got), s, row, 0, s, "results_index")
        got.append(res.message)
        got.append(library.search_problem(bpy.context, s) or "")
        got.append(library.result_problem(bpy.context, s) or "")
        self.texts += got
        return got

    def run(self, op, *args, **kw):
        """Run an operator; a refusal is fine (its report is collected). Returns its result or None."""
        try:
            return op(*args, **kw)
        except RuntimeError as exc:  # an ERROR report, or a poll refusal: Blender's line holds our message
            text = str(exc).strip()
            m = REPORT.match(text)
            self.reports.append(m.group(2) if m else text)
            return None
        finally:
            self.collect()

    def collect(self):
        out = self.capfd.readouterr().out
        for line in out.splitlines():
            m = REPORT.match(line.strip())
            if m:
                self.reports.append(m.group(2))


def _bad(texts):
    return [t for t in texts if t and (SYMBOL.search(t) or EXCEPTION_NAME.search(t))]


@pytest.fixture
def session(empty_file, monkeypatch, tmp_path, capfd):
    monkeypatch.setenv(search.CACHE_ENV, str(tmp_path / "index"))
    frame_rates.forget()
    arms = build(names=("07_01.001", "09_02", "002_03"))
    one_frame_pose(arms["07_01"])
    activate(arms["07_01"])
    got = Session(capfd)
    got.collect()  # the import's own lines
    got.reports.clear()
    yield got
    frame_rates.forget()


def _select(res, source):
    res.results_index = next(i for i, r in enumerate(res.results) if r.source == source)


def test_no_text_of_a_session_holds_a_thesis_symbol_or_an_exception_name(session, tmp_path):
    ops, s = bpy.ops.shapesig, bpy.context.scene.shapesig
    res = library.results_of(bpy.context)
    session.panel()  # before any search
    # Find Similar, the default (Motion and pose)
    assert session.run(ops.rank) == {"FINISHED"}
    drawn = session.panel()
    assert res.order_by == "local" and f"{MEASURES['local'].column} \u25b2" in drawn
    assert any(t.startswith(f"{MEASURES['local'].label} = ") for t in drawn)
    # Motion only, the best ten checked for timing: the "sim^3 = 1.0817, d_S* = 8.2126"
    s.similarity = "sim"
    assert session.run(ops.rank) == {"FINISHED"}
    drawn = session.panel()
    assert res.order_by == "elastic" and f"{MEASURES['elastic'].column} \u25b2" in drawn
    assert MEASURES["sim"].column in drawn  # the other column's header
    assert any(t.startswith(f"{MEASURES['sim'].label} = ") and f", {MEASURES['elastic'].label} = " in t
               for t in drawn), drawn
    assert f"sorted by {MEASURES['elastic'].status};" in res.message
    assert any(f"sorted by {MEASURES['elastic'].status} (best first)" in t for t in drawn)
    # Why Different, then Assign and Preview of another rig's take (retargeted), then Blend of the query and it
    _select(res, "002_03")
    assert session.run(ops.explain_result) == {"FINISHED"}
    session.panel()
    assert session.run(ops.preview_result) == {"FINISHED"}
    session.panel()
    assert session.run(ops.preview_result, stop=True) == {"FINISHED"}
    _select(res, "09_02")
    assert session.run(ops.assign_result) == {"FINISHED"}
    session.panel()
    assert session.run(ops.blend_actions, action_a="07_01", action_b="09_02", weight=0.5) == {"FINISHED"}
    got = session.run(ops.blend_actions, action_a="07_01", action_b="07_01.001", weight=0.5, loop=True, fps_b=120)
    assert got == {"FINISHED"}, session.reports[-1]
    # Moments (the issue: the label said sim^3 while the value was sim^2), Why Different and Assign of a moment
    activate(bpy.data.objects["07-walk"])
    bpy.data.objects["07-walk"].animation_data.action = bpy.data.actions["07_01"]
    s.use_windows = True
    assert session.run(ops.rank) == {"FINISHED"}
    drawn = session.panel()
    assert res.results and res.order_by in ("local", "sim", "elastic") and res.results[0].frame_last
    assert session.run(ops.explain_result) == {"FINISHED"}
    assert session.run(ops.assign_result) == {"FINISHED"}
    session.panel()
    s.use_windows = False
    # refusals: a loop of a one-frame pose, A and B the same, an out-of-range detail, a one-frame query, a result
    # whose action was deleted since the search
    assert session.run(ops.blend_actions, action_a="07_01", action_b="pose", weight=0.5, loop=True) is None
    assert session.run(ops.blend_actions, action_a="07_01", action_b="07_01", weight=0.5) is None
    s.level = 7
    session.panel()
    assert any(t.startswith(f"{OPTIONS['level'].status.capitalize()}: expected") for t in session.texts)
    assert session.run(ops.rank) is None
    s.level = 3
    s.query_action = "pose"
    session.run(ops.rank)
    session.panel()
    s.query_action = "07_01"
    assert session.run(ops.rank) == {"FINISHED"}
    _select(res, "09_02")
    bpy.data.actions.remove(bpy.data.actions["09_02"])
    assert session.run(ops.assign_result) is None
    assert session.run(ops.explain_result) is None
    session.panel()
    # the Bone Map panel's operators on the iClone rig, and a map file that is no map
    activate(bpy.data.objects["002_03"])
    for op in (ops.bone_map_detect, ops.bone_map_clear):
        assert session.run(op) == {"FINISHED"}
        session.panel()
    assert session.run(ops.bone_map_export, filepath=str(tmp_path / "iclone.json")) == {"FINISHED"}
    (tmp_path / "bad.json").write_text("{not json")
    assert session.run(ops.bone_map_import, filepath=str(tmp_path / "bad.json")) is None
    session.panel()
    # what was read is real: the reports of each kind are there
    reports = " | ".join(session.reports)
    for needle in ("results from", "largest share:", "previewing", "preview stopped", "action",
                   "Blend Actions: created",
                   "loop of", "same action", "too short to loop", "no longer exists", "Detect Bone Map:",
                   "Clear Bone Map:", "bones written to", "Import Bone Map:"):
        assert needle in reports, needle
    assert len(session.texts) > 200 and len(session.reports) >= 15
    bad = _bad(session.texts) + _bad(session.reports)
    assert not bad, "\n".join(bad)


def test_the_settings_and_the_panel_take_their_names_from_the_one_source(addon):
    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d
    from blender_shapesig.properties import ShapeSigResult, ShapeSigSettings

    props = ShapeSigSettings.bl_rna.properties
    items = props["similarity"].enum_items
    assert props["similarity"].name == OPTIONS["similarity"].label
    for key in ("local", "sim"):
        assert items[key].name == ENGINES[key].label and items[key].description == ENGINES[key].tooltip
    assert props["use_windows"].name == ENGINES["moments"].label
    for key in ("level", "rerank", "depth"):
        assert props[key].name == OPTIONS[key].label and props[key].description == OPTIONS[key].tooltip
    row = ShapeSigResult.bl_rna.properties
    assert row["distance"].name == MEASURES["sim"].label and row["elastic"].name == MEASURES["elastic"].label
    assert "d_S*" in row["elastic"].description and "sim^n" in row["distance"].description  # symbols: tooltips
    assert SHAPESIG_PT_search_view3d.bl_label == PANEL_NAME
