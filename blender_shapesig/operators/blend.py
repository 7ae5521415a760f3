"""``shapesig.blend_actions``: time-aligned SRVT geodesic blends of two actions (issue 6).

A thin operator: it parses its properties, calls ``blend_actions.blend_actions`` (read both actions, blend,
write new actions ``<A>_x_<B>_<weight>`` with a fake user; nothing is created on error), optionally assigns the
first blend, and reports. See docs/blending.md.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..core.blend import blend_weights
from ..core.errors import MAX_INBETWEENS, ShapeSigError, check_integer, check_weight
from ..core.metrics import DEFAULT_DEPTH

__all__ = ["SHAPESIG_OT_blend_actions", "classes"]


class SHAPESIG_OT_blend_actions(bpy.types.Operator):
    """Blend two actions of the active armature along the SRVT geodesic (time-aligned) into new actions"""

    bl_idname = "shapesig.blend_actions"
    bl_label = "Blend Actions"
    bl_options = {"REGISTER", "UNDO"}

    action_a: StringProperty(name="Action A", description="The action at weight 0")
    action_b: StringProperty(name="Action B", description="The action at weight 1")
    weight: FloatProperty(
        name="Weight", description="0 gives A, 1 gives B (used when In-betweens is 1); a value outside [0, 1] "
        "is refused", default=0.5, soft_min=0.0, soft_max=1.0, subtype="FACTOR")
    align: BoolProperty(
        name="Align", description="Time-align B to A by the elastic (dynamic programming) warp first",
        default=True)
    depth: IntProperty(
        name="Depth", description="Largest step of the alignment's dynamic programming", default=DEFAULT_DEPTH,
        soft_min=1, soft_max=30)
    inbetweens: IntProperty(
        name="In-betweens",
        description=f"Number of blended actions; more than 1 gives evenly spaced weights i/(K+1) (at most "
                    f"{MAX_INBETWEENS}; more is refused)",
        default=1, soft_min=1, soft_max=MAX_INBETWEENS)
    frames: IntProperty(
        name="Length", description="Frames of each blend; 0: automatic ((1-w) A + w B frames)",
        default=0, soft_min=0, soft_max=100_000)
    bone_subset: EnumProperty(
        name="Bones",
        description="Which bones to blend; the others keep A's motion (in the blended timing)",
        items=(
            ("ALL", "All Shared", "Every bone animated in both actions"),
            ("SELECTED", "Selected", "The selected pose bones"),
            ("LIST", "List", "A comma-separated list of bone names"),
        ),
        default="ALL")
    bone_list: StringProperty(name="Bone List", description="Comma-separated bone names")
    root: EnumProperty(
        name="Root Motion",
        description="How the root translation is made",
        items=(
            ("BLEND", "Blend", "Blend root displacements in the heading frame, time-aligned"),
            ("A", "Keep A", "Keep A's root path (in the blended timing)"),
        ),
        default="BLEND")
    assign: BoolProperty(
        name="Assign Result", description="Make the (first) blend the armature's active action",
        default=True)

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != "ARMATURE":
            cls.poll_message_set("The active object must be an armature")
            return False
        if len(bpy.data.actions) < 2:
            cls.poll_message_set("Blending needs two actions in the file")
            return False
        return True

    def invoke(self, context, event):
        obj = context.active_object
        if obj is not None and obj.type == "ARMATURE":
            current = obj.animation_data.action if obj.animation_data else None
            if not self.action_a and current is not None:
                self.action_a = current.name
            if not self.action_b:
                for act in bpy.data.actions:
                    if act.name != self.action_a:
                        self.action_b = act.name
                        break
        return context.window_manager.invoke_props_dialog(self, width=360)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop_search(self, "action_a", bpy.data, "actions")
        layout.prop_search(self, "action_b", bpy.data, "actions")
        row = layout.row()
        row.enabled = self.inbetweens == 1
        row.prop(self, "weight", slider=True)
        layout.prop(self, "inbetweens")
        layout.prop(self, "align")
        row = layout.row()
        row.enabled = self.align
        row.prop(self, "depth")
        layout.prop(self, "frames")
        layout.prop(self, "bone_subset")
        if self.bone_subset == "LIST":
            layout.prop(self, "bone_list")
        layout.prop(self, "root")
        layout.prop(self, "assign")

    def _fail(self, message):
        self.report({"ERROR"}, f"Blend Actions: {message}")
        return {"CANCELLED"}

    def _bones(self, obj):
        """The bone subset (None: every shared bone); ShapeSigError when the subset is empty."""
        from ..blend_actions import selected_bone_names

        if self.bone_subset == "SELECTED":
            bones = selected_bone_names(obj)
            if not bones:
                raise ShapeSigError("no pose bones are selected")
            return bones
        if self.bone_subset == "LIST":
            bones = [b.strip() for b in self.bone_list.split(",") if b.strip()]
            if not bones:
                raise ShapeSigError("the bone list is empty")
            return bones
        return None

    def _weights(self):
        """The blend weights; the values a script may set outside the sliders' soft limits are refused here
        (the properties have no hard limits: those would clamp weight=5 to 1 silently)."""
        check_weight(self.weight)
        check_integer(self.depth, "depth", minimum=1)
        if self.frames != 0:
            check_integer(self.frames, "length", minimum=2)
        return blend_weights(self.inbetweens, self.weight)  # in-betweens within 1..MAX_INBETWEENS

    def execute(self, context):
        from .. import action_io
        from ..blend_actions import blend_actions

        obj = context.active_object
        wm = context.window_manager if getattr(context, "window", None) is not None else None
        try:
            if not self.action_a or not self.action_b:
                raise ShapeSigError("choose two actions A and B")
            acts = [bpy.data.actions.get(n) for n in (self.action_a, self.action_b)]
            for name, act in zip((self.action_a, self.action_b), acts):
                if act is None:
                    raise ShapeSigError(f"no action named {name!r}")
            weights = self._weights()
            show = wm is not None and len(weights) > 1
            if show:
                wm.progress_begin(0, 2 * len(weights))
            try:
                result = blend_actions(obj, acts[0], acts[1], weights, align=self.align, depth=self.depth,
                                       frames=self.frames or None, bones=self._bones(obj),
                                       root="a" if self.root == "A" else "blend",
                                       progress=(lambda i, n: wm.progress_update(i)) if show else None)
            finally:
                if show:
                    wm.progress_end()
        except ShapeSigError as exc:
            return self._fail(str(exc))
        if self.assign:
            action_io.assign_action(obj, result.actions[0])
        note = ""
        if result.unmatched:
            note = f"; {len(result.unmatched)} bone(s) animated only in A keep A's motion"
        names = ", ".join(act.name for act in result.actions)
        self.report({"INFO"}, f"Blend Actions: created {len(result.actions)} action(s): {names}{note}")
        return {"FINISHED"}


def menu_func(self, context):
    self.layout.operator(SHAPESIG_OT_blend_actions.bl_idname, text="Blend Actions (ShapeSig)")


_MENUS = ("VIEW3D_MT_object_animation", "VIEW3D_MT_pose")


def menu_register():
    for name in _MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(menu_func)


def menu_unregister():
    for name in _MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(menu_func)


classes = (SHAPESIG_OT_blend_actions,)
