"""The scene's search library (Blender layer): the query (``query_item``), the library items (``library_items``: the
file's actions, keyed by a typed ``ActionKey``, and the clip files of the chosen folders, step by step in
``SearchLibrary``), the cache registry (``cache_dir``, ``get_cache``), the one-line preconditions
(``search_problem``, ``result_problem``), Build Index's steps (``index_steps``) and the cost of an index
(``index_cost``). A click is ``rank_job.RankJob``, its rows ``result_rows``'. Source actions are only read. See
docs/dev/blender_layer.md.
"""

import fnmatch
import functools
import hashlib
import os
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

import bpy

from ..actions import action_changes, action_spaces, frame_rates, scene_motion
from ..rigs import rigmap
from ..core import search as index
from ..core.io import sources
from ..core.measure_words import OPTIONS
from ..core.errors import ShapeSigError, check_frame_range, check_integer
from ..core.io.files import skipped_line
from ..actions.owners import find_owner
from .rig_library import library_actions
from ..preferences import ADDON_ID, get_preferences
from ..properties import PANEL_MAX_LEVEL, index_level, results_of, settings_of, uses_local

__all__ = ["ActionKey", "ActionItem", "CACHES", "cache_dir", "get_cache", "settings_of", "armature_digest",
           "owner_armature", "action_item", "search_problem", "result_problem", "preview_problem", "query_item",
           "SearchLibrary", "search_library", "library_items", "index_items", "index_steps",
           "missing_count", "active_armature", "check_problem", "index_cost", "cost_text", "COSTLY_LEVEL"]

# The session's stores: (absolute index folder, compact limit) -> SignatureCache (their memory layer survives
# operators; clearing this dict makes the next operator read the folder afresh).
CACHES = {}


# ------------------------------------------------------------------------------------------ the cache

def cache_dir(context) -> str:
    """The index folder: the preferences' folder, else the command line's per-user default
    (``index.default_cache_dir``: $SHAPESIG_CACHE_DIR, else the user's cache folder), so the panel and the CLI
    share one index."""
    prefs = get_preferences(context)
    if prefs is not None and prefs.cache_dir:
        return bpy.path.abspath(prefs.cache_dir)
    return index.default_cache_dir()


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
    """What an action's clip depends on: the action's F-curve data (``action_io.read_hash``), the armature
    it is read with (bone names, rotation modes, rest orientations: ``armature_digest``) and the frame range
    (None: the whole action). Clips are read in armature space, keyed bones only."""

    read_hash: str
    armature_digest: str
    frame_range: Optional[Tuple[int, int]] = None
    trim: str = "none"            # "auto" trims rest-pose / ramp frames (core.clip.trim)
    fps: Optional[float] = None   # the rate read at (None: the action's own, else the scene's)

    @functools.cached_property
    def text(self) -> str:
        """The cache key (made once: a click asks for every library action's)."""
        return (f"action:{self.read_hash}|arm:{self.armature_digest}|range:{self.frame_range}"
                f"|space:armature|keyed|bone_map={sources.bone_map_key('auto')}"
                + (f"|{sources.trim_key(self.trim)}" if self.trim != "none" else "")
                + (f"|fps={self.fps}" if self.fps else ""))


@dataclass
class ActionItem(sources.LibraryItem):
    """A library item that is an action of this file (``action`` its name), keyed by ``action_key``."""

    action_key: Optional[ActionKey] = None
    rate: Optional[Tuple[float, bool]] = None  # (fps, known): ``frame_rates.rate_of`` when the item was made


def armature_digest(obj) -> str:
    """Digest of an armature's pose bones: names, rotation modes and rest orientations, and of the object's world
    matrix (the world-axes rotations the index stores depend on them: ``action_spaces.to_armature_space``)."""
    h = hashlib.sha1()
    world = action_spaces.object_matrix(obj)
    if world is not None:
        h.update(np.round(world, 9).tobytes())
    for pb in obj.pose.bones:
        h.update(f"{pb.name}\x1f{pb.rotation_mode}\x1e".encode())
        rest = np.array(pb.bone.matrix_local.to_3x3(), dtype=np.float64)
        h.update(np.round(rest, 9).tobytes())
    h.update(rigmap.map_digest(obj).encode())  # the bone map stored on the armature (rigmap)
    return h.hexdigest()[:16]


