"""The scene's search library (Blender layer): what the search operators and the panel search, and where.

* The query: the active armature's action, or the chosen one, optionally a frame range of it (``query_item``).
* The library (``library_items``): the file's actions that animate the armature's bones (name pattern, assets
  only), each read with the armature that plays it (its bone order, rest orientations and rotation modes), and
  the clip files of the chosen folders (``core.sources.library``: keyed by ``ClipSpec.key``, so the command
  line and the panel share entries; read only when their key is not cached).
* Keys are typed: an action's key is an ``ActionKey`` (the action's content hash, the armature's digest, the
  frame range), whose ``text`` is the cache key; an item knows it is an action of this file because it is an
  ``ActionItem``, never by parsing its key.
* The cache registry (``cache_dir``, ``get_cache``): one ``SignatureCache`` per index folder for the session.
* Preconditions (``search_problem``, ``result_problem``): one-line reasons why an operator cannot run; the
  operators' ``poll`` and the panel show the same text.
* Results (``rank_into_settings``, ``store_results``, ``result_action``, previews) in ``scene.shapesig``.

Source actions are only read, never modified.
"""

import fnmatch
import hashlib
import os
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

import bpy

from . import action_io, compat, rigmap
from .core import index, rigs, sources
from .core.errors import ShapeSigError
from .preferences import ADDON_ID, get_preferences
from .properties import settings_of

__all__ = ["ActionKey", "ActionItem", "CACHES", "cache_dir", "get_cache", "settings_of", "armature_digest",
           "owner_armature", "action_item", "search_problem", "result_problem", "preview_problem", "query_item",
           "library_items", "index_items", "missing_count", "rank_into_settings", "store_results",
           "selected_action", "result_action", "start_preview", "stop_preview"]

# The session's stores: (absolute index folder, compact limit) -> SignatureCache (their memory layer survives
# operators; clearing this dict makes the next operator read the folder afresh).
CACHES = {}


# ------------------------------------------------------------------------------------------ the cache

def cache_dir(context) -> str:
    """The index folder: the preferences' folder, else $SHAPESIG_CACHE_DIR, else the extension's user folder
    (``bpy.utils.extension_path_user``) when running as an extension, else core's per-user default."""
    prefs = get_preferences(context)
    if prefs is not None and prefs.cache_dir:
        return bpy.path.abspath(prefs.cache_dir)
    env = os.environ.get(index.CACHE_ENV)
    if env:
        return env
    return compat.extension_user_path(ADDON_ID, "cache") or index.default_cache_dir()


def get_cache(context) -> index.SignatureCache:
    """One SignatureCache per index folder (and compact mode) for the whole session."""
    path = os.path.abspath(cache_dir(context))
    limit = index.COMPACT_MAX_DIRECTION if getattr(get_preferences(context), "compact_index", False) else None
    cache = CACHES.get((path, limit))
    if cache is None:
        cache = CACHES[(path, limit)] = index.SignatureCache(path, max_direction=limit)
    return cache


# --------------------------------------------------------------------------------------- typed keys

@dataclass(frozen=True)
class ActionKey:
    """What an action's clip depends on: the action's F-curve data (``action_io.action_hash``), the armature
    it is read with (bone names, rotation modes, rest orientations: ``armature_digest``) and the frame range
    (None: the whole action). Clips are read in armature space, keyed bones only."""

    action_hash: str
    armature_digest: str
    frame_range: Optional[Tuple[int, int]] = None

    @property
    def text(self) -> str:
        """The cache key."""
        return (f"action:{self.action_hash}|arm:{self.armature_digest}|range:{self.frame_range}"
                f"|space:armature|keyed|bone_map=auto{rigs.TABLES_VERSION}")


@dataclass
class ActionItem(sources.LibraryItem):
    """A library item that is an action of this file (``action`` its name), keyed by ``action_key``."""

    action_key: Optional[ActionKey] = None


def armature_digest(obj) -> str:
    """Digest of an armature's pose bones: names, rotation modes and rest orientations (armature-space
    rotations, what the index stores, depend on them)."""
    h = hashlib.sha1()
    for pb in obj.pose.bones:
        h.update(f"{pb.name}\x1f{pb.rotation_mode}\x1e".encode())
        rest = np.array(pb.bone.matrix_local.to_3x3(), dtype=np.float64)
        h.update(np.round(rest, 9).tobytes())
    h.update(rigmap.map_digest(obj).encode())  # the bone map stored on the armature (rigmap)
    return h.hexdigest()[:16]


