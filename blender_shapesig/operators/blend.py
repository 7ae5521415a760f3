"""``shapesig.blend_actions``: time-aligned SRVT geodesic blends of two or more actions, and
``shapesig.bake_blend_timing``: a blend written with editable timing baked into a plain action. Thin operators:
they parse their properties, call ``blend_actions.blend_actions`` / ``bake_strip`` (nothing is created on error),
optionally assign the first blend, and report. See docs/blending.md.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, IntVectorProperty, StringProperty

from ..core.blend import blend_weights
from ..core.clip.prepare import check_fps
from ..core.errors import MAX_INBETWEENS, ShapeSigError, check_integer, check_weight
from ..core.measure_words import OPTIONS
from ..core.metrics import DEFAULT_DEPTH
from .preconditions import armature_or_message, two_actions_or_message

__all__ = ["SHAPESIG_OT_blend_actions", "SHAPESIG_OT_bake_blend_timing", "classes", "parse_extra"]


def parse_extra(text):
    """``"jog=0.2, skip=0.1"`` -> [("jog", 0.2), ("skip", 0.1)] (a name may hold '='; the last one splits);
    ShapeSigError (one line) on an entry without a weight."""
    out = []
    for part in str(text or "").split(","):
        part = part.strip()
        if not part:
            continue
        name, sep, value = part.rpartition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out.append((name.strip(), check_weight(float(value), f"weight of {name.strip()!r}")))
        except ValueError:
            raise ShapeSigError(f"extra actions: expected NAME=WEIGHT entries separated by commas, got {part!r}") \
                from None
    return out


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
        name=OPTIONS["depth"].label, description=OPTIONS["depth"].tooltip, default=DEFAULT_DEPTH,
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
    # not remembered between dialogs (SKIP_SAVE): a range belongs to the actions it was chosen for
    range_a: IntVectorProperty(
        name="A Frames", description="Frames of A to blend (first, last, inclusive); 0, 0: all of A. For two "
        "cyclic actions the dialog starts with one stride of each", size=2, default=(0, 0), options={"SKIP_SAVE"})
    range_b: IntVectorProperty(
        name="B Frames", description="Frames of B to blend (first, last, inclusive); 0, 0: all of B. For two "
        "cyclic actions the dialog starts with one stride of each", size=2, default=(0, 0), options={"SKIP_SAVE"})
    strides_for: StringProperty(
        name="Strides For", description="The actions and ranges the dialog's one-stride default was found for "
        "(A, B, A's first and last, B's first and last, tab-separated)", options={"HIDDEN", "SKIP_SAVE"})
    extra: StringProperty(
        name="More Actions", description="More actions to blend and their weights: NAME=WEIGHT, ... (A's weight "
        "is 1 - B's - theirs; one blend)")
    loop: BoolProperty(
        name="Loop", description="A seamless cycle: one stride of each action (cycle detection; an action that "
        "already is one cycle loops as it is), aligned, closed",
        default=False)
    feet: EnumProperty(
        name="Feet", description="Feet planted in the sources stay planted in the blend",
        items=(("LOCK", "Lock", "Keep planted feet planted (two-bone IK on the legs)"),
               ("NONE", "None", "As blended")),
        default="LOCK")
    mask: StringProperty(
        name="Mask", description="Per-bone-group weights of B: GROUP=WEIGHT, ... with groups upper, legs, arms, "
        "spine, head, left_arm, right_arm, left_leg, right_leg, a canonical joint, a bone or a custom group; "
        "root motion follows the legs")
    groups: StringProperty(
        name="Groups", description="Custom groups for the mask: NAME=JOINT+JOINT; ... (joints or bone names)")
    timing: EnumProperty(
        name="Timing", description="How the blended timing is written",
        items=(("BAKE", "Bake", "The blended timing in the keys of the new action"),
               ("NLA", "Editable (NLA)", "The pose curve on A's time, played by an NLA strip whose animated Strip "
                "Time is the blended clock: nudge it in the Graph Editor, then Bake Blend Timing")),
        default="BAKE")
    fps_a: FloatProperty(
        name="A Frame Rate", description="Frames per second A was captured at (0: its own rate: recorded, found "
        "in its source file, else the scene's, shown as assumed)", default=0.0, soft_min=0.0, soft_max=240.0)
    fps_b: FloatProperty(
        name="B Frame Rate", description="Frames per second B was captured at (0: its own rate: recorded, found "
        "in its source file, else the scene's, shown as assumed)", default=0.0, soft_min=0.0, soft_max=240.0)
    allow_long: BoolProperty(
        name="Allow Long", description="Blend actions lasting more than 8 times as long as each other (refused "
        "otherwise: choose a frame range of the longer one)", default=False)
    allow_partial: BoolProperty(
        name="Allow Partial", description="Blend two rigs whose bone maps pair fewer than half of the joints both "
        "rigs have (refused otherwise: map more bones in the Bone Map panel)", default=False)
    expect_b: StringProperty(
        name="Expected B", description="The read hash B had when a search result named it (the panel's Blend): "
        "a B changed since is refused", options={"HIDDEN", "SKIP_SAVE"})
    assign: BoolProperty(
        name="Assign Result", description="Make the (first) blend the armature's active action (Editable timing: "
        "clear the active action so the strip plays)",
        default=True)

    @classmethod
    def poll(cls, context):
        return armature_or_message(cls, context) is not None and two_actions_or_message(cls, "Blending")

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
            self._default_strides(obj)
        return context.window_manager.invoke_props_dialog(self, width=360)

    def _default_strides(self, obj):
        """Two cyclic actions and no ranges or loop asked for: the ranges start at one stride of each (whole takes
        shuffle, then take big strides; docs/blending.md), visible and changeable in the dialog."""
        from ..blend.blend_actions import stride_ranges

        acts = [bpy.data.actions.get(n) if n else None for n in (self.action_a, self.action_b)]
        if self.loop or None in acts or acts[0] == acts[1] or tuple(self.range_a) != (0, 0) \
                or tuple(self.range_b) != (0, 0):
            return
        strides = stride_ranges(obj, *acts)
        if strides is not None:
            self.range_a, self.range_b = strides
            self.strides_for = "\t".join([acts[0].name, acts[1].name] + [str(v) for r in strides for v in r])

    def _strides_note(self):
        """(the line the dialog shows about the one-stride default or '', True when its ranges were found for
        other actions than A and B now: then they are not used)."""
        parts = self.strides_for.split("\t")
        if len(parts) != 6:
            return "", False
        ranges = (tuple(int(v) for v in parts[2:4]), tuple(int(v) for v in parts[4:6]))
        if (tuple(self.range_a), tuple(self.range_b)) != ranges:
            return "", False  # changed by hand: the user's ranges
        if parts[:2] != [self.action_a, self.action_b]:
            return f"The one-stride ranges were found for {parts[0]} and {parts[1]}: whole actions are blended", True
        return "One stride of each (cycles found); 0, 0 blends the whole action", False

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop_search(self, "action_a", bpy.data, "actions")
        layout.prop_search(self, "action_b", bpy.data, "actions")
        for name, prop in ((self.action_a, "fps_a"), (self.action_b, "fps_b")):
            _draw_rate(layout, self, name, prop)
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
        layout.prop(self, "range_a")
        layout.prop(self, "range_b")
        note, stale = self._strides_note()
        if note:
            layout.label(text=note, icon="ERROR" if stale else "INFO")
        layout.prop(self, "allow_long")
        layout.prop(self, "allow_partial")
        layout.prop(self, "extra")
        layout.prop(self, "mask")
        if self.mask:
            layout.prop(self, "groups")
        layout.prop(self, "loop")
        layout.prop(self, "feet", expand=True)
        row = layout.row()
        row.enabled = not self.loop
        row.prop(self, "timing", expand=True)
        layout.prop(self, "assign")

    def _fail(self, message):
        self.report({"ERROR"}, f"Blend Actions: {message}")
        return {"CANCELLED"}

    def _bones(self, obj):
        """The bone subset (None: every shared bone); ShapeSigError when the subset is empty."""
        from ..blend.blend_actions import selected_bone_names

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
        check_integer(self.depth, OPTIONS["depth"].status, minimum=1)
        if self.frames != 0:
            check_integer(self.frames, "length", minimum=2)
        return blend_weights(self.inbetweens, self.weight)  # in-betweens within 1..MAX_INBETWEENS

    def _options(self):
        """The options as ``blend_actions`` keywords (ranges, extra actions, mask, groups, loop, feet,
        timing); ShapeSigError (one line) on bad input."""
        from ..core.blend import parse_groups, parse_mask, parse_range

        stale = self._strides_note()[1]  # one-stride ranges found for other actions than A and B now
        ranges = [None if tuple(r) == (0, 0) or stale else parse_range(tuple(r), label)
                  for r, label in ((self.range_a, "A Frames"), (self.range_b, "B Frames"))]
        extra = []
        for name, w in parse_extra(self.extra):
            act = bpy.data.actions.get(name)
            if act is None:
                raise ShapeSigError(f"no action named {name!r} (More Actions)")
            extra.append((act, w))
        if extra and self.inbetweens != 1:
            raise ShapeSigError("More Actions make one blend: set In-betweens to 1")
        return dict(ranges=ranges, extra=extra, loop=self.loop, feet=self.feet.lower(),
                    mask=parse_mask(self.mask) if self.mask.strip() else None,
                    groups=parse_groups([g for g in self.groups.split(";") if g.strip()]) or None,
                    timing="nla" if self.timing == "NLA" else "bake")

    def execute(self, context):
        from ..actions.action_hashes import read_hash
        from ..blend.blend_actions import blend_actions
        from ..search.results import changed_error

        obj = context.active_object
        wm = context.window_manager if getattr(context, "window", None) is not None else None
        try:
            if not self.action_a or not self.action_b:
                raise ShapeSigError("choose two actions A and B")
            acts = [bpy.data.actions.get(n) for n in (self.action_a, self.action_b)]
            for name, act in zip((self.action_a, self.action_b), acts):
                if act is None:
                    raise ShapeSigError(f"no action named {name!r}")
            if self.expect_b and read_hash(acts[1]) != self.expect_b:
                raise changed_error(self.action_b)
            weights = self._weights()
            options = self._options()
            options["allow_long"] = self.allow_long
            options["allow_partial"] = self.allow_partial
            options["rates"] = [check_fps(f, label) if f else None
                                for f, label in ((self.fps_a, "A Frame Rate"), (self.fps_b, "B Frame Rate"))]
            show = wm is not None and len(weights) > 1
            if show:
                wm.progress_begin(0, 2 * len(weights))
            try:
                result = blend_actions(obj, acts[0], acts[1], weights, align=self.align, depth=self.depth,
                                       frames=self.frames or None, bones=self._bones(obj),
                                       root="a" if self.root == "A" else "blend",
                                       progress=(lambda i, n: wm.progress_update(i)) if show else None, **options)
            finally:
                if show:
                    wm.progress_end()
        except ShapeSigError as exc:
            return self._fail(str(exc))
        if self.assign:
            self._assign(obj, result)
        self.report({"INFO"}, f"Blend Actions: {_summary(result)}")
        if result.info.get("rate_note"):
            self.report({"WARNING"}, f"Blend Actions: {result.info['rate_note']}")
        return {"FINISHED"}

    def _assign(self, obj, result):
        from .. import compat
        from ..actions import action_io

        if not result.strips:
            action_io.assign_action(obj, result.actions[0])
            return
        previous = obj.animation_data.action
        if previous is not None and not previous.use_fake_user and previous.users <= 1:
            compat.stash_action(obj, previous)  # never left without users
        compat.assign_action(obj, None)  # the strip plays


def _draw_rate(layout, op, name, prop):
    """A row: the action's frame rate as read (assumed ones say so) and the override field."""
    from ..actions.frame_rates import rate_of, rate_text

    act = bpy.data.actions.get(name) if name else None
    row = layout.row()
    row.prop(op, prop)
    if act is not None and not getattr(op, prop):
        fps, known, _how = rate_of(act)
        row.label(text=rate_text(fps) if known else f"{rate_text(fps)} (assumed)",
                  icon="NONE" if known else "ERROR")


