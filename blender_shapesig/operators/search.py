"""Signature search operators (sidebar tab "ShapeSig"; settings and results in ``scene.shapesig``).

Thin: each parses the scene's settings, calls ``blender_shapesig.library`` (the scene's search library) and
reports. Preconditions (an armature, a query action, results to pick from) are checked in ``poll``
(``library.search_problem`` / ``library.result_problem``), whose message Blender shows on the greyed-out button
and in the error of a script's call.

* ``shapesig.build_index``: index every library clip not in the cache yet, stepping the one index generator
  (``core.index.iter_entries``): with a window modally, one clip per timer tick, with a progress bar (Esc
  cancels; what is done stays cached); without one (background, the bpy module, scripts) synchronously.
* ``shapesig.rank``: rank the library by sim^n against the query, optionally re-rank the best K by elastic
  distance; fills ``scene.shapesig.results``. Clips not in the index are computed on the way (and cached).
* ``shapesig.assign_result``: make the selected result the active armature's action (a folder clip is first
  written as a new action).
* ``shapesig.preview_result``: assign the result temporarily and play; run again to stop and restore.
* ``shapesig.clear_index``: delete the cache files.
"""

import bpy
from bpy.props import BoolProperty

from .. import action_io, library
from ..core import index
from ..core.errors import ShapeSigError
# names kept for scripts and tests written against this module (they live in ``library``)
from ..library import CACHES as _CACHES  # noqa: F401
from ..library import get_cache, library_items, missing_count, query_item, rank_into_settings

__all__ = ["classes", "get_cache", "query_item", "library_items", "rank_into_settings", "missing_count"]


def _tag_redraw(context):
    screen = getattr(context, "screen", None)
    for area in getattr(screen, "areas", ()):
        if area.type in ("VIEW_3D", "DOPESHEET_EDITOR", "NLA_EDITOR"):
            area.tag_redraw()


def _poll_with(problem):
    """A ``poll`` classmethod: refused with ``problem(context, settings)``'s one-line reason, if any."""

    def poll(cls, context):
        reason = problem(context, library.settings_of(context))
        if reason is not None:
            cls.poll_message_set(reason)
        return reason is None

    return classmethod(poll)


class SHAPESIG_OT_build_index(bpy.types.Operator):
    """Compute the signature index of every library clip not indexed yet (Esc cancels)"""

    bl_idname = "shapesig.build_index"
    bl_label = "Build Index"
    bl_options = {"REGISTER"}  # writes only the cache folder, never the .blend

    then_rank: BoolProperty(name="Then Rank", description="Run Find Similar when the index is complete",
                            default=False, options={"SKIP_SAVE", "HIDDEN"})

    _timer = None

    poll = _poll_with(library.search_problem)

    def _prepare(self, context):
        self.settings = library.settings_of(context)
        self.items = library.index_items(context, self.settings)
        self.cache = get_cache(context)
        self.errors = []
        self.steps = index.iter_entries(self.items, self.settings.level, self.cache, self.errors)
        self.done = 0
        self.before = dict(self.cache.stats)

    def _step(self):
        next(self.steps, None)
        self.done += 1

    def _finish(self, context, cancelled=False):
        s = self.settings
        s.index_running = False
        s.index_progress = 1.0 if not cancelled else s.index_progress
        computed = self.cache.stats["misses"] - self.before.get("misses", 0)
        msg = (f"index: {self.done} of {len(self.items)} clips, {computed} computed, "
               f"{self.done - computed} already indexed")
        if cancelled:
            msg = "cancelled; " + msg
        if self.errors:
            msg += f"; {len(self.errors)} could not be read ({self.errors[0]})"
        s.message = msg
        self.report({"WARNING"} if (self.errors or cancelled) else {"INFO"}, msg)
        _tag_redraw(context)
        if getattr(self, "then_rank", False) and not cancelled:
            try:
                bpy.ops.shapesig.rank()
            except RuntimeError:
                pass  # rank reported its error already

    def execute(self, context):
        try:
            self._prepare(context)
            while self.done < len(self.items):
                self._step()
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self._finish(context)
        return {"FINISHED"}

    def invoke(self, context, event):
        if context.window is None or bpy.app.background:
            return self.execute(context)
        try:
            self._prepare(context)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self.settings.index_running = True
        self.settings.index_progress = 0.0
        wm = context.window_manager
        wm.progress_begin(0, len(self.items))
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()

    def modal(self, context, event):
        if event.type == "ESC":
            self._end_modal(context)
            self._finish(context, cancelled=True)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if self.done < len(self.items):
                self._step()
        except Exception as exc:  # noqa: BLE001 - never leave a modal operator running after an error
            self._end_modal(context)
            self.settings.index_running = False
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self.settings.index_progress = self.done / max(len(self.items), 1)
        context.window_manager.progress_update(self.done)
        _tag_redraw(context)
        if self.done >= len(self.items):
            self._end_modal(context)
            self._finish(context)
            return {"FINISHED"}
        return {"RUNNING_MODAL"}


