"""Scene settings and results of the signature search (``scene.shapesig``).

``ShapeSigSettings``: the query (action, optional frame range), the library (the file's actions filtered
by a name pattern / asset flag, plus folders of clip files), the level, the re-rank count, and the
results of the last ranking (``results``, a collection of ``ShapeSigResult`` sorted by sim^n, shown by
the sidebar's UI list) with a status ``message``.
"""

import bpy
from bpy.props import (BoolProperty, CollectionProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from .core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL

__all__ = ["ShapeSigResult", "ShapeSigSettings", "classes", "settings_of"]


# K of the two-stage search the panel uses by default (see docs/evaluation.md, "Winner").
RERANK_DEFAULT = 10


class ShapeSigResult(bpy.types.PropertyGroup):
    """One ranked clip. ``name`` (the item name) is the action's name or the file's base name."""

    distance: FloatProperty(name="Distance", description="Normalized log-signature distance sim^n (eq. 9.1)",
                            precision=4)
    elastic: FloatProperty(name="Elastic", description="Elastic distance d_S* (when re-ranked)", precision=4)
    has_elastic: BoolProperty(name="Has Elastic", default=False)
    approximate: BoolProperty(name="Approximate", description="Distance estimated from the sketch (compact index)",
                              default=False)
    frames: IntProperty(name="Frames")
    shared: IntProperty(name="Shared Bones")
    partial: BoolProperty(name="Partial Match", default=False,
                          description="Shares few of the query's moving bones: compared on those only, ranked "
                                      "after the whole-body matches")
    is_action: BoolProperty(name="Action In File", description="The result is an action of this file",
                            default=True)
    source: StringProperty(name="Source", description="Action name, or the clip file (FILE.blend#ACTION)")
    clip_name: StringProperty(name="Clip", description="The clip's name inside its source")


class ShapeSigSettings(bpy.types.PropertyGroup):
    # query
    query_action: StringProperty(
        name="Query Action", description="Action to search with; empty: the active armature's action")
    use_frame_range: BoolProperty(name="Frame Range", description="Search with a part of the query action",
                                  default=False)
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)
    # library
    use_file_actions: BoolProperty(name="File Actions", description="Search the actions of this file",
                                   default=True)
    name_filter: StringProperty(name="Filter", description="Only actions whose name matches this pattern "
                                "(wildcards * and ?; empty: all)", default="")
    assets_only: BoolProperty(name="Assets Only", description="Only actions marked as assets", default=False)
    catalog: StringProperty(name="Catalog", description="With Assets Only: only assets whose catalog's simple name "
                            "matches this pattern (wildcards; empty: any catalog)", default="")
    use_folders: BoolProperty(name="Folders", description="Also search clip files in folders", default=False)
    folders: StringProperty(name="Folders", description="Folders of .bvh/.amc/.blend clips, separated by ';' "
                            "(empty: the add-on preferences' library folders)", default="")
    crop_start: IntProperty(name="Crop Start", description="Ignore the frames before this one in every clip "
                            "(library actions, folder clips and the query unless it has a frame range): 7 for "
                            "CMU 'Daz-friendly' BVH files (frame 1 is a rest pose, frames 2-6 a ramp from it); "
                            "0 keeps all",
                            default=0, min=0)
    # search
    level: IntProperty(name="Level", description="Log-signature level n of sim^n", default=DEFAULT_LEVEL,
                       min=1, max=4)
    # default 10: the evaluation's winner (docs/evaluation.md): a sim^3 shortlist re-ranked by d_S* over the top
    # 10 matched d_S*'s leave-one-out accuracy on every CMU set at a fraction of its cost
    rerank: IntProperty(name="Re-rank", description="Re-order the best K by elastic distance (0: off)",
                        default=RERANK_DEFAULT, min=0, max=100)
    top: IntProperty(name="Show", description="Number of results kept (0: all)", default=25, min=0)
    depth: IntProperty(name="Depth", description="Elastic DP search depth", default=DEFAULT_DEPTH, min=1, max=30)
    # results
    results: CollectionProperty(type=ShapeSigResult)
    results_index: IntProperty(name="Result", default=0)
    query_name: StringProperty(name="Query")
    message: StringProperty(name="Message", description="Status of the last index build or ranking")
    # index build / preview state
    index_running: BoolProperty(default=False, options={"SKIP_SAVE"})
    index_progress: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    preview_action: StringProperty(description="Action to restore when the preview stops", default="")
    preview_object: StringProperty(description="Armature being previewed", default="")


classes = (ShapeSigResult, ShapeSigSettings)


def settings_of(context):
    """``context.scene.shapesig`` or None."""
    scene = getattr(context, "scene", None)
    return getattr(scene, "shapesig", None) if scene is not None else None


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    bpy.types.Scene.shapesig = PointerProperty(type=ShapeSigSettings)


def unregister():
    if hasattr(bpy.types.Scene, "shapesig"):
        del bpy.types.Scene.shapesig
    _unregister_classes()
