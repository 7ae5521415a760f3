"""Signature search operators (sidebar tab "ShapeSig"; settings and results in ``scene.shapesig``).

* ``shapesig.build_index``: compute the index entry (log-signature, sketch, increments) of every library
  clip that is not in the cache yet. With a window it runs modally, one clip per timer tick, with a
  progress bar (Esc cancels; what is done stays cached); without one (background, the bpy module, scripts
  calling ``execute``) it runs synchronously.
* ``shapesig.rank``: rank the library by sim^n against the query (the active armature's action, or the
  chosen one, optionally a frame range of it), optionally re-rank the best K by elastic distance; fills
  ``scene.shapesig.results``. Clips not in the index are computed on the way (and cached).
* ``shapesig.assign_result``: make the selected result the active armature's action (a folder clip is
  first written as a new action).
* ``shapesig.preview_result``: assign the result temporarily and play; run again to stop and restore.
* ``shapesig.clear_index``: delete the cache files.

The library: the file's actions that animate the armature's bones (name pattern, assets only), read with
the active armature (its bone order and rotation modes), and the clip files of the chosen folders (read
only when their key is not cached). Keys: ``action_hash`` of the action + the armature's bones and modes +
the frame range; for files, their bytes, size and mtime (core.search.file_key). Source actions are only
read, never modified.
"""

import fnmatch
import hashlib
import os

import numpy as np

import bpy
from bpy.props import BoolProperty

from ..core import search
from ..core.errors import ShapeSigError

__all__ = ["classes", "cache_dir", "get_cache", "query_item", "library_items", "rank_into_settings"]

_PACKAGE = __package__.rpartition(".")[0]  # the add-on's module name (bl_ext.<repo>.blender_shapesig as an extension)
_CACHES = {}


# ------------------------------------------------------------------------------------------ helpers

def _preferences(context):
    addons = getattr(context.preferences, "addons", None)
    addon = addons.get(_PACKAGE) if addons is not None else None
    return getattr(addon, "preferences", None)


def cache_dir(context):
    """The index folder: the preferences' folder, else $SHAPESIG_CACHE_DIR, else the extension's user folder
    (``bpy.utils.extension_path_user``) when running as an extension, else core's per-user default."""
    prefs = _preferences(context)
    if prefs is not None and prefs.cache_dir:
        return bpy.path.abspath(prefs.cache_dir)
    env = os.environ.get(search.CACHE_ENV)
    if env:
        return env
    if _PACKAGE.startswith("bl_ext.") and hasattr(bpy.utils, "extension_path_user"):
        try:
            return bpy.utils.extension_path_user(_PACKAGE, path="cache", create=True)
        except (ValueError, RuntimeError, OSError):
            pass
    return search.default_cache_dir()


def get_cache(context):
    """One SignatureCache per index folder for the whole session (its memory layer survives operators)."""
    path = os.path.abspath(cache_dir(context))
    prefs = _preferences(context)
    limit = search.COMPACT_MAX_DIRECTION if getattr(prefs, "compact_index", False) else None
    cache = _CACHES.get((path, limit))
    if cache is None:
        cache = _CACHES[(path, limit)] = search.SignatureCache(path, max_direction=limit)
    return cache


def _armature(context):
    obj = context.active_object
    if obj is None or obj.type != "ARMATURE":
        raise ShapeSigError("select an armature (the query is its action)")
    return obj


def _armature_digest(obj):
    h = hashlib.sha1()
    for pb in obj.pose.bones:
        h.update(f"{pb.name}\x1f{pb.rotation_mode}\x1e".encode())
        # the rest orientation: armature-space rotations (what the index stores) depend on it
        rest = np.array(pb.bone.matrix_local.to_3x3(), dtype=np.float64)
        h.update(np.round(rest, 9).tobytes())
    return h.hexdigest()[:16]


def _cropped_range(action, crop_start):
    """(crop_start, last frame) when the action starts before crop_start, else None (the whole action)."""
    if not crop_start:
        return None
    first, last = (int(round(v)) for v in action.frame_range)
    if first >= crop_start or last <= crop_start:
        return None
    return (int(crop_start), last)


def _owner_armature(action, default):
    """The armature object that plays ``action`` (active action or an NLA strip), else ``default``.

    A library action is read with its own rig: its bones' rest orientations give the armature space, and
    bones of another rig are not mistaken for unanimated bones of this one."""
    if default is not None and getattr(default.animation_data, "action", None) == action:
        return default
    for ob in bpy.data.objects:
        if ob.type != "ARMATURE" or ob.animation_data is None:
            continue
        if ob.animation_data.action == action:
            return ob
        for track in ob.animation_data.nla_tracks:
            if any(strip.action == action for strip in track.strips):
                return ob
    return default


