"""``shapesig.transition``: join the active action into another at their best cut (or a chosen one), with
generated frames between, as a new action. A thin operator: it parses its properties, calls
``transitions.make_transition`` (nothing is created on error), optionally assigns the result, and reports the cut.
See docs/transitions.md.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from ..core.errors import ShapeSigError, check_integer
from ..actions.scene_motion import timing_text
from .preconditions import armature_or_message, two_actions_or_message

__all__ = ["SHAPESIG_OT_transition", "classes"]


class SHAPESIG_OT_transition(bpy.types.Operator):
    """Play the active action, then hand over to another at the best place, with generated frames between (a new action; the sources are not changed)"""

    bl_idname = "shapesig.transition"
    bl_label = "Transition"
    bl_options = {"REGISTER", "UNDO"}

    action_b: StringProperty(name="To Action", description="The action to hand over to")
    best_cut: BoolProperty(name="Best Cut", description="Hand over where the two motions agree best (pose, "
                           "speed and planted feet over a short window)", default=True)
    frame_a: IntProperty(name="Leave At", description="The frame of the active action where it hands over")
    frame_b: IntProperty(name="Enter At", description="The frame of the other action where it takes over")
    frames: IntProperty(name="Frames", description="Generated frames between the two; 0: 0.3 s", default=0,
                        soft_min=0, soft_max=240)
    generator: EnumProperty(
        name="In-between", description="How the frames between are made",
        items=(("GEODESIC", "Ease", "Along the shortest path between the poses, carrying each motion's speed in "
                "and out"),
               ("LIBRARY", "From Library", "From the file's other actions: the stretch of motion that best "
                "bridges the gap, fitted to both ends")),
        default="GEODESIC")
    assign: BoolProperty(name="Assign Result", description="Make the transition the armature's active action",
                         default=True)
    strips: BoolProperty(name="As NLA Strips", description="Play the transition from a new NLA track as three "
                         "strips (the active action's part, the frames between, the other action's part) instead "
                         "of as the active action", default=False)
    cuts_for: StringProperty(name="Cuts For", description="The ranked places found when the dialog opened: the "
                             "other action's name, then leave/enter frames and costs, tab-separated",
                             options={"HIDDEN", "SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        obj = armature_or_message(cls, context)
        if obj is None:
            return False
        if obj.animation_data is None or obj.animation_data.action is None:
            cls.poll_message_set("The armature needs an active action to start from")
            return False
        return two_actions_or_message(cls, "A transition")

    def invoke(self, context, event):
        current = context.active_object.animation_data.action
        if not self.action_b or self.action_b == current.name:
            self.action_b = next((a.name for a in bpy.data.actions if a != current), "")
        self._rank(context.active_object, current)
        return context.window_manager.invoke_props_dialog(self, width=340)

    def _rank(self, obj, current):
        """The ranked places for the chosen action, shown in the dialog (the first two preset the frames)."""
        from ..blend.transitions import ranked_cuts

        other = bpy.data.actions.get(self.action_b) if self.action_b else None
        if other is None or other == current:
            return
        try:
            cuts = ranked_cuts(obj, current, other)
        except ShapeSigError:
            return
        if cuts:
            self.frame_a, self.frame_b = int(cuts[0][0]), int(cuts[0][1])
        self.cuts_for = "\t".join([other.name] + [f"{a}:{b}:{c:.3f}" for a, b, c in cuts])

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop_search(self, "action_b", bpy.data, "actions")
        layout.prop(self, "best_cut")
        parts = self.cuts_for.split("\t")
        if len(parts) > 1 and parts[0] == self.action_b:
            box = layout.box()
            box.label(text="Best places (leave at, enter at, difference):", icon="INFO")
            for k, text in enumerate(parts[1:]):
                a, b, c = text.split(":")
                box.label(text=f"{k + 1}. frame {a} to frame {b}  ({float(c):.2f})")
        col = layout.column()
        col.enabled = not self.best_cut
        col.prop(self, "frame_a")
        col.prop(self, "frame_b")
        layout.prop(self, "frames")
        layout.prop(self, "generator", expand=True)
        layout.prop(self, "strips")
        row = layout.row()
        row.enabled = not self.strips
        row.prop(self, "assign")

    def execute(self, context):
        from .. import compat
        from ..actions import action_io
        from ..blend.transitions import make_transition

        obj = context.active_object
        try:
            act_a = obj.animation_data.action
            act_b = bpy.data.actions.get(self.action_b) if self.action_b else None
            if act_b is None:
                raise ShapeSigError(f"no action named {self.action_b!r}" if self.action_b else
                                    "choose the action to hand over to")
            frames = check_integer(self.frames, "frames", minimum=0) or None
            cut = None if self.best_cut else (self.frame_a, self.frame_b)
            result = make_transition(obj, act_a, act_b, cut=cut, frames=frames,
                                     generator=self.generator.lower())
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Transition: {exc}")
            return {"CANCELLED"}
        if self.strips:
            from ..blend.transitions import place_as_strips

            try:
                place_as_strips(obj, result)
            except (ShapeSigError, RuntimeError):
                compat.remove_action(result.action)
                self.report({"ERROR"}, "Transition: the NLA strips could not be made; nothing was created")
                return {"CANCELLED"}
        elif self.assign:
            action_io.assign_action(obj, result.action)
        fa, fb = result.info["cut_frames"]
        self.report({"INFO"}, f"Transition: created {result.action.name}: {act_a.name} to frame {fa}, "
                              f"{result.info['frames']} frames between, {act_b.name} from frame {fb} "
                              f"({timing_text(result.action)}){', as NLA strips' if self.strips else ''}")
        return {"FINISHED"}


def menu_func(self, context):
    self.layout.operator(SHAPESIG_OT_transition.bl_idname, text="Transition (ShapeSig)")


# the 3D Viewport menus the entry joins (Object > Animation, Pose): operators/__init__.py registers them
menus = (("VIEW3D_MT_object_animation", menu_func), ("VIEW3D_MT_pose", menu_func))


classes = (SHAPESIG_OT_transition,)
