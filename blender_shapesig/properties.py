"""Scene settings of the Motion Search panel (``scene.shapesig``, ``ShapeSigSettings``: query, library, level, re-rank
count, a running preview's state) and its transient results on the window manager
(``window_manager.shapesig_results``, ``ShapeSigResults``: no undo step, not saved). See docs/dev/blender_layer.md.
"""

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from .core.io.registry import extensions_text
from .core.measure_words import ENGINES, MEASURES, OPTIONS, measure_words
from .core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL, LOCAL

__all__ = ["column_word", "ShapeSigResult", "ShapeSigResults", "ShapeSigSettings", "classes", "settings_of", "results_of", "uses_local",
           "index_level"]


# K of the two-stage search the panel uses by default (see docs/evaluation.md, "Winner").
RERANK_DEFAULT = 10
# The panel's highest level (level 4 already costs ~2.5 s and ~7 MB per clip); the integer settings have soft
# limits only: a script's value out of range is refused by ``library.search_problem``, never clamped.
PANEL_MAX_LEVEL = 4



def column_word(column: str) -> str:
    """A results column in a sentence ("sorted by ..."): 'sim' -> 'similarity', 'elastic' -> 'timing-aligned
    difference' (``core.measure_words``; the thesis' symbols are in the tooltips)."""
    return measure_words(column).status


def uses_local(settings) -> bool:
    """True when Find Similar runs the local search (Similarity: Motion and pose; moments rank by signatures)."""
    return getattr(settings, "similarity", LOCAL) == LOCAL and not settings.use_windows


def index_level(settings) -> int:
    """The signature level indexed: the Level, or the default one for the local search (its fallback)."""
    return DEFAULT_LEVEL if uses_local(settings) else settings.level

class ShapeSigResult(bpy.types.PropertyGroup):
    """One ranked clip. ``name`` (the item name) is the action's name or the file's base name."""

    distance: FloatProperty(name=MEASURES["sim"].label, description=MEASURES["sim"].tooltip, precision=4)
    elastic: FloatProperty(name=MEASURES["elastic"].label, description=MEASURES["elastic"].tooltip, precision=4)
    has_elastic: BoolProperty(name="Has Elastic", default=False)
    approximate: BoolProperty(name="Approximate", description="Distance estimated from the sketch (compact index)",
                              default=False)
    frames: IntProperty(name="Frames")
    shared: IntProperty(name="Shared Bones")
    partial: BoolProperty(name="Partial Match", default=False,
                          description="Shares few of the query's moving bones, or compares under half of the "
                                      "joints (or arms and legs) both rigs have: compared on those only, ranked "
                                      "after the whole-body matches")
    is_action: BoolProperty(name="Action In File", description="The result is an action of this file",
                            default=True)
    source: StringProperty(name="Source", description="Action name, or the clip file (FILE.blend#ACTION)")
    clip_name: StringProperty(name="Clip", description="The clip's name inside its source")
    # readable rows
    label: StringProperty(name="Label", description="Unique display label: the action, or the file (with its "
                          "action for a .blend, and as many parent folders as tell two files apart)")
    spec: StringProperty(name="File", description="The clip file as discovered (FILE.blend#ACTION); empty for "
                         "an action of this file")
    coverage: FloatProperty(name="Coverage", description="Joints compared / the joints both rigs have",
                            precision=2)
    unmapped: StringProperty(name="Unmapped", description="Joints both rigs have that were not compared "
                             "(comma-separated)")
    frame_first: IntProperty(name="First Frame", description="First frame of the matched clip or window")
    frame_last: IntProperty(name="Last Frame", description="Last frame of the matched clip or window")
    # moments and explanations
    window_action: StringProperty(name="Window Action", description="The action written for the matched window "
                                  "(Assign / Preview of a moment); Blend uses it")
    on_armature: StringProperty(name="On Armature", description="The action written for this row on the active "
                                "armature when the result is another rig's motion (retargeted through the bone maps)")
    kept: StringProperty(name="Kept At Rest", description="Bones of the armature with no counterpart in the "
                         "result's rig: they keep their rest pose")
    explain: StringProperty(name="Explanation", description="Why different (JSON, core.elastic.explain): per-joint "
                            "shares of the elastic distance and the alignment cost over time")
    # the frames read before trimming, when trimming cut some (0..0: nothing trimmed)
    kept_first: IntProperty(name="Compared From", description="First frame compared, after trimming")
    kept_last: IntProperty(name="Compared To", description="Last frame compared, after trimming")
    read_first: IntProperty(name="Read From", description="First frame read, before trimming")
    read_last: IntProperty(name="Read To", description="Last frame read, before trimming")
    # the identity of what the row names, so that a replaced target is refused (results.check_target)
    target: StringProperty(name="Target", description="At the search: the action's read hash, or the file's "
                           "path, size and modification time")
    written: StringProperty(name="Written", description="Actions written for this row and their read hashes "
                            "(JSON)")
    # the row's picture (thumbnails.py): made after the click, in the background
    preview_icon: IntProperty(name="Preview Icon", description="Icon id of the row's picture of key poses (0 while "
                              "it is being made, and in background mode)", default=0)
    preview_path: StringProperty(name="Preview File", description="The row's picture of key poses (PNG in the "
                                 "index folder; empty while it is being made)", default="")
    why_query_path: StringProperty(name="Why Query Picture", description="Why Different: the query's key poses")
    why_result_path: StringProperty(name="Why Result Picture", description="Why Different: the result's poses at "
                                    "the times the alignment matches to the query's")


