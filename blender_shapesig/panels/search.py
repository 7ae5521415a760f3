"""Sidebar tab "ShapeSig" (3D Viewport, Dope Sheet and NLA sidebars): the Motion Search panel, with the query,
the library, Build Index and Find Similar, the results list and, for the selected result, Assign, Preview,
Blend and "Why different". It only draws: preconditions are the operators' ``poll``, shown as a label
(``library.search_problem``). See docs/search.md, "In Blender".
"""

import json

import bpy

from ..search import library, result_rows
from ..core.elastic.explain import top_joints
from ..core.measure_words import ENGINES, MEASURES, OPTIONS, PANEL_NAME, measure_words
from ..core.metrics import LOCAL
from ..properties import column_word
from ..search.results import expected_hash, take_moments

# the "Why different" box: bars of the largest shares, and the cost over time in this many cells
EXPLAIN_BARS = 5
STRIP_CELLS = 24
PICTURE_SCALE = 6.0  # the active row's picture and the Why Different strips, in icon sizes

__all__ = ["classes", "SHAPESIG_UL_results", "draw_search"]


class SHAPESIG_UL_results(bpy.types.UIList):
    """Ranked results: unique label, the sort column first (the timing-aligned difference when re-ranked, else the
    similarity or the local search's score), the other measure, and the clip's frames / matched window; partial
    matches greyed with their bones compared."""

    bl_idname = "SHAPESIG_UL_results"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        icon = "ACTION" if item.is_action else "FILE"
        if self.layout_type in {"DEFAULT", "COMPACT"}:
            row = layout.row(align=True)
            split = row.split(factor=0.45)
            # a partial match (few shared bones) is greyed out, with the number of bones it was compared on
            split.active = not item.partial
            text = (item.label or item.name) + (f" (partial, {item.coverage:.0%})" if item.partial else "")
            if item.preview_icon:  # the row's picture of key poses, once made (thumbnails.py)
                split.label(text=text, icon_value=item.preview_icon)
            else:
                split.label(text=text, icon=icon)
            nums = split.row(align=True)
            sim = ("~" if item.approximate else "") + f"{item.distance:.4f}"
            if library.results_of(context).order_by == result_rows.ELASTIC_COLUMN and item.has_elastic:
                nums.label(text=f"{item.elastic:.3f}")
                nums.label(text=sim)
            else:
                nums.label(text=sim)
                nums.label(text=f"{item.elastic:.3f}" if item.has_elastic else "")
            nums.label(text=f"{item.frame_first}-{item.frame_last}" if item.frame_last else f"{item.frames} f")
        else:
            layout.alignment = "CENTER"
            layout.label(text="", icon=icon)


def _header(layout, results):
    """Column names over the list, the sort column first and marked with an arrow."""
    row = layout.row(align=True)
    split = row.split(factor=0.45)
    split.label(text="Clip")
    nums = split.row(align=True)
    nums.label(text=f"{measure_words(results.order_by).column} \u25b2")
    second = {result_rows.ELASTIC_COLUMN: MEASURES["sim"].column, result_rows.LOCAL_COLUMN: ""}
    nums.label(text=second.get(results.order_by, MEASURES["elastic"].column))
    nums.label(text="Frames")


def _draw_moment_steps(layout, res):
    """For a moment: its place among the take's moments and buttons to step along the take's timeline."""
    order = take_moments(res.results, res.results_index)
    if len(order) < 2:
        return
    row = layout.row(align=True)
    row.label(text=f"Moment {order.index(res.results_index) + 1} of {len(order)} in this take", icon="SEQUENCE")
    row.operator("shapesig.step_moment", icon="TRIA_LEFT", text="").step = -1
    row.operator("shapesig.step_moment", icon="TRIA_RIGHT", text="").step = 1


def _progress(row, what, factor):
    """A progress bar (``UILayout.progress``, Blender 4.0+) of a running modal operator."""
    row.progress(factor=factor, type="BAR", text=f"{what} {factor:.0%} (Esc cancels)")


def _message(layout, text, icon="INFO"):
    box = layout.box()
    for i, line in enumerate(_wrap(text, 48)):
        box.label(text=line, icon=icon if i == 0 else "BLANK1")