def owner_armature(action, default, owners=None):
    """The armature object ``action`` belongs to (``owners.find_owner``, ``default`` the armature the user works
    with), else ``default`` when no armature holds its bones; ShapeSigError (one line) when it cannot be decided.

    A library action is read with its own rig: its bones' rest orientations give the armature space, and
    bones of another rig are not mistaken for unanimated bones of this one."""
    known = owners.get(action.as_pointer(), False) if owners else False  # rig_library.library_actions' owners
    return (find_owner(action, prefer=default) if known is False else known) or default


def action_item(action, obj, frame_range=None, digests=None, trim="none", fps=None, owners=None) -> ActionItem:
    """The library item of an action, read with the armature that plays it (else ``obj``) through that
    armature's bone map (``rigmap.bone_map_of``). Its content hash is the session's fingerprint
    (``action_changes``: re-read only when the action changed); ``digests``: a dict remembering
    ``armature_digest`` per armature for one library. ``trim`` "auto": rest-pose / ramp frames dropped
    (``sources.trim_ends``; a ``frame_range``'s start is explicit and kept: pass "none" for an exact range);
    ``fps``: the rate to read at (None: the action's own); ``owners``: the owners ``library_actions`` found."""
    arm = owner_armature(action, obj, owners)
    stored = frame_rates.stored_rate(action)
    rate = (stored, True) if stored else tuple(frame_rates.rate_of(action)[:2])
    fps = fps or (None if stored else rate[0])  # found or assumed
    digests = {} if digests is None else digests
    digest = digests.get(arm.as_pointer())
    if digest is None:
        digest = digests[arm.as_pointer()] = armature_digest(arm)
    key = ActionKey(action_changes.action_fingerprint(action), digest,
                    None if frame_range is None else (int(frame_range[0]), int(frame_range[1])), trim,
                    float(fps) if fps else None)

    def load(action=action, arm=arm, key=key, name=action.name):
        # armature space: comparable with folder clips and with actions of rigs with other bone rolls;
        # only the bones the action keys (a bone it does not animate is unknown, not the rest pose)
        clip = scene_motion.read_motion(action, arm, frame_range=key.frame_range, name=name, fps=key.fps)
        # trimmed (an explicit range's start kept) and into the comparison space, as files are (sources.read)
        start = key.frame_range[0] if key.frame_range else None
        return sources.after_read([clip], trim=key.trim, start=start, bone_map=rigmap.bone_map_of(arm))[0]

    return ActionItem(action.name, key.text, load, source=action.name, action=action.name, action_key=key,
                      rate=rate)


# ------------------------------------------------------------------------------------ preconditions

def active_armature(context):
    obj = getattr(context, "active_object", None)
    return obj if obj is not None and obj.type == "ARMATURE" else None


def _query_action(obj, settings):
    if settings.query_action:
        return bpy.data.actions.get(settings.query_action)
    if settings.preview_object == obj.name and settings.preview_action:
        return bpy.data.actions.get(settings.preview_action)  # while previewing: the action Stop gives back
    return obj.animation_data.action if obj.animation_data else None


def search_problem(context, settings) -> Optional[str]:
    """Why the search (build index, rank) cannot run, in one line, or None."""
    if settings is None:
        return "the scene has no ShapeSig settings (is the add-on registered?)"
    obj = active_armature(context)
    if obj is None:
        return "select an armature (the query is its action)"
    if _query_action(obj, settings) is None:
        if settings.query_action:
            return f"there is no action {settings.query_action!r}"
        return f"armature {obj.name!r} has no action: assign one or choose a query action"
    try:
        _check_values(settings)
        if settings.use_frame_range:
            _query_range(_query_action(obj, settings), settings)
    except ShapeSigError as exc:
        return str(exc)
    if not settings.use_file_actions and not settings.use_folders:
        return "the library is empty: search file actions or folders"
    return None


def _check_values(settings):
    """The search settings' integers, refused out of range (they have soft limits only: no silent clamping)."""
    check_integer(settings.level, OPTIONS["level"].status, 1, maximum=PANEL_MAX_LEVEL)
    check_integer(settings.rerank, OPTIONS["rerank"].status, 0)
    check_integer(settings.top, "show", 0)
    check_integer(settings.depth, OPTIONS["depth"].status, 1)
    check_integer(settings.crop_start, "crop start", 0)
    _read_options(settings)


def _read_options(settings):
    """(trim, fps) every clip of a search is read with: the Trim toggle, the FPS field (0: each clip's
    own rate; else refused unless plausible, ``prepare.check_fps``)."""
    from ..core.clip.prepare import check_fps

    fps = check_fps(settings.fps, "FPS") if settings.fps else None
    return settings.trim, fps