def owner_armature(action, default):
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


def action_item(action, obj, frame_range=None) -> ActionItem:
    """The library item of an action, read with the armature that plays it (else ``obj``)."""
    arm = owner_armature(action, obj)
    key = ActionKey(action_io.action_hash(action), armature_digest(arm),
                    None if frame_range is None else (int(frame_range[0]), int(frame_range[1])))

    def load(action=action, arm=arm, frame_range=key.frame_range, name=action.name):
        # armature space: comparable with folder clips and with actions of rigs with other bone rolls;
        # only the bones the action keys (a bone it does not animate is unknown, not the rest pose)
        clip = action_io.read_action(action, armature=arm, frame_range=frame_range, name=name,
                                     space="armature", exclude_unkeyed=True)
        # the comparison space across rigs, as folder clips get it at the front door (core.sources.read)
        return rigs.apply_bone_map(clip, rigmap.stored_map(arm) or "auto")

    return ActionItem(action.name, key.text, load, source=action.name, action=action.name, action_key=key)


# ------------------------------------------------------------------------------------ preconditions

def _armature(context):
    obj = getattr(context, "active_object", None)
    return obj if obj is not None and obj.type == "ARMATURE" else None


def _query_action(obj, settings):
    if settings.query_action:
        return bpy.data.actions.get(settings.query_action)
    return obj.animation_data.action if obj.animation_data else None


def search_problem(context, settings) -> Optional[str]:
    """Why the search (build index, rank) cannot run, in one line, or None."""
    if settings is None:
        return "the scene has no ShapeSig settings (is the add-on registered?)"
    obj = _armature(context)
    if obj is None:
        return "select an armature (the query is its action)"
    if _query_action(obj, settings) is None:
        if settings.query_action:
            return f"there is no action {settings.query_action!r}"
        return f"armature {obj.name!r} has no action: assign one or choose a query action"
    if settings.use_frame_range and settings.frame_end <= settings.frame_start:
        return f"the frame range {settings.frame_start}..{settings.frame_end} needs two frames"
    if not settings.use_file_actions and not settings.use_folders:
        return "the library is empty: search file actions or folders"
    return None


def result_problem(context, settings) -> Optional[str]:
    """Why the selected result cannot be assigned or previewed, in one line, or None."""
    if settings is None:
        return "the scene has no ShapeSig settings (is the add-on registered?)"
    if _armature(context) is None:
        return "select an armature (the query is its action)"
    if not settings.results:
        return "no results: run Find Similar first"
    if not 0 <= settings.results_index < len(settings.results):
        return "select a result in the list"
    return None


def preview_problem(context, settings) -> Optional[str]:
    """Why Preview cannot run, or None: while a preview plays, running it again stops it."""
    if settings is not None and settings.preview_object:
        return None
    return result_problem(context, settings)


def _check(problem):
    if problem is not None:
        raise ShapeSigError(problem)


# ------------------------------------------------------------------------------------------ library

def _cropped_range(action, crop_start):
    """(crop_start, last frame) when the action starts before crop_start, else None (the whole action)."""
    if not crop_start:
        return None
    first, last = (int(round(v)) for v in action.frame_range)
    if first >= crop_start or last <= crop_start:
        return None
    return (int(crop_start), last)


def query_item(context, settings):
    """(armature, action, ActionItem) of the query; ShapeSigError with a clear message otherwise."""
    _check(search_problem(context, settings))
    obj = _armature(context)
    action = _query_action(obj, settings)
    if settings.use_frame_range:
        frame_range = (settings.frame_start, settings.frame_end)
    else:
        frame_range = _cropped_range(action, settings.crop_start)
    return obj, action, action_item(action, obj, frame_range)


def _folders(context, settings):
    text = settings.folders
    if not text:
        prefs = get_preferences(context)
        text = prefs.library_folders if prefs is not None else ""
    return [bpy.path.abspath(p.strip()) for p in text.split(";") if p.strip()]


def _file_actions(settings, obj):
    """The file's actions that animate ``obj``'s bones, filtered by name pattern and asset catalog."""
    pattern = settings.name_filter.strip()
    catalog = settings.catalog.strip()
    for action in action_io.armature_actions(obj):
        if pattern and not fnmatch.fnmatchcase(action.name, pattern):
            continue
        if settings.assets_only:
            asset = getattr(action, "asset_data", None)
            if asset is None:
                continue
            if catalog and not fnmatch.fnmatchcase(getattr(asset, "catalog_simple_name", ""), catalog):
                continue
        yield action


