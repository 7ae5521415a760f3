"""``shapesig.import_acclaim``: File > Import > Acclaim Motion (.asf/.amc).

A thin operator: the picked files -> ``readers.acclaim.choose_files`` -> ``readers.acclaim.import_acclaim``
(the armature builder and pose maths) -> one report line. On any error it reports one line and creates
nothing.
"""

import os

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ImportHelper

from ..core.errors import ShapeSigError
from ..readers.acclaim import choose_files, import_acclaim

__all__ = ["SHAPESIG_OT_import_acclaim", "classes"]


class SHAPESIG_OT_import_acclaim(bpy.types.Operator, ImportHelper):
    """Import an Acclaim skeleton (.asf) and motions (.amc) as an armature with one action per motion"""

    bl_idname = "shapesig.import_acclaim"
    bl_label = "Import Acclaim (.asf/.amc)"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".amc"
    filter_glob: StringProperty(default="*.asf;*.amc", options={"HIDDEN"})
    filepath: StringProperty(name="File Path", description="An .asf skeleton or an .amc motion",
                             subtype="FILE_PATH")
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"HIDDEN", "SKIP_SAVE"})
    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    asf_path: StringProperty(
        name="Skeleton", description="The .asf skeleton; empty: the only .asf beside the .amc",
        subtype="FILE_PATH", default="")
    scale: FloatProperty(name="Scale", description="Scale on top of the ASF units converted to meters",
                         default=1.0, min=1e-6, max=1e6)
    frame_step: IntProperty(name="Frame Step", description="Keep every Nth AMC frame", default=1, min=1,
                            max=1000)
    fps: FloatProperty(name="Frame Rate", description="Capture rate of the AMC files (CMU: 120)",
                       default=120.0, min=0.001, max=10000.0)
    rotation_mode: EnumProperty(
        name="Rotation", description="Rotation mode of the pose bones and their F-curves",
        items=(
            ("QUATERNION", "Quaternion", "Quaternion rotations (no gimbal lock)"),
            ("NATIVE", "Native Euler", "Euler in each bone's ASF dof order"),
            ("XYZ", "Euler XYZ", ""), ("XZY", "Euler XZY", ""), ("YXZ", "Euler YXZ", ""),
            ("YZX", "Euler YZX", ""), ("ZXY", "Euler ZXY", ""), ("ZYX", "Euler ZYX", ""),
        ),
        default="QUATERNION",
    )
    update_scene: BoolProperty(name="Update Scene", description="Set the scene's frame rate and range",
                               default=False)

    def _paths(self):
        directory = self.directory or os.path.dirname(self.filepath)
        names = [f.name for f in self.files if f.name]
        paths = [os.path.join(directory, n) for n in names] if names else []
        if not paths and self.filepath:
            paths = [self.filepath]
        return paths

    @classmethod
    def poll(cls, context):
        if context.scene is None or context.collection is None:
            cls.poll_message_set("No active scene collection to add the armature to")
            return False
        return True

    def execute(self, context):
        try:
            asf, amcs = choose_files(self._paths(), bpy.path.abspath(self.asf_path) if self.asf_path else "")
            obj, actions = import_acclaim(context, asf, amcs, scale=self.scale, frame_step=self.frame_step,
                                          fps=self.fps, rotation_mode=self.rotation_mode,
                                          update_scene=self.update_scene)
        except ShapeSigError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except (OSError, RuntimeError) as exc:
            self.report({"ERROR"}, f"Acclaim import failed: {str(exc).splitlines()[0] if str(exc) else exc}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Imported {obj.name} with {len(actions)} action(s)")
        return {"FINISHED"}


def _menu_func(self, context):
    self.layout.operator(SHAPESIG_OT_import_acclaim.bl_idname, text="Acclaim Motion (.asf/.amc)")


menus = (("TOPBAR_MT_file_import", _menu_func),)  # File > Import (operators/__init__.py registers it)


classes = (SHAPESIG_OT_import_acclaim,)
