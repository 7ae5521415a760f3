"""Change detection for actions: each action's ``read_hash`` (and the bones it animates) is remembered for the
session with a cheap stamp and dropped when the depsgraph reports the action updated, on undo, redo and file load,
when the stamp differs, or on ``forget_fingerprints(action)``; ``action_fingerprint`` returns the same string as
``read_hash``. The fingerprints also outlive the session: they are stored in the index folder
(``SignatureCache.write_fingerprints``) keyed by the .blend file as it was loaded or saved (path, size,
modification time, inode, Blender version) and by each action's name and stamp, and a later session that
opens the same unchanged file takes an action's stored fingerprint only while no change to that action was
reported since the file was loaded (a depsgraph update, ``forget_fingerprints``), its name is the one it was
loaded under and its stamp is the same. See docs/search.md, "The index and its cache" and "The first click".
"""

import os

import bpy

from .. import compat
from .action_hashes import read_hash
from .bone_channels import bone_channels

__all__ = ["action_fingerprint", "action_bones", "forget_fingerprints", "refresh_fingerprints",
           "remembered_hash", "start_change_detection", "stop_change_detection", "use_store", "save_store",
           "store_stats"]

_FINGERPRINTS = {}  # action session id -> _Fingerprint
_HANDLERS = []  # the (handler list, function) pairs installed by _watch()


_GENERATION = [0]  # advanced by refresh_fingerprints: a stamp is read once per generation (once per click)


class _Fingerprint:
    __slots__ = ("stamp", "hash", "bone_set", "generation", "tried")

    def __init__(self, stamp):
        self.stamp = stamp
        self.tried = False  # the store looked at
        self.hash = None
        self.bone_set = None
        self.generation = _GENERATION[0]

    def bones(self, action):
        if self.bone_set is None:
            self.bone_set = frozenset(bone_channels(compat.all_action_fcurves(action)))
        return self.bone_set


def _uid(action):
    return getattr(action, "session_uid", None) or action.as_pointer()


def _bags(action):
    """The F-curve collections of an action (its channel bags on 4.4+, the action itself before)."""
    if not compat.is_layered(action):
        return [action.fcurves]
    bags = [bag.fcurves for layer in action.layers for strip in layer.strips
            for bag in getattr(strip, "channelbags", ())]
    legacy = getattr(action, "fcurves", None)
    return bags or ([legacy] if legacy is not None else [])


def _stamp(action):
    return tuple(len(fcurves) for fcurves in _bags(action))


# ------------------------------------------------------------------ fingerprints stored beyond the session

_STORE_FORMAT = 1  # raise when read_hash, bone_channels or the record change meaning
_FILE = {"key": None, "names": {}, "dirty": set(), "all_dirty": False, "cache": None, "records": None,
         "bone_sets": [], "written": None, "looked": None}
_STATS = {"stored": 0, "computed": 0, "writes": 0}


def store_stats() -> dict:
    """Counts since the file was loaded: fingerprints taken from the store, computed, and store writes."""
    return dict(_STATS)


def _file_key(filepath):
    """The .blend file as it is on disk now (a JSON list), or None (unsaved, unreadable)."""
    if not filepath:
        return None
    try:
        st = os.stat(filepath)
    except OSError:
        return None
    from .action_hashes import _READ_HASH_VERSION

    return [os.path.abspath(filepath), st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev, bpy.app.version_string,
            _STORE_FORMAT, _READ_HASH_VERSION.decode()]


def _local(action):
    """True for an action whose data is the file's own (not linked, not a library override)."""
    return action.library is None and getattr(action, "override_library", None) is None


def _disk_stamp(action, stamp=None):
    """The stamp an action's stored fingerprint is checked with: its F-curve counts (``stamp``: ``_stamp``'s,
    when known) and its frame range."""
    return [list(_stamp(action) if stamp is None else stamp), [float(v) for v in action.frame_range]]


def _snapshot(filepath):
    """The file as loaded (or saved) now: its key and each local action's name by its session id."""
    key = _file_key(filepath)
    _FILE.update(key=key, names={_uid(a): a.name for a in bpy.data.actions if _local(a)} if key else {},
                 dirty=set(), all_dirty=False, records=None, bone_sets=[], written=None, looked=None)