def result_problem(context, settings) -> Optional[str]:
    """Why the selected result cannot be assigned or previewed, in one line, or None."""
    if settings is None:
        return "the scene has no ShapeSig settings (is the add-on registered?)"
    if active_armature(context) is None:
        return "select an armature (the query is its action)"
    if not results_of().results:
        return "no results: run Find Similar first"
    if not 0 <= results_of().results_index < len(results_of().results):
        return "select a result in the list"
    return None


def preview_problem(context, settings) -> Optional[str]:
    """Why Preview cannot run, or None: while a preview plays, running it again stops it."""
    if settings is not None and settings.preview_object:
        return None
    return result_problem(context, settings)


def check_problem(problem):
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


def _query_range(action, settings):
    """The query's frame range: inside the action's own frames (``check_frame_range``: 2000..2100 on a
    317-frame action would compare held poses, every sim 1.0); a 0 start or end is the action's own."""
    first, last = (int(round(v)) for v in action.frame_range)
    return check_frame_range(settings.frame_start or first, settings.frame_end or last, first, last,
                             what=f"action {action.name!r}")


def query_item(context, settings, digests=None):
    """(armature, action, ActionItem) of the query; ShapeSigError with a clear message otherwise. ``digests``: as
    ``action_item``'s (a library made with the query shares them: the armature is hashed once)."""
    check_problem(search_problem(context, settings))
    action_changes.refresh_fingerprints(context)
    action_changes.use_store(get_cache(context))  # fingerprints stored by an earlier session
    obj = active_armature(context)
    action = _query_action(obj, settings)
    trim, fps = _read_options(settings)
    if settings.use_frame_range:  # an exact range: nothing trimmed from it
        frame_range, trim = _query_range(action, settings), "none"
    else:
        frame_range = _cropped_range(action, settings.crop_start)
    return obj, action, action_item(action, obj, frame_range, digests, trim=trim, fps=fps)


def _folders(context, settings):
    text = settings.folders
    if not text:
        prefs = get_preferences(context)
        text = prefs.library_folders if prefs is not None else ""
    return [bpy.path.abspath(p.strip()) for p in text.split(";") if p.strip()]


def _file_actions(settings, obj, owners=None):
    """The file's actions ``obj``'s search compares (``rig_library``), filtered by name pattern and catalog;
    ``owners``: as ``library_actions``'."""
    pattern = settings.name_filter.strip()
    catalog = settings.catalog.strip()
    for action in library_actions(obj, owners):
        if pattern and not fnmatch.fnmatchcase(action.name, pattern):
            continue
        if settings.assets_only:
            asset = getattr(action, "asset_data", None)
            if asset is None:
                continue
            if catalog and not fnmatch.fnmatchcase(getattr(asset, "catalog_simple_name", ""), catalog):
                continue
        yield action


def _folder_library(context, settings) -> sources.Library:
    """The folders' clip files as a ``sources.Library`` (found now, keyed one per step by its ``members``): the
    command line's library, with the panel's read options."""
    folders = _folders(context, settings)
    if not folders:
        raise ShapeSigError("no library folders: add some in the panel or the add-on preferences")
    asf = bpy.path.abspath(settings.asf.strip()) if settings.asf.strip() else None
    if asf is not None and not os.path.isfile(asf):
        raise ShapeSigError(f"the skeleton file {asf} does not exist")
    missing = next((f for f in folders if not os.path.isdir(f)), None)
    if missing is not None:
        raise ShapeSigError(f"library folder {missing!r} does not exist")
    trim, fps = _read_options(settings)
    files = sources.Library(folders, lambda text: sources.ClipSpec.parse(
        text, start=settings.crop_start or None, asf=asf, trim=trim, fps=fps), strict=False)
    files.found()  # a folder that does not exist is refused now; files the readers never open are skipped
    return files


@dataclass
class SearchLibrary:
    """What a search reads: the query (its action and item), the file's actions as items, and the folders' clip
    files (``files``, a ``sources.Library``) that are keyed only in ``members``, one per step, so that hashing the
    files runs inside the progress loop (Esc reaches it). ``skipped``: the files left out (not regular files,
    unreadable, over a cap: one-line ShapeSigErrors)."""

    action: object
    query: ActionItem
    actions: list
    files: Optional[sources.Library] = None
    unkeyed: int = 0  # members that could not be keyed (their reasons are in ``skipped``)

    @property
    def skipped(self) -> list:
        return self.files.skipped if self.files is not None else []

    @property
    def size(self) -> int:  # the query, the actions, the folder files
        return 1 + len(self.actions) + (len(self.files) if self.files is not None else 0)

    def members(self):
        """Yield each member's LibraryItem, the query first; a folder file is keyed at its turn (None when it
        cannot be: its reason joins ``skipped``)."""
        yield self.query
        yield from self.actions
        for item in self.files.members(holes=True) if self.files is not None else ():
            self.unkeyed += item is None
            yield item

    def skipped_text(self) -> str:  # '; skipped 4 files that are not regular files or ...: x.bvh, ...' or ''
        return f"; {skipped_line(self.skipped)}" if self.skipped else ""