def _summary(result):
    """The report line: the new actions, bones that kept A's motion, planted feet and loops."""
    names = ", ".join(act.name for act in result.actions)
    text = f"created {len(result.actions)} action(s): {names}"
    if result.strips and result.clips:
        clip = result.clips[0]
        text += f" ({(clip.frames - 1) / clip.fps:.2f} s)"
    elif result.actions:
        from ..actions.scene_motion import timing_text

        text += f" ({timing_text(result.actions[0])})"
    if result.strips:
        from ..blend.blend_actions import TIMING_TRACK

        text += f" (editable timing: NLA track '{TIMING_TRACK}')"
    if result.unmatched:
        text += f"; {len(result.unmatched)} bone(s) animated only in A keep A's motion"
    reports = result.info.get("feet") or []
    planted = sum(len(f["drift_after"]) for r in reports if "feet" in r for f in r["feet"])
    if planted:
        text += f"; {planted} planted contact(s)"
    skipped = [r["skipped"] for r in reports if "skipped" in r]
    if skipped:
        text += f"; feet not planted: {skipped[0]}"
    if result.info.get("loop"):
        text += f"; loop of {result.info['loop'][0]['frames']} frames"
    return text


class SHAPESIG_OT_bake_blend_timing(bpy.types.Operator):
    """Bake the blend strips of the active armature written with editable timing (NLA, animated Strip Time) into
    plain actions"""

    bl_idname = "shapesig.bake_blend_timing"
    bl_label = "Bake Blend Timing"
    bl_options = {"REGISTER", "UNDO"}

    assign: BoolProperty(name="Assign Result", description="Make the (first) baked action the active action",
                         default=False)

    @classmethod
    def poll(cls, context):
        from ..blend.blend_actions import timed_strips

        obj = armature_or_message(cls, context)
        if obj is None:
            return False
        if not timed_strips(obj):
            cls.poll_message_set("The armature has no blend strip with editable timing (Blend Actions, Timing: "
                                 "Editable)")
            return False
        return True

    def execute(self, context):
        from .. import compat
        from ..actions import action_io
        from ..blend.blend_actions import bake_strip, timed_strips

        obj = context.active_object
        made = []
        try:
            for strip in timed_strips(obj):
                made.append(bake_strip(obj, strip))
        except ShapeSigError as exc:
            for act in made:
                compat.remove_action(act)
            self.report({"ERROR"}, f"Bake Blend Timing: {exc}")
            return {"CANCELLED"}
        if self.assign:
            action_io.assign_action(obj, made[0])
        self.report({"INFO"}, f"Bake Blend Timing: created {', '.join(a.name for a in made)}")
        return {"FINISHED"}


def menu_func(self, context):
    self.layout.operator(SHAPESIG_OT_blend_actions.bl_idname, text="Blend Actions (ShapeSig)")


# the 3D Viewport menus the entry joins (Object > Animation, Pose): operators/__init__.py registers them
menus = (("VIEW3D_MT_object_animation", menu_func), ("VIEW3D_MT_pose", menu_func))


classes = (SHAPESIG_OT_blend_actions, SHAPESIG_OT_bake_blend_timing)
