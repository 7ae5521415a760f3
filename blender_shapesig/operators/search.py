"""The Motion Search panel's operators (tab "ShapeSig"; settings in ``scene.shapesig``): ``shapesig.build_index``,
``shapesig.rank`` (Find Similar, with an optional elastic re-rank), ``shapesig.assign_result``,
``shapesig.preview_result``, ``shapesig.clear_index`` and ``shapesig.explain_result``. Thin: they parse the
settings, call ``library`` (a click: ``rank_job``) and report (a failure is one line through ``errors_ui``'s guard); preconditions are in ``poll`` (``library.search_problem`` /
``result_problem``). See docs/search.md and docs/dev/blender_layer.md.
"""

import time

import bpy
from bpy.props import BoolProperty

from ..search import library, rank_job, results
from ..core import search as index
from ..core.elastic.explain import top_joints
from ..core.measure_words import OPTIONS
from ..core.errors import ShapeSigError, error_line
# names kept for scripts and tests written against this module (they live in ``library``)
from ..search.library import get_cache
from ..properties import index_level, uses_local
from .modal_job import ModalJob, tag_redraw
from ..actions.scene_motion import timing_text

__all__ = ["classes"]


def _poll_with(problem):
    """A ``poll`` classmethod: refused with ``problem(context, settings)``'s one-line reason, if any."""

    def poll(cls, context):
        reason = problem(context, library.settings_of(context))
        if reason is not None:
            cls.poll_message_set(reason)
        return reason is None

    return classmethod(poll)


def _confirm_cost(op, context, event, settings):
    """Before a costly (level-4) index in the UI: a confirmation with the estimated time and disk.
    None to go on, else the invoke's return value (the dialog; OK runs the operator again, confirmed)."""
    if op.confirmed or settings is None or index_level(settings) < library.COSTLY_LEVEL \
            or context.window is None \
            or bpy.app.background:
        return None
    try:
        clips, seconds, nbytes = library.index_cost(context, settings)
    except ShapeSigError:
        return None  # execute reports the problem
    if clips == 0:
        return None
    text = f"{OPTIONS['level'].label} {settings.level}: {library.cost_text(clips, seconds, nbytes)}"
    op.confirmed = True
    return context.window_manager.invoke_confirm(op, event, title=op.bl_label, message=text,
                                                 confirm_text="Index", icon="WARNING")


class _IndexingJob(ModalJob):
    """A click that may index the library: a costly level asks first (``_confirm_cost``)."""

    def _ask(self, context, event):
        return _confirm_cost(self, context, event, library.settings_of(context))