def search_library(context, settings) -> SearchLibrary:
    """The query and the library without reading or hashing a clip file (``SearchLibrary``)."""
    digests = {}  # each armature hashed once (the query's and the library actions')
    obj, action, q = query_item(context, settings, digests)
    actions, files = [], None
    trim, fps = _read_options(settings)
    if settings.use_file_actions:
        owners = {}
        actions = [action_item(a, obj, _cropped_range(a, settings.crop_start), digests, trim, fps, owners)
                   for a in _file_actions(settings, obj, owners)]
        actions = [it for it in actions if it.key != q.key]
        action_changes.save_store()  # for the next session (written when they changed)
    if settings.use_folders:
        files = _folder_library(context, settings)
    return SearchLibrary(action, q, actions, files)


def library_items(context, settings, obj=None) -> List[sources.LibraryItem]:
    """The library's LibraryItems (file actions, then folder files keyed now; ``obj`` unused: the query's rig)."""
    return [it for it in search_library(context, settings).members() if it is not None][1:]


def index_items(context, settings) -> List[sources.LibraryItem]:
    """What Build Index indexes: the query, then the library (every folder file keyed now)."""
    return [it for it in search_library(context, settings).members() if it is not None]


def index_steps(lib: SearchLibrary, level, cache, errors, local=False, computed=None):
    """Build Index, one step per member of ``lib`` (a folder file is keyed at its turn): (item or None, entries),
    indexed when the store lacks it (``index.iter_entries``, ``local``: its local entries too; a read error joins
    ``errors``); the keys of the items computed now join ``computed``."""
    for item in lib.members():
        if item is None:
            yield None, []
            continue
        misses, failed = cache.stats["misses"], len(errors)
        got = next(index.iter_entries([item], level, cache, errors, local=local))
        if computed is not None and cache.stats["misses"] > misses and len(errors) == failed:
            computed.append(item.key)  # not in the store (or its file unreadable), read and indexed now
        yield got


def missing_count(context, settings) -> int:
    """How many of the query and library clips the settings' search (the local one: its own entries) lacks."""
    cache, level = get_cache(context), index_level(settings)
    return sum(not (cache.local.contains(it.key) if uses_local(settings) else cache.contains(it.key, level))
               for it in index_items(context, settings))


# Cost of an index (level 4 must not start unannounced). Measured: 110 CMU clips with 17 moving joints
# took 277.9 s and 750 MB at level 4. An entry is dominated by its log-signature direction (float32, Witt's
# dimension of R^(3 x moving joints) at the level), and computing it scales with that dimension too.
COST_REFERENCE = {"clips": 110, "moving": 17, "level": 4, "seconds": 277.9, "bytes": 750e6}
COSTLY_LEVEL = 4


def index_cost(context, settings):
    """(clips not indexed yet, estimated seconds, estimated bytes) of indexing the library at the settings'
    level, each clip assumed to move as many joints as the query (read once here)."""
    from ..core.signatures.signatures import log_signature_dim

    cache = get_cache(context)
    todo = [it for it in index_items(context, settings) if not cache.contains(it.key, settings.level)]
    if not todo:
        return 0, 0.0, 0.0
    _obj, _action, q = query_item(context, settings)
    clip = q.clips()[0]
    moving = max(len(clip.bones) - len(clip.still_bones()), 1)
    ref = COST_REFERENCE
    ref_dim = ref["clips"] * log_signature_dim(3 * ref["moving"], ref["level"])
    dim = len(todo) * log_signature_dim(3 * moving, settings.level)
    return len(todo), ref["seconds"] * dim / ref_dim, ref["bytes"] * dim / ref_dim


def cost_text(clips, seconds, nbytes):
    """One line: '110 clips to index at level 4: about 4.6 min and 750 MB of index'."""
    span = f"{seconds / 60:.1f} min" if seconds >= 90 else f"{seconds:.0f} s"
    size = f"{nbytes / 1e9:.1f} GB" if nbytes >= 1e9 else f"{nbytes / 1e6:.0f} MB"
    return f"{clips} clips to index: about {span} and {size} of index"
