"""Stepping through the moments of a take (Moments lists every occurrence): ``shapesig.step_moment`` selects the next
or previous moment of the selected result's take along its timeline, previewing it when a preview plays. Thin: it
calls ``results.step_moment`` and reports; the precondition is ``results.moment_problem`` in ``poll``."""

import bpy
from bpy.props import IntProperty

from ..search import library, results
from .modal_job import tag_redraw

__all__ = ["classes"]


class SHAPESIG_OT_step_moment(bpy.types.Operator):
    """Select the next or previous moment of this take along its timeline (a running preview plays it)"""

    bl_idname = "shapesig.step_moment"
    bl_label = "Step Through Moments"
    bl_options = {"REGISTER", "UNDO"}

    step: IntProperty(name="Step", description="1: the next moment in the take, -1: the previous one", default=1,
                      min=-1, max=1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        reason = results.moment_problem(context, library.settings_of(context))
        if reason is not None:
            cls.poll_message_set(reason)
        return reason is None

    def execute(self, context):
        row, place, count = results.step_moment(context, library.settings_of(context), 1 if self.step >= 0 else -1)
        self.report({"INFO"}, f"moment {place} of {count} in {row.label or row.name}: frames "
                              f"{row.frame_first}-{row.frame_last}")
        tag_redraw(context)
        return {"FINISHED"}


classes = (SHAPESIG_OT_step_moment,)