def _action_item(action, obj, frame_range=None):
    from .. import action_io

    arm = _owner_armature(action, obj)
    key = (f"action:{action_io.action_hash(action)}|arm:{_armature_digest(arm)}|range:{frame_range}"
           f"|space:armature|keyed")
    name = action.name

    def load(action=action, arm=arm, frame_range=frame_range, name=name):
        # armature space: comparable with folder clips and with actions of rigs with other bone rolls;
        # only the bones the action keys (a bone it does not animate is unknown, not the rest pose)
        return action_io.read_action(action, armature=arm, frame_range=frame_range, name=name,
                                     space="armature", exclude_unkeyed=True)

    return search.LibraryItem(name, key, load, source=action.name)


def query_item(context, settings):
    """(armature, action, LibraryItem) of the query; ShapeSigError with a clear message otherwise."""
    obj = _armature(context)
    if settings.query_action:
        action = bpy.data.actions.get(settings.query_action)
        if action is None:
            raise ShapeSigError(f"there is no action {settings.query_action!r}")
    else:
        action = obj.animation_data.action if obj.animation_data else None
        if action is None:
            raise ShapeSigError(f"armature {obj.name!r} has no action: assign one or choose a query action")
    frame_range = None
    if settings.use_frame_range:
        if settings.frame_end <= settings.frame_start:
            raise ShapeSigError(f"the frame range {settings.frame_start}..{settings.frame_end} needs two frames")
        frame_range = (settings.frame_start, settings.frame_end)
    else:
        frame_range = _cropped_range(action, settings.crop_start)
    return obj, action, _action_item(action, obj, frame_range)


def _folders(context, settings):
    text = settings.folders
    if not text:
        prefs = _preferences(context)
        text = prefs.library_folders if prefs is not None else ""
    return [bpy.path.abspath(p.strip()) for p in text.split(";") if p.strip()]


def library_items(context, settings, obj):
    """The library as LibraryItems: the file's actions (filtered), then the folders' clip files."""
    from .. import action_io

    items = []
    if settings.use_file_actions:
        pattern = settings.name_filter.strip()
        for action in action_io.armature_actions(obj):
            if pattern and not fnmatch.fnmatchcase(action.name, pattern):
                continue
            if settings.assets_only:
                asset = getattr(action, "asset_data", None)
                if asset is None:
                    continue
                catalog = settings.catalog.strip()
                if catalog and not fnmatch.fnmatchcase(getattr(asset, "catalog_simple_name", ""), catalog):
                    continue
            items.append(_action_item(action, obj, _cropped_range(action, settings.crop_start)))
    if settings.use_folders:
        folders = _folders(context, settings)
        if not folders:
            raise ShapeSigError("no library folders: add some in the panel or the add-on preferences")
        items += search.folder_library(folders, start=settings.crop_start or None)
    return items


def missing_count(context, settings):
    """How many of the query and library clips are not in the index yet."""
    obj, _action, q = query_item(context, settings)
    cache = get_cache(context)
    items = [q] + [it for it in library_items(context, settings, obj) if it.key != q.key]
    return sum(not cache.contains(it.key, settings.level) for it in items)


def _store_results(settings, results, query_name):
    settings.results.clear()
    for r in results:
        row = settings.results.add()
        row.name = r.name
        row.distance = r.distance
        row.has_elastic = r.elastic is not None
        row.approximate = r.approximate
        row.elastic = r.elastic if r.elastic is not None else 0.0
        row.frames = r.frames
        row.shared = r.shared
        row.partial = r.partial
        row.is_action = r.key.startswith("action:")
        row.source = r.source if not row.is_action else r.name
        row.clip_name = r.name
    settings.results_index = 0
    settings.query_name = query_name


def rank_into_settings(context, settings):
    """Run the search with the panel's settings and store the results; returns the RankList."""
    obj, action, q = query_item(context, settings)
    items = [it for it in library_items(context, settings, obj) if it.key != q.key]
    if not items:
        raise ShapeSigError("the library is empty: no other action animates this armature"
                            + (" or matches the filter" if settings.name_filter else "")
                            + ("" if settings.use_folders else "; add folders of clips"))
    cache = get_cache(context)
    res = search.rank_clips(q, items, metric="sim", level=settings.level, rerank=settings.rerank,
                            top=settings.top or None, cache=cache, depth=settings.depth)
    _store_results(settings, res, action.name)
    return res


def _settings(context):
    from ..properties import settings_of

    s = settings_of(context)
    if s is None:
        raise ShapeSigError("the scene has no ShapeSig settings (is the add-on registered?)")
    return s