class ShapeSigResults(bpy.types.PropertyGroup):
    """The last Find Similar click (on the window manager: not in undo steps, not saved)."""

    results: CollectionProperty(type=ShapeSigResult)
    results_index: IntProperty(name="Result", default=0)
    query_name: StringProperty(name="Query")
    message: StringProperty(name="Message", description="Status of the last index build or ranking")
    order_by: StringProperty(name="Sorted By", description="The one column the rows are sorted by (ascending): "
                             "'sim', 'elastic' or 'local' (core.measure_words)")
    seconds: FloatProperty(name="Seconds", description="Measured time of the last click, start to results")
    query_bones: IntProperty(name="Query Bones", description="Bones of the query")
    query_preview_icon: IntProperty(name="Query Preview Icon", description="Icon id of the query's picture", default=0)
    query_preview_path: StringProperty(name="Query Preview File", description="The query's picture of key poses")
    running: BoolProperty(default=False, description="A Find Similar click is running (Esc cancels)")
    progress: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR")


class ShapeSigSettings(bpy.types.PropertyGroup):
    # query
    query_action: StringProperty(
        name="Query Action", description="Action to search with; empty: the active armature's action")
    # no update callback here: the bpy module of Blender 4.2 crashes at exit after registering one
    use_frame_range: BoolProperty(name="Frame Range", description="Search with a part of the query action",
                                  default=False)
    frame_start: IntProperty(name="Start", description="First frame of the query, inside the action's frames "
                             "(0: the action's first frame)", default=0)
    frame_end: IntProperty(name="End", description="Last frame of the query, inside the action's frames "
                           "(0: the action's last frame)", default=0)
    # library
    use_file_actions: BoolProperty(name="File Actions", description="Search the actions of this file",
                                   default=True)
    name_filter: StringProperty(name="Filter", description="Only actions whose name matches this pattern "
                                "(wildcards * and ?; empty: all)", default="")
    assets_only: BoolProperty(name="Assets Only", description="Only actions marked as assets", default=False)
    catalog: StringProperty(name="Catalog", description="With Assets Only: only assets whose catalog's simple name "
                            "matches this pattern (wildcards; empty: any catalog)", default="")
    use_folders: BoolProperty(name="Folders", description="Also search clip files in folders", default=False)
    folders: StringProperty(name="Folders", description=f"Folders of clip files ({extensions_text('and')}), "
                            "separated by ';' (empty: the add-on preferences' library folders)", default="")
    asf: StringProperty(name="Skeleton", description="The .asf skeleton of the folders' AMC files (empty: the "
                        "only .asf beside each .amc)", default="", subtype="FILE_PATH")
    crop_start: IntProperty(name="Crop Start", description="Ignore the frames before this one in every clip "
                            "(library actions, folder clips and the query unless it has a frame range); rest-pose "
                            "and ramp frames need none (Trim: Auto). 0 keeps all",
                            default=0, soft_min=0)
    # how every clip is read (query, file actions, folder clips); part of each clip's index key
    trim: EnumProperty(
        name="Trim", description="Rest-pose / ramp frames at the ends of each clip (core/clip/trim.py); an explicit "
        "crop start or frame range keeps its end",
        items=(("auto", "Auto", "Drop detected rest-pose and ramp frames at both ends"),
               ("none", "None", "Compare every frame")),
        default="auto")
    fps: FloatProperty(name="FPS", description="Frame rate the clips are read at (0: each action's own rate, "
                       "else the scene's; each file's own rate)", default=0.0, soft_min=0.0, soft_max=240.0)
    # the Bone Map panel's selected row (its list draws the active armature's bones)
    bone_map_index: IntProperty(name="Bone", default=0)
    # search
    use_windows: BoolProperty(name=ENGINES["moments"].label, description=ENGINES["moments"].tooltip, default=False)
    similarity: EnumProperty(
        name=OPTIONS["similarity"].label, description=OPTIONS["similarity"].tooltip,
        items=tuple((key, ENGINES[key].label, ENGINES[key].tooltip) for key in (LOCAL, "sim")),
        default=LOCAL)
    level: IntProperty(name=OPTIONS["level"].label, description=OPTIONS["level"].tooltip, default=DEFAULT_LEVEL,
                       soft_min=1, soft_max=PANEL_MAX_LEVEL)
    # default 10: the evaluation's winner (docs/evaluation.md): a sim^3 shortlist re-ranked by d_S* over the top
    # 10 matched d_S*'s leave-one-out accuracy on every CMU set at a fraction of its cost
    rerank: IntProperty(name=OPTIONS["rerank"].label, description=OPTIONS["rerank"].tooltip,
                        default=RERANK_DEFAULT, soft_min=0, soft_max=100)
    top: IntProperty(name="Show", description="Number of results kept (0: all)", default=25, soft_min=0)
    depth: IntProperty(name=OPTIONS["depth"].label, description=OPTIONS["depth"].tooltip, default=DEFAULT_DEPTH,
                       soft_min=1, soft_max=30)
    # index build / preview state (the preview's is what Stop restores exactly; saved with the file, so a file
    # saved while previewing still restores on Stop)
    index_running: BoolProperty(default=False, options={"SKIP_SAVE"})
    index_progress: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    preview_action: StringProperty(description="Action to restore when the preview stops", default="")
    preview_object: StringProperty(description="Armature being previewed", default="")
    preview_slot: StringProperty(description="Identifier of the action slot to restore", default="")
    preview_modes: StringProperty(description="Pose bones' rotation modes to restore (JSON)", default="")
    preview_frame: IntProperty(description="Scene frame to restore", default=0)
    preview_fake_user: BoolProperty(description="The preview gave the previous action a fake user (to keep it "
                                    "through a save); Stop takes it back", default=False)
    preview_animdata: BoolProperty(description="The armature had animation data before the preview",
                                   default=True)
    preview_written: StringProperty(description="Action written for the preview (a folder result); removed at "
                                    "Stop unless it was assigned", default="")


classes = (ShapeSigResult, ShapeSigResults, ShapeSigSettings)


def settings_of(context):
    """``context.scene.shapesig`` or None."""
    scene = getattr(context, "scene", None)
    return getattr(scene, "shapesig", None) if scene is not None else None


def results_of(context=None):
    """``window_manager.shapesig_results``: the last click's rows and status (transient UI state)."""
    context = context or bpy.context
    wm = getattr(context, "window_manager", None) or bpy.data.window_managers[0]
    return wm.shapesig_results


_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    bpy.types.Scene.shapesig = PointerProperty(type=ShapeSigSettings)
    bpy.types.WindowManager.shapesig_results = PointerProperty(type=ShapeSigResults)


def unregister():
    if hasattr(bpy.types.WindowManager, "shapesig_results"):
        del bpy.types.WindowManager.shapesig_results
    if hasattr(bpy.types.Scene, "shapesig"):
        del bpy.types.Scene.shapesig
    _unregister_classes()
