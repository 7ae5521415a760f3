"""The "Bone Map" subpanel of the ShapeSig sidebar tab: the active armature's bones, each with the canonical joint it
is compared as (and the detected one when that differs), a joint changed from the row's menu, and buttons for
Detect, Clear, Import / Export JSON and the saved maps. Until the first edit it shows the map the search would use
(``rigmap.bone_map_of``). See docs/rigs.md, "The Bone Map editor".
"""

import os

import bpy

from ..rigs import rigmap
from ..search import library
from ..core.errors import ShapeSigError

__all__ = ["classes", "SHAPESIG_UL_bone_map", "draw_bone_map", "bone_rows", "unmapped_rows"]

# (armature data pointer, map text, maps folder and its mtime, bone names) -> ({bone: (joint in use, detected
# joint)}, where the map comes from): the list draws one row at a time; detection runs once per armature and map
_ROWS = {}
NONE = "\u2014"  # how "not a joint" is shown


def bone_rows(obj):
    """({bone: (joint in use or "", detected or "")}, "stored" | "picked" | "auto") of the armature, memoized
    until its map, its bones or the auto-pick folder change. ShapeSigError when its stored map is corrupt."""
    folder = rigmap.maps_folder(auto_only=True)
    stamp = os.stat(folder).st_mtime_ns if folder and os.path.isdir(folder) else 0
    names = tuple(b.name for b in obj.data.bones)
    memo = (obj.data.as_pointer(), str(obj.data.get(rigmap.PROP, "")), folder, stamp, names)
    got = _ROWS.get(memo)
    if got is None:
        used = rigmap.bone_map_of(obj)
        kind = "auto" if used == "auto" else ("stored" if rigmap.PROP in obj.data else "picked")
        _ROWS.clear()
        rows = rigmap.rows(obj)
        unmapped = rigmap.unmapped_joints(obj, {b: j for b, j, _d in rows if j})
        got = _ROWS[memo] = ({b: (j, d) for b, j, d in rows}, kind, unmapped)
    return got[:2]


def unmapped_rows(obj):
    """The canonical joints the armature's rig has that its map in use leaves out (``rigmap.unmapped_joints``),
    memoized with ``bone_rows``."""
    bone_rows(obj)
    return next(iter(_ROWS.values()))[2]


class SHAPESIG_UL_bone_map(bpy.types.UIList):
    """A bone, its joint (a menu of the canonical joints) and, greyed, the detected joint when it differs."""

    bl_idname = "SHAPESIG_UL_bone_map"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        obj = context.active_object
        try:
            joint, detected = bone_rows(obj)[0].get(item.name, ("", ""))
        except ShapeSigError:
            joint = detected = ""
        row = layout.row(align=True)
        split = row.split(factor=0.45)
        split.label(text=item.name, icon="BONE_DATA")
        right = split.row(align=True)
        op = right.operator_menu_enum("shapesig.bone_map_set", "joint", text=joint or NONE,
                                      icon="CHECKMARK" if joint else "BLANK1")
        op.bone = item.name
        hint = right.row()
        hint.active = False
        hint.label(text="auto: " + (detected or NONE) if detected != joint else "")


class SHAPESIG_MT_saved_maps(bpy.types.Menu):
    """The saved maps of the preferences' Bone Maps Folder"""

    bl_idname = "SHAPESIG_MT_saved_maps"
    bl_label = "Saved Maps"

    def draw(self, context):
        paths = rigmap.saved_maps(rigmap.maps_folder(context))
        if not paths:
            self.layout.label(text="No maps: set a Bone Maps Folder in the preferences", icon="INFO")
        for path in paths:
            op = self.layout.operator("shapesig.bone_map_import_saved", text=os.path.basename(path))
            op.name = os.path.basename(path)
        if paths:
            self.layout.separator()
            self.layout.operator("shapesig.bone_map_pick", icon="VIEWZOOM")


_KINDS = {"stored": ("Stored map", "CHECKMARK"), "picked": ("Auto-picked saved map (not stored)", "FILE"),
          "auto": ("Automatic", "AUTO")}


def _status(obj):
    """(text, icon): where the map in use comes from and how many bones it maps."""
    try:
        rows, kind = bone_rows(obj)
    except ShapeSigError as exc:
        return f"{exc}; Clear it", "ERROR"
    text, icon = _KINDS[kind]
    return f"{text}: {sum(1 for j, _d in rows.values() if j)} of {len(rows)} bones", icon


def draw_bone_map(layout, context):
    """Draw the editor for the active armature (a hint when there is none)."""
    obj = getattr(context, "active_object", None)
    s = library.settings_of(context)
    if obj is None or obj.type != "ARMATURE" or s is None:
        layout.label(text="Select an armature to see its bone map.", icon="INFO")
        return
    text, icon = _status(obj)
    layout.label(text=text, icon=icon)
    row = layout.row(align=True)
    row.operator("shapesig.bone_map_detect", text="Detect", icon="AUTO")
    row.operator("shapesig.bone_map_clear", text="Clear", icon="X")
    layout.template_list("SHAPESIG_UL_bone_map", "", obj.data, "bones", s, "bone_map_index", rows=8)
    try:
        missing = unmapped_rows(obj)
    except ShapeSigError:  # a corrupt stored map: the status line says so
        missing = []
    if missing:  # what comparisons leave out: the rig has these joints, no bone is given them
        box = layout.column(align=True)
        box.label(text=f"Unmapped: {len(missing)} joint(s) of this rig", icon="ERROR")
        for i in range(0, len(missing), 4):
            box.label(text=", ".join(missing[i:i + 4]))
    row = layout.row(align=True)
    row.operator("shapesig.bone_map_import", text="Import", icon="IMPORT")
    row.operator("shapesig.bone_map_export", text="Export", icon="EXPORT")
    row.menu("SHAPESIG_MT_saved_maps", text="Saved", icon="FILE_FOLDER")


class _BoneMapPanel:
    bl_label = "Bone Map"
    bl_region_type = "UI"
    bl_category = "ShapeSig"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_bone_map(self.layout, context)


class SHAPESIG_PT_bone_map_view3d(_BoneMapPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_bone_map_view3d"
    bl_space_type = "VIEW_3D"
    bl_parent_id = "SHAPESIG_PT_search_view3d"


class SHAPESIG_PT_bone_map_dopesheet(_BoneMapPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_bone_map_dopesheet"
    bl_space_type = "DOPESHEET_EDITOR"
    bl_parent_id = "SHAPESIG_PT_search_dopesheet"


class SHAPESIG_PT_bone_map_nla(_BoneMapPanel, bpy.types.Panel):
    bl_idname = "SHAPESIG_PT_bone_map_nla"
    bl_space_type = "NLA_EDITOR"
    bl_parent_id = "SHAPESIG_PT_search_nla"


classes = (SHAPESIG_UL_bone_map, SHAPESIG_MT_saved_maps, SHAPESIG_PT_bone_map_view3d,
           SHAPESIG_PT_bone_map_dopesheet, SHAPESIG_PT_bone_map_nla)
