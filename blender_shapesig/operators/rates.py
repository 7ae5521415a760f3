"""``shapesig.set_frame_rate``: record an action's frame rate (the panel's per-action override, one undo step):
the rate given, else the one its source file says (``frame_rates.found_rate``). See docs/action_io.md.
"""

import bpy
from bpy.props import FloatProperty, StringProperty

from ..core.errors import ShapeSigError

__all__ = ["SHAPESIG_OT_set_frame_rate", "classes"]


class SHAPESIG_OT_set_frame_rate(bpy.types.Operator):
    """Record the frame rate an action was captured at (search and blends read it at this rate)"""

    bl_idname = "shapesig.set_frame_rate"
    bl_label = "Set Frame Rate"
    bl_options = {"REGISTER", "UNDO"}

    action: StringProperty(name="Action", description="The action (empty: the active armature's action)")
    fps: FloatProperty(name="Frame Rate", description="Frames per second it was captured at (0: the rate its "
                       "source file says, when found)", default=0.0, soft_min=0.0, soft_max=240.0)

    def _action(self, context):
        if self.action:
            return bpy.data.actions.get(self.action)
        obj = context.active_object
        return getattr(getattr(obj, "animation_data", None), "action", None)

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if getattr(getattr(obj, "animation_data", None), "action", None) is None and not bpy.data.actions:
            cls.poll_message_set("No action to set a frame rate on")
            return False
        return True

    def invoke(self, context, event):
        from ..actions.frame_rates import rate_of

        act = self._action(context)
        if act is not None and not self.fps:
            self.fps = rate_of(act, context)[0]
        return context.window_manager.invoke_props_dialog(self, width=300)

    def execute(self, context):
        from ..actions.frame_rates import found_rate, rate_text, record

        act = self._action(context)
        if act is None:
            raise ShapeSigError(f"no action named {self.action!r}" if self.action else "no active action")
        if self.fps:
            record(act, self.fps, "user")
        else:
            found = found_rate(act, context)
            if found is None:
                raise ShapeSigError(f"no source file of {act.name!r} found: type its frame rate")
            record(act, found[0], f"file {bpy.path.basename(found[1])}")
        self.report({"INFO"}, f"Set Frame Rate: {act.name} at {rate_text(act['shapesig_fps'])}")
        return {"FINISHED"}


classes = (SHAPESIG_OT_set_frame_rate,)