def use_store(cache):
    """Store fingerprints in ``cache`` (a ``SignatureCache``; once per click): its record of the loaded file is
    read the first time."""
    if cache is not _FILE["cache"]:
        _FILE.update(cache=cache, records=None, written=None)
    if _FILE["records"] is None:
        _FILE["records"], _FILE["bone_sets"] = {}, []
        key = _FILE["key"]
        record = cache.read_fingerprints(key[0]) if key is not None and cache is not None else None
        if record is not None and record.get("key") == key and isinstance(record.get("actions"), dict):
            _FILE["records"], _FILE["bone_sets"] = record["actions"], record.get("bone_sets", [])
            _FILE["written"] = _FILE["records"]


def _trusted(action, uid, stamp=None):
    """The stored (hash, bones) of an action unchanged since the file was loaded, else None (``stamp``: its
    ``_stamp`` when known)."""
    records = _FILE["records"]
    if not records or _FILE["all_dirty"] or uid in _FILE["dirty"]:
        return None
    name = action.name
    if _FILE["names"].get(uid) != name or not _local(action):
        return None
    rec = records.get(name)
    if not isinstance(rec, list) or len(rec) != 3 or rec[0] != _disk_stamp(action, stamp):
        return None
    try:
        bones = frozenset(_FILE["bone_sets"][rec[2]])
    except (IndexError, TypeError):
        return None
    return rec[1], bones


def _records(clean_only):
    """{name: [stamp, hash, bone set index]} and the bone sets of the actions whose fingerprint is known now (in
    the session or trusted from the store); ``clean_only``: only those unchanged since the file was loaded."""
    records, sets, index = {}, [], {}
    for action in bpy.data.actions:
        if not _local(action):
            continue
        uid = _uid(action)
        clean = not _FILE["all_dirty"] and uid not in _FILE["dirty"] and _FILE["names"].get(uid) == action.name
        if clean_only and not clean:
            continue
        rec, stamp = _FINGERPRINTS.get(uid), _stamp(action)
        if rec is not None and rec.hash is not None and rec.stamp == stamp:
            found = rec.hash, rec.bones(action)
        else:
            found = _trusted(action, uid, stamp) if clean else None
        if found is None:
            continue
        bones = tuple(sorted(found[1]))
        if bones not in index:
            index[bones] = len(sets)
            sets.append(list(bones))
        records[action.name] = [_disk_stamp(action, stamp), found[0], index[bones]]
    return records, sets


def _write(key, records, sets):
    cache = _FILE["cache"]
    if cache is None or key is None:
        return False
    ok = cache.write_fingerprints(key[0], {"key": key, "actions": records, "bone_sets": sets})
    _STATS["writes"] += ok
    return ok


def save_store():
    """Write the fingerprints of the actions unchanged since the file was loaded (after a click), when some
    were computed since the last look and they differ from the stored ones."""
    if _FILE["key"] is None or _FILE["cache"] is None or _STATS["computed"] == _FILE["looked"]:
        return
    _FILE["looked"] = _STATS["computed"]
    records, sets = _records(clean_only=True)
    if records and records != _FILE["written"]:
        if _write(_FILE["key"], records, sets):
            _FILE["written"] = records


def _record(action) -> _Fingerprint:
    _watch()
    uid = _uid(action)
    rec = _FINGERPRINTS.get(uid)
    if rec is not None and rec.generation == _GENERATION[0]:
        return rec
    stamp = _stamp(action)
    if rec is None or rec.stamp != stamp:
        rec = _FINGERPRINTS[uid] = _Fingerprint(stamp)
    rec.generation = _GENERATION[0]
    return rec


def remembered_hash(action):
    """The action's fingerprint when it is remembered and current, else None (never computes one; not the stored
    ones: ``action_fingerprint`` takes those)."""
    rec = _FINGERPRINTS.get(_uid(action)) if _HANDLERS else None
    return rec.hash if rec is not None and rec.generation == _GENERATION[0] else None


def action_bones(action) -> frozenset:
    """The names of the pose bones ``action`` animates (F-curves not muted), remembered like its fingerprint."""
    rec = _record(action)
    if rec.bone_set is None:
        _from_store(action, rec)
    return rec.bones(action)