def library_items(context, settings, obj) -> List[sources.LibraryItem]:
    """The library as LibraryItems: the file's actions (filtered), then the folders' clip files."""
    items = []
    if settings.use_file_actions:
        items += [action_item(a, obj, _cropped_range(a, settings.crop_start)) for a in _file_actions(settings, obj)]
    if settings.use_folders:
        folders = _folders(context, settings)
        if not folders:
            raise ShapeSigError("no library folders: add some in the panel or the add-on preferences")
        items += sources.library(folders, start=settings.crop_start or None)
    return items


def _search_items(context, settings):
    """(query action, query item, library items without the query)."""
    obj, action, q = query_item(context, settings)
    return action, q, [it for it in library_items(context, settings, obj) if it.key != q.key]


def index_items(context, settings) -> List[sources.LibraryItem]:
    """What Build Index indexes: the query, then the library."""
    _action, q, items = _search_items(context, settings)
    return [q] + items


def missing_count(context, settings) -> int:
    """How many of the query and library clips are not in the index yet."""
    cache = get_cache(context)
    return sum(not cache.contains(it.key, settings.level) for it in index_items(context, settings))


# ------------------------------------------------------------------------------------------ results

def store_results(settings, results, items, query_name):
    """Write a RankList into ``settings.results`` (``items``: the library ranked, to tell actions from files)."""
    kinds = {it.key: isinstance(it, ActionItem) for it in items}
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
        row.is_action = kinds.get(r.key, False)
        row.source = r.name if row.is_action else r.source
        row.clip_name = r.name
    settings.results_index = 0
    settings.query_name = query_name


def rank_into_settings(context, settings) -> index.RankList:
    """Run the search with the panel's settings and store the results; returns the RankList."""
    action, q, items = _search_items(context, settings)
    if not items:
        raise ShapeSigError("the library is empty: no other action animates this armature"
                            + (" or matches the filter" if settings.name_filter else "")
                            + ("" if settings.use_folders else "; add folders of clips"))
    res = index.rank_clips(q, items, metric="sim", level=settings.level, rerank=settings.rerank,
                           top=settings.top or None, cache=get_cache(context), depth=settings.depth)
    store_results(settings, res, items, action.name)
    return res


def selected_action(context, settings):
    """(armature, action) of the selected result (``result_action``); ShapeSigError with a clear message."""
    _check(result_problem(context, settings))
    obj = _armature(context)
    return obj, result_action(settings, obj, settings.results[settings.results_index])


def result_action(settings, obj, row):
    """The bpy action of a result row; a folder clip is first read (``core.sources``) and written as a new
    action on ``obj`` (the row then names that action)."""
    if row.is_action:
        action = bpy.data.actions.get(row.source)
        if action is None:
            raise ShapeSigError(f"the action {row.source!r} no longer exists")
        return action
    loaded = sources.read(row.source)
    clip = next((c for c in loaded if c.name == row.clip_name), loaded[0])
    if settings.crop_start and clip.frame_end >= settings.crop_start:
        clip = clip.crop(start=settings.crop_start)
    action = action_io.write_action(clip, armature=obj, name=clip.name)
    row.is_action = True
    row.source = action.name
    return action


def start_preview(context, settings, obj, action):
    """Assign ``action`` to ``obj`` until ``stop_preview`` (the current action is remembered) and play it."""
    current = obj.animation_data.action if obj.animation_data else None
    settings.preview_object = obj.name
    settings.preview_action = current.name if current is not None else ""
    compat.assign_action(obj, action)
    context.scene.frame_set(int(action.frame_range[0]))
    screen = getattr(context, "screen", None)
    if screen is not None and context.window is not None and not screen.is_animation_playing:
        bpy.ops.screen.animation_play()


def stop_preview(context, settings):
    """Give the previewed armature its action back and stop playing."""
    obj = bpy.data.objects.get(settings.preview_object)
    if obj is not None:
        compat.assign_action(obj, bpy.data.actions.get(settings.preview_action) if settings.preview_action else None)
    settings.preview_object = ""
    settings.preview_action = ""
    screen = getattr(context, "screen", None)
    if screen is not None and screen.is_animation_playing:
        bpy.ops.screen.animation_cancel(restore_frame=True)