class SHAPESIG_OT_rank(bpy.types.Operator):
    """Rank the library by similarity (sim^n) to the query action"""

    bl_idname = "shapesig.rank"
    bl_label = "Find Similar"
    bl_options = {"REGISTER", "UNDO"}

    poll = _poll_with(library.search_problem)

    def invoke(self, context, event):
        # In the UI, when several clips still need indexing, index them first with the cancellable
        # progress bar (build_index ranks when it is done); otherwise rank at once.
        if context.window is not None and not bpy.app.background:
            try:
                missing = missing_count(context, library.settings_of(context))
            except ShapeSigError:
                missing = 0  # execute reports the problem
            if missing >= 2:
                bpy.ops.shapesig.build_index("INVOKE_DEFAULT", then_rank=True)
                return {"CANCELLED"}
        return self.execute(context)

    def execute(self, context):
        settings = library.settings_of(context)
        try:
            res = rank_into_settings(context, settings)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Rank: {exc}")
            settings.message = str(exc)
            return {"CANCELLED"}
        st = res.stats
        msg = (f"{len(res)} results from {st.get('library', 0)} clips ({st.get('misses', 0)} newly indexed, "
               f"{st.get('seconds', 0.0):.2f} s)")
        if res.warnings:
            msg += f"; {len(res.warnings)} warning(s): {res.warnings[0]}"
        self.report({"WARNING"} if res.warnings else {"INFO"}, msg)
        settings.message = msg
        _tag_redraw(context)
        return {"FINISHED"}


class SHAPESIG_OT_assign_result(bpy.types.Operator):
    """Make the selected result the active armature's action"""

    bl_idname = "shapesig.assign_result"
    bl_label = "Assign Result"
    bl_options = {"REGISTER", "UNDO"}

    poll = _poll_with(library.result_problem)

    def execute(self, context):
        settings = library.settings_of(context)
        try:
            obj, action = library.selected_action(context, settings)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Assign Result: {exc}")
            return {"CANCELLED"}
        action_io.assign_action(obj, action)  # the replaced action is kept (stashed) when nothing else uses it
        self.report({"INFO"}, f"{obj.name}: action {action.name!r}")
        return {"FINISHED"}


class SHAPESIG_OT_preview_result(bpy.types.Operator):
    """Play the selected result on the armature; run again to stop and restore its action"""

    bl_idname = "shapesig.preview_result"
    bl_label = "Preview Result"
    bl_options = {"REGISTER", "UNDO"}

    stop: BoolProperty(name="Stop", description="Stop the preview and restore the action", default=False,
                       options={"SKIP_SAVE"})

    poll = _poll_with(library.preview_problem)

    def execute(self, context):
        settings = library.settings_of(context)
        if settings.preview_object or self.stop:
            library.stop_preview(context, settings)
            self.report({"INFO"}, "preview stopped")
            return {"FINISHED"}
        try:
            obj, action = library.selected_action(context, settings)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Preview: {exc}")
            return {"CANCELLED"}
        library.start_preview(context, settings, obj, action)
        start, end = (int(v) for v in action.frame_range)
        self.report({"INFO"}, f"previewing {action.name!r} (frames {start}-{end}); run again to stop")
        return {"FINISHED"}


class SHAPESIG_OT_clear_index(bpy.types.Operator):
    """Delete the signature index files (they are rebuilt when needed)"""

    bl_idname = "shapesig.clear_index"
    bl_label = "Clear Index"
    bl_options = {"REGISTER"}

    def execute(self, context):
        try:
            cache = get_cache(context)
            n, size = cache.disk_usage()
            cache.clear()
        except OSError as exc:
            self.report({"ERROR"}, f"Clear Index: {exc}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"removed {n} index files ({size / 2 ** 20:.1f} MB)")
        return {"FINISHED"}


classes = (SHAPESIG_OT_build_index, SHAPESIG_OT_rank, SHAPESIG_OT_assign_result, SHAPESIG_OT_preview_result,
           SHAPESIG_OT_clear_index)