class SHAPESIG_OT_build_index(_IndexingJob, bpy.types.Operator):
    """Compute the signature index of every library clip not indexed yet (Esc cancels)"""

    bl_idname = "shapesig.build_index"
    bl_label = "Build Index"
    bl_options = {"REGISTER"}  # writes only the cache folder, never the .blend

    then_rank: BoolProperty(name="Then Rank", description="Run Find Similar when the index is complete",
                            default=False, options={"SKIP_SAVE", "HIDDEN"})
    confirmed: BoolProperty(options={"SKIP_SAVE", "HIDDEN"}, default=False)

    poll = _poll_with(library.search_problem)
    OP_NAME, RUNNING, PROGRESS = "build_index", "index_running", "index_progress"

    def _panel(self, context):
        return library.settings_of(context)

    def _again(self):
        return {"then_rank": self.then_rank}

    def _start(self, context):
        self.settings = library.settings_of(context)
        self.lib = library.search_library(context, self.settings)  # folder files are hashed in the steps
        self.total = self.lib.size
        self.cache = get_cache(context)
        self.errors = []
        self.computed = []
        self.steps = library.index_steps(self.lib, index_level(self.settings), self.cache, self.errors,
                                         local=uses_local(self.settings), computed=self.computed)
        self.done = 0

    def _work(self):
        """One clip a tick."""
        if self.done < self.total:
            next(self.steps, None)
            self.done += 1

    def _fraction(self):
        return self.done / max(self.total, 1)

    def _finished(self):
        return self.done >= self.total

    def _cancel(self, context):
        return self._finish(context, cancelled=True)

    def _done(self, context):
        return self._finish(context)

    def _finish(self, context, cancelled=False):
        s = self.settings
        s.index_running = False
        s.index_progress = 1.0 if not cancelled else s.index_progress
        # a clip that fails to read is counted apart, never as computed
        failed = len(self.errors)
        computed = len(self.computed)
        msg = (f"index: {self.done} of {self.total} clips, {computed} computed, "
               f"{self.done - computed - failed - self.lib.unkeyed} already indexed")
        if cancelled:
            msg = "cancelled; " + msg
        if self.errors:
            msg += f"; {failed} could not be read ({self.errors[0]})"
        msg += self.lib.skipped_text()
        if self.cache.warning:  # the index folder could not be used: one line, however many clips
            msg += f"; {self.cache.warning}"
        library.results_of(context).message = msg
        self.report({"WARNING"} if (self.errors or cancelled or self.lib.skipped or self.cache.warning) else {"INFO"},
                    msg)
        tag_redraw(context)
        if getattr(self, "then_rank", False) and not cancelled:
            try:
                bpy.ops.shapesig.rank()
            except RuntimeError:
                pass  # rank reported its error already
        return {"CANCELLED"} if cancelled else {"FINISHED"}


class SHAPESIG_OT_rank(_IndexingJob, bpy.types.Operator):
    """Rank the library by how similar each clip's motion is to the query action, as the Similarity choice says
    (Esc cancels a long ranking)"""

    bl_idname = "shapesig.rank"
    bl_label = "Find Similar"
    # no UNDO: the click writes only transient UI state (window_manager.shapesig_results), never the file, so it
    # pushes no whole-file undo step
    bl_options = {"REGISTER"}

    confirmed: BoolProperty(options={"SKIP_SAVE", "HIDDEN"}, default=False)

    poll = _poll_with(library.search_problem)
    OP_NAME, RUNNING, PROGRESS = "rank", "running", "progress"

    def _panel(self, context):
        return library.results_of(context)

    def _start(self, context):
        # the click's start (invoke): the panel reports its whole time
        self.job = rank_job.RankJob(context, library.settings_of(context), started=getattr(self, "t0", None))

    def _work(self):
        """Several quick steps a tick, one slow one at most."""
        t_end = time.perf_counter() + 0.05
        while not self.job.step() and time.perf_counter() < t_end:
            pass

    def _fraction(self):
        return self.job.progress

    def _finished(self):
        return self.job.finished

    def _done(self, context):
        msg = self.job.store()
        library.results_of(context).running = False
        self.report({"WARNING"} if self.job.warnings or self.job.failed or self.job.skipped else {"INFO"}, msg)
        tag_redraw(context)
        return {"FINISHED"}

    def _fail(self, context, exc):
        library.results_of(context).message = error_line(exc)
        return ModalJob._fail(self, context, exc)

    def _cancel(self, context):
        out = library.results_of(context)
        out.running = False
        out.message = (f"Find Similar cancelled after {time.perf_counter() - self.job.t0:.2f} s "
                       f"({self.job.indexed} clips newly indexed stay in the index)")
        self.report({"WARNING"}, out.message)
        tag_redraw(context)
        return {"CANCELLED"}

    def invoke(self, context, event):
        self.t0 = time.perf_counter()  # the click: the panel reports its whole time
        return ModalJob.invoke(self, context, event)


