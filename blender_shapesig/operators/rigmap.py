"""Bone-map operators of the "Bone Map" panel: detect, clear, set one bone's joint, export / import the saved-map
JSON, import a saved map by name and pick the maps folder's best map. Thin: each checks the active armature in
``poll``, calls one ``rigmap`` function and reports; a change is one undo step and a bad map file is refused
with one line, changing nothing. See docs/rigs.md, "The Bone Map editor".
"""

import os

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..rigs import rigmap
from ..core import rigs
from ..core.errors import ShapeSigError

__all__ = ["classes", "JOINT_ITEMS"]

# the joint enum of the editor: "NONE" (not a joint) and the canonical joints (static items: no callbacks)
JOINT_ITEMS = (("NONE", "\u2014", "Not a joint: this bone is not compared"),) + tuple(
    (j, j, f"Canonical joint {j}") for j in rigs.JOINTS)


def armature_problem(context, edits=True):
    """Why a bone-map operator cannot run (one line), or None; ``edits``: it stores a map on the armature."""
    obj = getattr(context, "active_object", None)
    if obj is None or obj.type != "ARMATURE":
        return "select an armature: bone maps are stored on the active armature"
    if edits and getattr(obj.data, "library", None) is not None:
        return f"armature {obj.data.name!r} is linked from a library: its bone map cannot be edited"
    return None


class _ArmatureOperator:
    bl_options = {"REGISTER", "UNDO"}
    edits = True  # stores a map on the armature (refused on linked armature data)

    @classmethod
    def poll(cls, context):
        reason = armature_problem(context, cls.edits)
        if reason is not None:
            cls.poll_message_set(reason[:1].upper() + reason[1:])
        return reason is None

    def _run(self, context, call, done):
        """``call(obj)`` -> the stored map (a failure changes nothing and is one line: ``errors_ui``)."""
        mapping = call(context.active_object)
        self.report({"INFO"}, f"{self.bl_label}: {done(mapping)}")
        return {"FINISHED"}


class SHAPESIG_OT_bone_map_detect(_ArmatureOperator, bpy.types.Operator):
    """Store the automatically detected bone map on the armature (to edit it)"""

    bl_idname = "shapesig.bone_map_detect"
    bl_label = "Detect Bone Map"

    def execute(self, context):
        def call(obj):
            detected = rigmap.detect_armature_map(obj)
            if not detected:
                raise ShapeSigError(f"no bone of {obj.name!r} matches a known rig; map the bones by hand")
            return rigmap.store_map(obj, detected)

        return self._run(context, call, lambda m: f"{len(m)} bones mapped to canonical joints")


class SHAPESIG_OT_bone_map_clear(_ArmatureOperator, bpy.types.Operator):
    """Remove the stored bone map: the armature's bones are mapped automatically again"""

    bl_idname = "shapesig.bone_map_clear"
    bl_label = "Clear Bone Map"

    def execute(self, context):
        return self._run(context, lambda obj: rigmap.clear_map(obj) or {}, lambda m: "automatic detection")


class SHAPESIG_OT_bone_map_set(_ArmatureOperator, bpy.types.Operator):
    """Give this bone a canonical joint (a joint given to another bone moves here)"""

    bl_idname = "shapesig.bone_map_set"
    bl_label = "Set Joint"
    bl_property = "joint"

    bone: StringProperty(name="Bone", description="The armature's bone")
    joint: EnumProperty(name="Joint", description="Canonical joint of the bone", items=JOINT_ITEMS)

    def execute(self, context):
        return self._run(context, lambda obj: rigmap.set_joint(obj, self.bone, self.joint),
                         lambda m: f"{self.bone} -> {m.get(self.bone, 'not a joint')}")


class SHAPESIG_OT_bone_map_export(_ArmatureOperator, ExportHelper, bpy.types.Operator):
    """Write the armature's bone map as a JSON file ({"bone": "joint"}, what --bone-map FILE.json reads)"""

    bl_idname = "shapesig.bone_map_export"
    bl_label = "Export Bone Map"
    bl_options = {"REGISTER"}  # writes a file, not the .blend
    edits = False
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def invoke(self, context, event):
        folder = rigmap.maps_folder(context)
        if folder and not self.filepath:  # the file browser opens in the maps folder, named after the rig
            self.filepath = os.path.join(folder, bpy.path.clean_name(context.active_object.data.name) + ".json")
        return ExportHelper.invoke(self, context, event)

    def execute(self, context):
        def call(obj):
            rigmap.export_map(obj, self.filepath)
            return rigmap.armature_map(obj)

        return self._run(context, call, lambda m: f"{len(m)} bones written to {self.filepath}")


class SHAPESIG_OT_bone_map_import(_ArmatureOperator, ImportHelper, bpy.types.Operator):
    """Read a saved bone map (JSON) and store its entries for this armature's bones"""

    bl_idname = "shapesig.bone_map_import"
    bl_label = "Import Bone Map"
    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    def execute(self, context):
        return self._run(context, lambda obj: rigmap.import_map(obj, self.filepath),
                         lambda m: f"{len(m)} bones mapped from {os.path.basename(self.filepath)}")


class SHAPESIG_OT_bone_map_import_saved(_ArmatureOperator, bpy.types.Operator):
    """Import a saved bone map of the preferences' Bone Maps Folder"""

    bl_idname = "shapesig.bone_map_import_saved"
    bl_label = "Import Saved Map"

    name: StringProperty(name="Map", description="File name of the map in the Bone Maps Folder")

    def execute(self, context):
        return self._run(context, lambda obj: rigmap.import_saved(obj, self.name, rigmap.maps_folder(context)),
                         lambda m: f"{len(m)} bones mapped from {self.name}")


class SHAPESIG_OT_bone_map_pick(_ArmatureOperator, bpy.types.Operator):
    """Store the map of the Bone Maps Folder that names most of this armature's bones"""

    bl_idname = "shapesig.bone_map_pick"
    bl_label = "Best Saved Map"

    def execute(self, context):
        picked = []

        def call(obj):
            folder = rigmap.maps_folder(context)
            path, mapping = rigmap.best_saved_map(obj, folder)
            if path is None:
                raise ShapeSigError(f"no saved map in {folder or '(no Bone Maps Folder set)'} names a bone of "
                                    f"{obj.name!r}")
            picked.append(os.path.basename(path))
            return rigmap.store_map(obj, mapping)

        return self._run(context, call, lambda m: f"{len(m)} bones mapped from {picked[0]}")


classes = (SHAPESIG_OT_bone_map_detect, SHAPESIG_OT_bone_map_clear, SHAPESIG_OT_bone_map_set,
           SHAPESIG_OT_bone_map_export, SHAPESIG_OT_bone_map_import, SHAPESIG_OT_bone_map_import_saved,
           SHAPESIG_OT_bone_map_pick)