def _tag_redraw(context):
    screen = getattr(context, "screen", None)
    for area in getattr(screen, "areas", ()):
        if area.type in ("VIEW_3D", "DOPESHEET_EDITOR", "NLA_EDITOR"):
            area.tag_redraw()


# ---------------------------------------------------------------------------------------- operators

class SHAPESIG_OT_build_index(bpy.types.Operator):
    """Compute the signature index of every library clip not indexed yet (Esc cancels)"""

    bl_idname = "shapesig.build_index"
    bl_label = "Build Index"
    bl_options = {"REGISTER"}  # writes only the cache folder, never the .blend

    then_rank: BoolProperty(name="Then Rank", description="Run Find Similar when the index is complete",
                            default=False, options={"SKIP_SAVE", "HIDDEN"})

    _timer = None

    def _prepare(self, context):
        self.settings = _settings(context)
        obj, _action, q = query_item(context, self.settings)
        self.items = [q] + [it for it in library_items(context, self.settings, obj) if it.key != q.key]
        self.cache = get_cache(context)
        self.level = self.settings.level
        self.done = 0
        self.errors = []
        self.before = dict(self.cache.stats)

    def _step(self):
        item = self.items[self.done]
        try:
            self.cache.entries(item, self.level)
        except ShapeSigError as exc:
            self.errors.append(f"{item.name}: {exc}")
        self.done += 1

    def _finish(self, context, cancelled=False):
        s = self.settings
        s.index_running = False
        s.index_progress = 1.0 if not cancelled else s.index_progress
        computed = self.cache.stats["misses"] - self.before.get("misses", 0)
        msg = (f"index: {self.done} of {len(self.items)} clips, {computed} computed, "
               f"{self.done - computed} already indexed")
        if cancelled:
            msg = "cancelled; " + msg
        if self.errors:
            msg += f"; {len(self.errors)} could not be read ({self.errors[0]})"
        s.message = msg
        self.report({"WARNING"} if (self.errors or cancelled) else {"INFO"}, msg)
        _tag_redraw(context)
        if getattr(self, "then_rank", False) and not cancelled:
            try:
                bpy.ops.shapesig.rank()
            except RuntimeError:
                pass  # rank reported its error already

    def execute(self, context):
        try:
            self._prepare(context)
            while self.done < len(self.items):
                self._step()
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self._finish(context)
        return {"FINISHED"}

    def invoke(self, context, event):
        if context.window is None or bpy.app.background:
            return self.execute(context)
        try:
            self._prepare(context)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self.settings.index_running = True
        self.settings.index_progress = 0.0
        wm = context.window_manager
        wm.progress_begin(0, len(self.items))
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()

    def modal(self, context, event):
        if event.type == "ESC":
            self._end_modal(context)
            self._finish(context, cancelled=True)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if self.done < len(self.items):
                self._step()
        except Exception as exc:  # noqa: BLE001 - never leave a modal operator running after an error
            self._end_modal(context)
            self.settings.index_running = False
            self.report({"ERROR"}, f"Build Index: {exc}")
            return {"CANCELLED"}
        self.settings.index_progress = self.done / max(len(self.items), 1)
        context.window_manager.progress_update(self.done)
        _tag_redraw(context)
        if self.done >= len(self.items):
            self._end_modal(context)
            self._finish(context)
            return {"FINISHED"}
        return {"RUNNING_MODAL"}


class SHAPESIG_OT_rank(bpy.types.Operator):
    """Rank the library by similarity (sim^n) to the query action"""

    bl_idname = "shapesig.rank"
    bl_label = "Find Similar"
    bl_options = {"REGISTER", "UNDO"}

    def invoke(self, context, event):
        # In the UI, when several clips still need indexing, index them first with the cancellable
        # progress bar (build_index ranks when it is done); otherwise rank at once.
        if context.window is not None and not bpy.app.background:
            try:
                missing = missing_count(context, _settings(context))
            except ShapeSigError:
                missing = 0  # execute reports the problem
            if missing >= 2:
                bpy.ops.shapesig.build_index("INVOKE_DEFAULT", then_rank=True)
                return {"CANCELLED"}
        return self.execute(context)

    def execute(self, context):
        try:
            settings = _settings(context)
            res = rank_into_settings(context, settings)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Rank: {exc}")
            s = getattr(context.scene, "shapesig", None)
            if s is not None:
                s.message = str(exc)
            return {"CANCELLED"}
        st = res.stats
        msg = (f"{len(res)} results from {st.get('library', 0)} clips ({st.get('misses', 0)} newly indexed, "
               f"{st.get('seconds', 0.0):.2f} s)")
        if res.warnings:
            msg += f"; {len(res.warnings)} warning(s): {res.warnings[0]}"
            self.report({"WARNING"}, msg)
        else:
            self.report({"INFO"}, msg)
        settings.message = msg
        _tag_redraw(context)
        return {"FINISHED"}


