"""Add-on preferences: where the signature index is kept, the default library folders and the folder of saved
bone maps (``rigmap``: import a map by name; with Auto-Pick, armatures without a stored map use the folder's map
made for their rig).

The preferences' ``bl_idname`` is the add-on's module name (``__package__`` of this top-level module:
``blender_shapesig`` when installed as a legacy add-on or imported from source,
``bl_ext.<repository>.blender_shapesig`` as an extension), never a hard-coded string.
"""

import bpy
from bpy.props import BoolProperty, StringProperty

from .core.io.registry import extensions_text

ADDON_ID = __package__

__all__ = ["ShapeSigPreferences", "get_preferences", "ADDON_ID", "classes"]


class ShapeSigPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    cache_dir: StringProperty(
        name="Index Folder",
        description="Where the signature index (one small file per clip) is kept, in its own subfolder "
                    "blender_shapesig-cache (nothing else here is touched). Empty: $SHAPESIG_CACHE_DIR, "
                    "else a per-user cache folder, the same as the command line's",
        subtype="DIR_PATH",
        default="",
    )
    library_folders: StringProperty(
        name="Library Folders",
        description=f"Default folders of clip files ({extensions_text('and')}) searched besides the file's "
                    "actions; separate several with ';'",
        default="",
    )

    compact_index: BoolProperty(
        name="Compact Index",
        description="Do not store long log-signatures (skeletons with more than about 19 moving bones at level 3): "
                    "such clips are ranked by their 16 KB sketch alone and their distances are approximate",
        default=False,
    )

    maps_folder: StringProperty(
        name="Bone Maps Folder",
        description="Folder of saved bone maps (.json, {\"bone\": \"canonical joint\"}): the Bone Map panel "
                    "imports them by name",
        subtype="DIR_PATH",
        default="",
    )
    auto_pick_map: BoolProperty(
        name="Auto-Pick Maps",
        description="An armature without a stored bone map uses the folder's saved map that names most of its "
                    "bones (at least 3), instead of the automatic detection",
        default=False,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "cache_dir")
        layout.prop(self, "compact_index")
        layout.prop(self, "library_folders")
        row = layout.row(align=True)
        row.prop(self, "maps_folder")
        row.prop(self, "auto_pick_map", toggle=True)
        row = layout.row()
        row.operator("shapesig.clear_index", icon="TRASH")


def get_preferences(context=None):
    """This add-on's preferences, or None when they are not registered (e.g. some test set-ups)."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ADDON_ID) if context.preferences else None
    return getattr(addon, "preferences", None)


classes = (ShapeSigPreferences,)
register, unregister = bpy.utils.register_classes_factory(classes)