def _kept_text(action):
    """'; retargeted from another rig, 3 bones without a counterpart keep their rest: a, b, c' or ''."""
    rows = library.results_of().results
    row = next((r for r in rows if action.name in (r.on_armature, r.window_action, r.source)), None)
    if row is None or not row.kept and row.on_armature != action.name and "shapesig_retargeted_from" not in action:
        return ""
    kept = [b for b in row.kept.split(", ") if b]
    text = "; retargeted from another rig through the bone maps"
    if kept:
        text += (f", {len(kept)} bone(s) without a counterpart keep their rest: {', '.join(kept[:6])}"
                 + (", ..." if len(kept) > 6 else ""))
    return text


class SHAPESIG_OT_assign_result(bpy.types.Operator):
    """Make the selected result the active armature's action (the replaced one is kept in the NLA)"""

    bl_idname = "shapesig.assign_result"
    bl_label = "Assign Result"
    bl_options = {"REGISTER", "UNDO"}

    poll = _poll_with(library.result_problem)

    def execute(self, context):
        obj, action, note = results.assign_result(context, library.settings_of(context))
        self.report({"INFO"}, f"{obj.name}: action {action.name!r} ({timing_text(action)}){_kept_text(action)}"
                              f"{'; ' + note if note else ''}")
        return {"FINISHED"}


class SHAPESIG_OT_preview_result(bpy.types.Operator):
    """Play the selected result on the armature; run again to stop and restore exactly what was there"""

    bl_idname = "shapesig.preview_result"
    bl_label = "Preview Result"
    bl_options = {"REGISTER", "UNDO"}

    stop: BoolProperty(name="Stop", description="Stop the preview and restore the action", default=False,
                       options={"SKIP_SAVE"})

    poll = _poll_with(library.preview_problem)

    def execute(self, context):
        settings = library.settings_of(context)
        if settings.preview_object or self.stop:
            results.stop_preview(context, settings)
            self.report({"INFO"}, "preview stopped")
            return {"FINISHED"}
        action = results.preview_result(context, settings)
        start, end = (int(v) for v in action.frame_range)
        self.report({"INFO"}, f"previewing {action.name!r} (frames {start}-{end}: {timing_text(action)})"
                              f"{_kept_text(action)}; run again to stop")
        return {"FINISHED"}


class SHAPESIG_OT_explain_result(bpy.types.Operator):
    """Why the selected result differs from the query: each joint's share of the timing-aligned difference (the
    elastic distance d_S*) and the alignment cost over the query's time"""

    bl_idname = "shapesig.explain_result"
    bl_label = "Why Different"
    bl_options = {"REGISTER"}  # writes only the transient result row

    poll = _poll_with(library.result_problem)

    def execute(self, context):
        out = results.explain_result(context, library.settings_of(context))
        name, share = top_joints(out, 1, "groups" if out.get("groups") else "joints")[0]
        note = f"; {out['resampled'][0].lower()}{out['resampled'][1:]}" if out.get("resampled") else ""
        self.report({"INFO"}, f"largest share: {name} {share:.0%}{note}")
        tag_redraw(context)
        return {"FINISHED"}


class SHAPESIG_OT_clear_index(bpy.types.Operator):
    """Delete the signature index files the add-on wrote (they are rebuilt when needed)"""

    bl_idname = "shapesig.clear_index"
    bl_label = "Clear Index"
    bl_options = {"REGISTER"}

    def execute(self, context):
        cache = get_cache(context)
        n, size = cache.disk_usage()
        cache.clear()
        msg = f"removed {n} index files ({size / 2 ** 20:.1f} MB)"
        if cache.warning:  # a folder that is not the cache's own: nothing in it was touched
            self.report({"WARNING"}, f"{msg}; {cache.warning}")
        else:
            self.report({"INFO"}, msg)
        return {"FINISHED"}


classes = (SHAPESIG_OT_build_index, SHAPESIG_OT_rank, SHAPESIG_OT_assign_result, SHAPESIG_OT_preview_result,
           SHAPESIG_OT_clear_index, SHAPESIG_OT_explain_result)