def _selected_result(context):
    settings = _settings(context)
    if not settings.results:
        raise ShapeSigError("no results: run Find Similar first")
    i = settings.results_index
    if not 0 <= i < len(settings.results):
        raise ShapeSigError("select a result in the list")
    return settings, settings.results[i]


def result_action(context, obj, row):
    """The bpy action of a result row; a folder clip is first written as a new action on ``obj``."""
    if row.is_action:
        action = bpy.data.actions.get(row.source)
        if action is None:
            raise ShapeSigError(f"the action {row.source!r} no longer exists")
        return action
    from .. import action_io, clips

    settings = _settings(context)
    loaded = clips.load_clips(row.source)
    match = [c for c in loaded if c.name == row.clip_name] or loaded
    clip = match[0]
    if settings.crop_start and clip.frame_end >= settings.crop_start:
        clip = clip.crop(start=settings.crop_start)
    action = action_io.write_action(clip, armature=obj, name=clip.name)
    row.is_action = True
    row.source = action.name
    return action


class SHAPESIG_OT_assign_result(bpy.types.Operator):
    """Make the selected result the active armature's action"""

    bl_idname = "shapesig.assign_result"
    bl_label = "Assign Result"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from .. import compat

        try:
            obj = _armature(context)
            _settings_, row = _selected_result(context)
            action = result_action(context, obj, row)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Assign Result: {exc}")
            return {"CANCELLED"}
        compat.assign_action(obj, action)
        self.report({"INFO"}, f"{obj.name}: action {action.name!r}")
        return {"FINISHED"}


class SHAPESIG_OT_preview_result(bpy.types.Operator):
    """Play the selected result on the armature; run again to stop and restore its action"""

    bl_idname = "shapesig.preview_result"
    bl_label = "Preview Result"
    bl_options = {"REGISTER", "UNDO"}

    stop: BoolProperty(name="Stop", description="Stop the preview and restore the action", default=False,
                       options={"SKIP_SAVE"})

    def _restore(self, context, settings):
        from .. import compat

        obj = bpy.data.objects.get(settings.preview_object)
        if obj is not None:
            compat.assign_action(obj, bpy.data.actions.get(settings.preview_action) if settings.preview_action else None)
        settings.preview_object = ""
        settings.preview_action = ""
        screen = getattr(context, "screen", None)
        if screen is not None and screen.is_animation_playing:
            bpy.ops.screen.animation_cancel(restore_frame=True)

    def execute(self, context):
        from .. import compat

        try:
            settings = _settings(context)
            if settings.preview_object or self.stop:
                self._restore(context, settings)
                self.report({"INFO"}, "preview stopped")
                return {"FINISHED"}
            obj = _armature(context)
            _s, row = _selected_result(context)
            action = result_action(context, obj, row)
        except ShapeSigError as exc:
            self.report({"ERROR"}, f"Preview: {exc}")
            return {"CANCELLED"}
        current = obj.animation_data.action if obj.animation_data else None
        settings.preview_object = obj.name
        settings.preview_action = current.name if current is not None else ""
        compat.assign_action(obj, action)
        start, end = (int(v) for v in action.frame_range)
        context.scene.frame_set(start)
        screen = getattr(context, "screen", None)
        if screen is not None and context.window is not None and not screen.is_animation_playing:
            bpy.ops.screen.animation_play()
        self.report({"INFO"}, f"previewing {action.name!r} (frames {start}-{end}); run again to stop")
        return {"FINISHED"}


class SHAPESIG_OT_clear_index(bpy.types.Operator):
    """Delete the signature index files (they are rebuilt when needed)"""

    bl_idname = "shapesig.clear_index"
    bl_label = "Clear Index"
    bl_options = {"REGISTER"}

    def execute(self, context):
        try:
            cache = get_cache(context)
            n, size = cache.disk_usage()
            cache.clear()
        except OSError as exc:
            self.report({"ERROR"}, f"Clear Index: {exc}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"removed {n} index files ({size / 2 ** 20:.1f} MB)")
        return {"FINISHED"}


classes = (SHAPESIG_OT_build_index, SHAPESIG_OT_rank, SHAPESIG_OT_assign_result, SHAPESIG_OT_preview_result,
           SHAPESIG_OT_clear_index)