def _wrap(text, width):
    words, lines, cur = str(text).split(), [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    if cur:
        lines.append(cur)
    return lines or [""]


def _sentence(text):
    return text[:1].upper() + text[1:] + ("" if text.endswith(".") else ".")


def _draw_query(layout, s, obj):
    col = layout.column(align=True)
    col.label(text="Query", icon="ARMATURE_DATA")
    col.prop_search(s, "query_action", bpy.data, "actions", text="")
    current = getattr(getattr(obj, "animation_data", None), "action", None)
    if not s.query_action and current is not None and obj.type == "ARMATURE":
        col.label(text=f"Active action: {current.name}")
    query = bpy.data.actions.get(s.query_action) if s.query_action else current
    if query is not None:
        _draw_rate(col, query)
    row = col.row(align=True)
    row.prop(s, "use_frame_range")
    sub = row.row(align=True)
    sub.active = s.use_frame_range
    sub.prop(s, "frame_start", text="")
    sub.prop(s, "frame_end", text="")


def _draw_rate(col, action):
    """The action's frame rate (assumed ones say so, in the warning colour) and the button to set it."""
    from ..actions.frame_rates import rate_of, rate_text

    fps, known, how = rate_of(action)
    row = col.row(align=True)
    row.alert = not known
    text = f"Frame rate: {rate_text(fps)}" + ("" if known else " (assumed: the scene's)")
    row.label(text=text, icon="TIME")
    op = row.operator("shapesig.set_frame_rate", text="", icon="PREFERENCES")
    op.action = action.name


def _draw_library(layout, s):
    col = layout.column(align=True)
    col.label(text="Library", icon="ASSET_MANAGER")
    row = col.row(align=True)
    row.prop(s, "use_file_actions", toggle=True)
    row.prop(s, "use_folders", toggle=True)
    if s.use_file_actions:
        row = col.row(align=True)
        row.prop(s, "name_filter", text="", icon="FILTER")
        row.prop(s, "assets_only", text="", icon="ASSET_MANAGER")
        if s.assets_only:
            col.prop(s, "catalog", text="", icon="OUTLINER_COLLECTION")
    if s.use_folders:
        col.prop(s, "folders", text="")
        col.prop(s, "asf", text="Skeleton (.asf)")
    col.prop(s, "crop_start")
    row = col.row(align=True)  # how every clip is read
    row.prop(s, "trim", expand=True)
    row.prop(s, "fps")


def _draw_search(layout, context, s):
    col = layout.column(align=True)
    col.prop(s, "use_windows", toggle=True, icon="SEQUENCE")
    signatures = s.use_windows or s.similarity != LOCAL
    sub = col.row(align=True)
    sub.active = not s.use_windows  # moments rank by sim^2 windows
    sub.prop(s, "similarity", text="")
    row = col.row(align=True)
    row.active = signatures  # the local search has its own second stage
    row.prop(s, "level")
    row.prop(s, "rerank")
    row = col.row(align=True)
    row.prop(s, "top")
    sub = row.row(align=True)
    sub.active = signatures and s.rerank > 0
    sub.prop(s, "depth")
    if signatures and s.level >= library.COSTLY_LEVEL:
        ref = library.COST_REFERENCE
        _message(layout, f"{OPTIONS['level'].label} {s.level} is costly: {ref['clips']} clips took "
                         f"{ref['seconds']:.0f} s and {ref['bytes'] / 1e6:.0f} MB of index; indexing asks first "
                         f"with an estimate.", "ERROR")
    results = library.results_of(context)
    row = layout.row(align=True)
    if results.running:
        _progress(row, "Ranking", results.progress)
        row = layout.row(align=True)
    if s.index_running:
        _progress(row, "Indexing", s.index_progress)
    else:
        row.operator("shapesig.build_index", icon="FILE_REFRESH")
    row = layout.row()
    row.scale_y = 1.3
    row.operator("shapesig.rank", icon="VIEWZOOM")
    problem = library.search_problem(context, s)
    if problem is not None:
        _message(layout, _sentence(problem), "ERROR")


def _draw_results(layout, s, res):
    if res.message:
        _message(layout, res.message)
    if not res.results:
        layout.label(text="No results yet.", icon="INFO")
        return
    layout.label(text=f"Similar to {res.query_name}, sorted by {column_word(res.order_by)} (best first); "
                      f"click took {res.seconds:.2f} s")
    _header(layout, res)
    layout.template_list("SHAPESIG_UL_results", "", res, "results", res, "results_index", rows=6)
    if not 0 <= res.results_index < len(res.results):
        layout.label(text="Select a result.", icon="INFO")
        return
    item = res.results[res.results_index]
    info = layout.column(align=True)
    if res.order_by == result_rows.LOCAL_COLUMN:
        info.label(text=f"{MEASURES['local'].label} = {item.distance:.4f} ({ENGINES['local'].status})")
    else:
        info.label(text=f"{MEASURES['sim'].label} = {item.distance:.4f}"
                   + (f", {MEASURES['elastic'].label} = {item.elastic:.4f}" if item.has_elastic else ""))
    window = f"frames {item.frame_first}-{item.frame_last}" if item.frame_last else f"{item.frames} frames"
    info.label(text=f"{window}, compared on {item.shared} bones ({item.coverage:.0%} of the joints both rigs have)")
    _draw_moment_steps(layout, res)
    if item.partial:
        info.label(text="Partial match: ranked after the whole-body matches", icon="ERROR")
    if item.unmapped:
        info.label(text=f"Unmapped: {item.unmapped}", icon="BONE_DATA")
    if item.read_last:  # trimming cut rest-pose / ramp frames: the frames compared and those read
        info.label(text=f"trimmed: frames {item.kept_first}-{item.kept_last} compared of "
                   f"{item.read_first}-{item.read_last} read", icon="INFO")
    if item.spec:
        info.label(text=item.spec, icon="FILE")
    if item.preview_icon:  # the larger picture of the active row
        layout.template_icon(icon_value=item.preview_icon, scale=PICTURE_SCALE)
    _draw_explanation(layout, item)
    row = layout.row(align=True)
    row.operator("shapesig.assign_result", icon="CHECKMARK", text="Assign")
    if s.preview_object:
        op = row.operator("shapesig.preview_result", icon="PAUSE", text="Stop")
        op.stop = True
    else:
        row.operator("shapesig.preview_result", icon="PLAY", text="Preview")
    query = res.query_name
    sub = row.row(align=True)
    sub.enabled = item.is_action and bool(query)
    op = sub.operator("shapesig.blend_actions", icon="MOD_DATA_TRANSFER", text="Blend")
    op.action_a = query
    op.action_b = item.source if item.is_action else ""
    if item.frame_last:  # a moment blends its window, written by Assign or Preview
        sub.enabled = bool(query) and item.window_action in bpy.data.actions
        op.action_b = item.window_action
        if not sub.enabled:
            layout.label(text="Assign or preview the moment to blend it.", icon="INFO")
    elif not item.is_action:
        layout.label(text="Assign a file result to blend it.", icon="INFO")
    op.expect_b = expected_hash(item, op.action_b)  # a B replaced since the search is refused
    if item.is_action and not item.frame_last:
        row = layout.row()
        row.enabled = bool(query)
        row.operator("shapesig.transition", icon="NEXT_KEYFRAME", text="Transition to this").action_b = item.source


def _strip(values, cells):
    """``values`` (cost per query interval) averaged into ``cells`` bins, scaled to the largest (0..1)."""
    n = len(values)
    if n == 0:
        return []
    bins = [values[i * n // cells:max((i + 1) * n // cells, i * n // cells + 1)] for i in range(min(cells, n))]
    means = [sum(b) / len(b) for b in bins]
    top = max(means)
    return [m / top if top > 0 else 0.0 for m in means]


def _draw_explanation(layout, item):
    """Why different: the largest joint (group) shares as bars and the alignment cost along the query as a strip
    (``core.elastic.explain``); a button computes it when the search did not."""
    box = layout.box()
    head = box.row(align=True)
    head.label(text="Why different", icon="ARMATURE_DATA")
    head.operator("shapesig.explain_result", text="", icon="FILE_REFRESH")
    if not item.explain:
        box.label(text="Press the button to explain this result.")
        return
    try:
        ex = json.loads(item.explain)
    except ValueError:
        return
    if ex.get("resampled"):  # a long take, compared at a lower rate (core.elastic.explain.fit_intervals)
        box.label(text=ex["resampled"], icon="INFO")
    key = "groups" if ex.get("groups") else "joints"
    col = box.column(align=True)
    for name, share in top_joints(ex, EXPLAIN_BARS, key):
        row = col.row(align=True)
        split = row.split(factor=0.4)
        split.label(text=name)
        split.progress(factor=float(share), type="BAR", text=f"{share:.0%}")
    if key == "groups":
        col.label(text="Joints: " + ", ".join(f"{n} {v:.0%}" for n, v in top_joints(ex, 3)))
    if item.why_query_path and item.why_result_path:  # both clips' key poses, matched by the alignment
        from ..search.thumbnails import icon_of

        for text, path in (("Query", item.why_query_path), ("This result, at the matched times", item.why_result_path)):
            icon = icon_of(path)
            if icon:
                box.label(text=text)
                box.template_icon(icon_value=icon, scale=PICTURE_SCALE)
    cells = _strip(ex.get("cost_over_time", []), STRIP_CELLS)
    if cells:
        box.label(text="Cost along the query (start to end)")
        row = box.row(align=True)
        for v in cells:
            row.progress(factor=v, type="BAR", text="")


def draw_search(layout, context):
    """Draw the search UI into ``layout`` (shared by the three sidebar panels): query, library, search and
    results. What the operators need is their ``poll``'s business (their buttons grey out); the panel shows
    the same reason (``library.search_problem``)."""
    s = library.settings_of(context)
    if s is None:
        layout.label(text="ShapeSig settings are not registered", icon="ERROR")
        return
    _draw_query(layout, s, getattr(context, "active_object", None))
    _draw_library(layout, s)
    _draw_search(layout, context, s)
    _draw_results(layout, s, library.results_of(context))


class _SearchPanel:
    bl_label = PANEL_NAME
    bl_region_type = "UI"
    bl_category = "ShapeSig"

    def draw(self, context):
        draw_search(self.layout, context)


class SHAPESIG_PT_search_view3d(_SearchPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_search_view3d"
    bl_space_type = "VIEW_3D"


class SHAPESIG_PT_search_dopesheet(_SearchPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_search_dopesheet"
    bl_space_type = "DOPESHEET_EDITOR"


class SHAPESIG_PT_search_nla(_SearchPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_search_nla"
    bl_space_type = "NLA_EDITOR"


classes = (SHAPESIG_UL_results, SHAPESIG_PT_search_view3d, SHAPESIG_PT_search_dopesheet, SHAPESIG_PT_search_nla)
