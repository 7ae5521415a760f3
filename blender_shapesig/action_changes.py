"""Change detection for actions: each action's ``read_hash`` (and the bones it animates) is remembered for the
session with a cheap stamp and dropped when the depsgraph reports the action updated, on undo, redo and file load,
when the stamp differs, or on ``forget_fingerprints(action)``; ``action_fingerprint`` returns the same string as
``read_hash``. See docs/search.md, "The index and its cache".
"""

import bpy

from . import compat
from .action_hashes import read_hash
from .bone_channels import bone_channels

__all__ = ["action_fingerprint", "action_bones", "forget_fingerprints", "refresh_fingerprints",
           "remembered_hash", "stop_change_detection"]

_FINGERPRINTS = {}  # action session id -> _Fingerprint
_HANDLERS = []  # the (handler list, function) pairs installed by _watch()


_GENERATION = [0]  # advanced by refresh_fingerprints: a stamp is read once per generation (once per click)


class _Fingerprint:
    __slots__ = ("stamp", "hash", "bone_set", "generation")

    def __init__(self, stamp):
        self.stamp = stamp
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
    """The action's fingerprint when it is remembered and current, else None (never computes one)."""
    rec = _FINGERPRINTS.get(_uid(action)) if _HANDLERS else None
    return rec.hash if rec is not None and rec.generation == _GENERATION[0] else None


def action_bones(action) -> frozenset:
    """The names of the pose bones ``action`` animates (F-curves not muted), remembered like its fingerprint."""
    return _record(action).bones(action)


def action_fingerprint(action) -> str:
    """``read_hash(action)``, computed once per session while the action is unchanged (see above)."""
    rec = _record(action)
    if rec.hash is None:
        rec.hash = read_hash(action)
    return rec.hash


def forget_fingerprints(action=None):
    """Drop the remembered fingerprint of ``action`` (None: of every action)."""
    if action is None:
        _FINGERPRINTS.clear()
    else:
        _FINGERPRINTS.pop(_uid(action), None)


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
            _FINGERPRINTS.pop(_uid(idb.original if idb.original is not None else idb), None)


@bpy.app.handlers.persistent
def _on_undo_redo_load(*_args):
    _FINGERPRINTS.clear()


def _watch():
    """Install the handlers (once per session)."""
    if _HANDLERS:
        return
    h = bpy.app.handlers
    for lst, fn in ((h.depsgraph_update_post, _on_depsgraph_update), (h.undo_post, _on_undo_redo_load),
                    (h.redo_post, _on_undo_redo_load), (h.load_post, _on_undo_redo_load)):
        if fn not in lst:
            lst.append(fn)
        _HANDLERS.append((lst, fn))


def stop_change_detection():
    """Remove the handlers and forget every fingerprint (when the add-on is disabled)."""
    for lst, fn in _HANDLERS:
        if fn in lst:
            lst.remove(fn)
    _HANDLERS.clear()
    _FINGERPRINTS.clear()
