"""``shapesig.blend_actions``: time-aligned SRVT geodesic blends of two actions (issue 6).

On the active armature, reads actions A and B (``action_io.read_action``, keyed bones only), blends
them with ``core.blend.blend_clip_series`` (one elastic warp for every in-between) and writes each
blend as a new action ``<A>_x_<B>_<weight>`` with a fake user (``action_io.write_action``). A and B
are never modified; on any error nothing is created. See docs/blending.md.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..core.blend import blend_clip_series, blend_weights
from ..core.errors import ShapeSigError

__all__ = ["SHAPESIG_OT_blend_actions", "armature_up_axis", "unique_action_name", "classes"]


def armature_up_axis(armature, bone_name):
    """The world's up (+Z) in the rest frame of ``bone_name`` (where its location and rotation
    channels live), as a unit 3-vector; None when the bone does not exist."""
    bone = armature.data.bones.get(bone_name) if bone_name else None
    if bone is None:
        return None
    obj_rot = armature.matrix_world.to_3x3().normalized()
    rest = bone.matrix_local.to_3x3().normalized()
    # world vector -> armature space -> bone rest space
    up = rest.transposed() @ (obj_rot.transposed() @ _z_axis())
    n = up.length
    if n < 1e-9:
        return None
    return tuple(c / n for c in up)


def _z_axis():
    from mathutils import Vector

    return Vector((0.0, 0.0, 1.0))


def unique_action_name(base, taken=()):
    """``base`` when no action has that name, else ``base_2``, ``base_3``, ... (Blender would turn a
    taken ``walk_x_run_0.50`` into ``walk_x_run_0.001``: it reads ``.50`` as a number suffix)."""
    if base not in bpy.data.actions and base not in taken:
        return base
    k = 2
    while f"{base}_{k}" in bpy.data.actions or f"{base}_{k}" in taken:
        k += 1
    return f"{base}_{k}"


def _selected_bone_names(armature):
    names = []
    for pb in armature.pose.bones:
        # 5.0: PoseBone.select; 4.2: Bone.select
        sel = pb.select if "select" in pb.bl_rna.properties else pb.bone.select
        if sel:
            names.append(pb.name)
    return names


class SHAPESIG_OT_blend_actions(bpy.types.Operator):
    """Blend two actions of the active armature along the SRVT geodesic (time-aligned) into new actions"""

    bl_idname = "shapesig.blend_actions"
    bl_label = "Blend Actions"
    bl_options = {"REGISTER", "UNDO"}

    action_a: StringProperty(name="Action A", description="The action at weight 0")
    action_b: StringProperty(name="Action B", description="The action at weight 1")
    weight: FloatProperty(
        name="Weight", description="0 gives A, 1 gives B (used when In-betweens is 1)",
        default=0.5, min=0.0, max=1.0, subtype="FACTOR")
    align: BoolProperty(
        name="Align", description="Time-align B to A by the elastic (dynamic programming) warp first",
        default=True)
    depth: IntProperty(
        name="Depth", description="Largest step of the alignment's dynamic programming", default=9,
        min=1, max=30)
    inbetweens: IntProperty(
        name="In-betweens",
        description="Number of blended actions; more than 1 gives evenly spaced weights i/(K+1)",
        default=1, min=1, max=99)
    frames: IntProperty(
        name="Length", description="Frames of each blend; 0: automatic ((1-w) A + w B frames)",
        default=0, min=0, max=1_000_000)
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
        # Errors (no armature, missing actions) are reported by execute with a clear message.
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

    def execute(self, context):
        from .. import action_io

        obj = context.active_object
        if obj is None or obj.type != "ARMATURE":
            return self._fail("the active object must be an armature")
        if not self.action_a or not self.action_b:
            return self._fail("choose two actions A and B")
        act_a = bpy.data.actions.get(self.action_a)
        act_b = bpy.data.actions.get(self.action_b)
        for name, act in ((self.action_a, act_a), (self.action_b, act_b)):
            if act is None:
                return self._fail(f"no action named {name!r}")
        if act_a == act_b:
            return self._fail(f"A and B are the same action {act_a.name!r}; choose two different actions")

        bones = None
        if self.bone_subset == "SELECTED":
            bones = _selected_bone_names(obj)
            if not bones:
                return self._fail("no pose bones are selected")
        elif self.bone_subset == "LIST":
            bones = [b.strip() for b in self.bone_list.split(",") if b.strip()]
            if not bones:
                return self._fail("the bone list is empty")

        wm = getattr(context, "window_manager", None)
        progress = wm is not None and getattr(context, "window", None) is not None and self.inbetweens > 1
        created = []
        try:
            weights = blend_weights(self.inbetweens, self.weight)
            a = action_io.read_action(act_a, armature=obj, exclude_unkeyed=True)
            b = action_io.read_action(act_b, armature=obj, exclude_unkeyed=True)
            up = armature_up_axis(obj, a.root_bone)
            if bones is not None:
                shared = set(a.bones) & set(b.bones)
                missing = [x for x in bones if x not in shared]
                if missing:
                    raise ShapeSigError(
                        f"bone(s) {', '.join(missing[:5])} are not animated in both {act_a.name!r} and "
                        f"{act_b.name!r}")
            if progress:
                wm.progress_begin(0, 2 * len(weights))
            try:
                clips = blend_clip_series(
                    a, b, weights, align=self.align, depth=self.depth, frames=self.frames or None,
                    bones=bones, root="a" if self.root == "A" else "blend", up_axis=up,
                    progress=(lambda i, n: wm.progress_update(i)) if progress else None)
                names = []
                for clip in clips:
                    names.append(unique_action_name(clip.name, names))
                for i, clip in enumerate(clips):
                    act = action_io.write_action(clip, armature=obj, name=names[i], fake_user=True,
                                                 assign=False)
                    created.append(act)
                    if progress:
                        wm.progress_update(len(weights) + i + 1)
            finally:
                if progress:
                    wm.progress_end()
        except ShapeSigError as exc:
            for act in created:
                bpy.data.actions.remove(act)
            return self._fail(str(exc))
        except Exception:
            for act in created:
                bpy.data.actions.remove(act)
            raise

        if self.assign and created:
            from .. import compat

            first = clips[0]
            for name, mode in zip(first.bones, first.rotation_modes):
                pb = obj.pose.bones.get(name)
                if pb is not None and mode and pb.rotation_mode != mode:
                    pb.rotation_mode = mode
            compat.assign_action(obj, created[0])
        names = ", ".join(act.name for act in created)
        note = ""
        unmatched = clips[0].meta.get("unmatched_a", ())
        if unmatched:
            note = f"; {len(unmatched)} bone(s) animated only in A keep A's motion"
        self.report({"INFO"}, f"Blend Actions: created {len(created)} action(s): {names}{note}")
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