def action_fingerprint(action) -> str:
    """``read_hash(action)``, computed once per session while the action is unchanged (see above)."""
    rec = _record(action)
    if rec.hash is None and not _from_store(action, rec):
        rec.hash = read_hash(action)
        _STATS["computed"] += 1
    return rec.hash


def _from_store(action, rec) -> bool:
    """Fill a new record from the store when the action's stored fingerprint is trusted (once per record)."""
    if rec.tried or not _FILE["records"]:
        return False
    rec.tried = True
    stored = _trusted(action, _uid(action), rec.stamp)
    if stored is None:
        return False
    rec.hash, rec.bone_set = stored[0], rec.bone_set or stored[1]
    _STATS["stored"] += 1
    return True


def forget_fingerprints(action=None):
    """Drop the remembered fingerprint of ``action`` (None: of every action); its stored one is not trusted
    again until the file is saved or loaded."""
    if action is None:
        _FINGERPRINTS.clear()
        _FILE["all_dirty"] = True
    else:
        _FINGERPRINTS.pop(_uid(action), None)
        _FILE["dirty"].add(_uid(action))


def refresh_fingerprints(context=None):
    """Start a new look at the file (once per click, before reading fingerprints): evaluate the depsgraph, so
    that edits not yet evaluated reach the update handler (in the UI it is evaluated already: this costs
    nothing), and read each action's stamp again on its next use (within one look, once)."""
    _watch()
    _GENERATION[0] += 1
    context = context or bpy.context
    if getattr(context, "view_layer", None) is not None:
        context.evaluated_depsgraph_get()


@bpy.app.handlers.persistent
def _on_depsgraph_update(_scene, depsgraph):
    for update in depsgraph.updates:
        idb = update.id
        if isinstance(idb, bpy.types.Action):
            uid = _uid(idb.original if idb.original is not None else idb)
            _FINGERPRINTS.pop(uid, None)
            _FILE["dirty"].add(uid)


@bpy.app.handlers.persistent
def _on_undo_redo(*_args):
    # the actions the undo step changes were reported changed when they were edited (the set only grows)
    _FINGERPRINTS.clear()


@bpy.app.handlers.persistent
def _on_load(*_args):
    _FINGERPRINTS.clear()
    _STATS.update(stored=0, computed=0, writes=0)
    _snapshot(bpy.data.filepath)


@bpy.app.handlers.persistent
def _on_save_pre(*_args):
    try:  # edits not evaluated yet reach the update handler before the fingerprints are written
        bpy.context.evaluated_depsgraph_get()
    except (AttributeError, RuntimeError):
        pass


@bpy.app.handlers.persistent
def _on_save_post(filepath="", *_args):
    """The saved file's fingerprints: the session's current ones and the trusted stored ones. Saved under the
    session's own path, the file as saved becomes the file as loaded (a copy saved elsewhere does not)."""
    filepath = filepath if isinstance(filepath, str) and filepath else bpy.data.filepath
    same = bpy.data.filepath and os.path.abspath(filepath) == os.path.abspath(bpy.data.filepath)
    records, sets = _records(clean_only=False)
    key = _file_key(filepath)
    if same:
        cache = _FILE["cache"]
        _snapshot(filepath)
        _FILE.update(cache=cache, records=records, bone_sets=sets, written=records)
    if records:
        _write(key, records, sets)


def _watch():
    """Install the handlers (once per session)."""
    if _HANDLERS:
        return
    h = bpy.app.handlers
    for lst, fn in ((h.depsgraph_update_post, _on_depsgraph_update), (h.undo_post, _on_undo_redo),
                    (h.redo_post, _on_undo_redo), (h.load_post, _on_load), (h.save_pre, _on_save_pre),
                    (h.save_post, _on_save_post)):
        if fn not in lst:
            lst.append(fn)
        _HANDLERS.append((lst, fn))


def start_change_detection():
    """Install the handlers (at register: a file loaded later is seen loaded, and its stored fingerprints can
    be trusted)."""
    _watch()


def stop_change_detection():
    """Remove the handlers and forget every fingerprint (when the add-on is disabled)."""
    for lst, fn in _HANDLERS:
        if fn in lst:
            lst.remove(fn)
    _HANDLERS.clear()
    _FINGERPRINTS.clear()
    _snapshot("")
