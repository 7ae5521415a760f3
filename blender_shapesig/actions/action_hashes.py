"""The content hashes of an action's F-curves (through the bpy objects it is given; no core maths).

* ``action_hash``: every edit of an F-curve changes it; the record the tests compare to show that an operator
  leaves its sources untouched.
* ``read_hash``: what ``action_io.read_action`` reads; the search library keys an action's clip by it, and
  ``action_changes`` remembers it per session. One ``foreach_get`` per F-curve of motion capture, seven for
  ``action_hash``.
"""

import hashlib

import numpy as np

from .. import compat

__all__ = ["action_hash", "read_hash"]


def _settings_text(item, depth=1):
    """Every plain setting of an RNA struct (numbers, flags, enums, arrays) in RNA order, and those of the items
    of its collections (an envelope's control points) down to ``depth``."""
    parts = []
    for p in item.bl_rna.properties:
        if p.identifier == "rna_type" or p.type == "POINTER":
            continue
        v = getattr(item, p.identifier, None)
        if p.type == "COLLECTION":
            if depth > 0 and v is not None:
                parts.append(f"{p.identifier}=[{'/'.join(_settings_text(x, depth - 1) for x in v)}]")
            continue
        parts.append(f"{p.identifier}={tuple(v) if hasattr(v, '__len__') and not isinstance(v, str) else v}")
    return ";".join(parts)


def _modifier_text(m):
    """A modifier's type and settings."""
    return f"{m.type};{_settings_text(m)}"


def action_hash(action) -> str:
    """SHA-1 of the action's F-curve data (all slots): data paths, indices, mute, extrapolation, modifiers and
    their settings, and every key's co, handles, handle types, interpolation and easing. Any edit of an F-curve
    changes it (``read_hash`` is the cheaper key of what ``read_action`` reads)."""
    h = hashlib.sha1()
    fcurves = compat.all_action_fcurves(action)
    for fc in sorted(fcurves, key=lambda f: (f.data_path, f.array_index)):
        h.update(f"{fc.data_path}[{fc.array_index}]|{fc.mute}|{fc.extrapolation}|".encode())
        h.update("|".join(_modifier_text(m) for m in fc.modifiers).encode())
        kp = fc.keyframe_points
        n = len(kp)
        h.update(n.to_bytes(8, "little"))
        if not n:
            continue
        for attr in ("co", "handle_left", "handle_right"):
            buf = np.empty(2 * n, dtype=np.float32)  # the RNA float type
            kp.foreach_get(attr, buf)
            h.update(buf.tobytes())
        for attr in ("interpolation", "handle_left_type", "handle_right_type", "easing"):
            ibuf = np.empty(n, dtype=np.int32)  # enum values: foreach_get reads them on 4.2 to 5.2
            kp.foreach_get(attr, ibuf)
            h.update(ibuf.tobytes())
    return h.hexdigest()


_READ_HASH_VERSION = b"read_hash 1|"
_INTERP_BEZIER = 2  # Keyframe.interpolation enum values above it are the easing types (SINE ... ELASTIC)


def _keys_on_integer_frames(cos):
    """Per curve (its keys' ``co`` as x0, y0, x1, ...), True when the keys sit on consecutive integer frames
    (or there are none): one vectorized test for all the curves of an action."""
    ns = np.array([len(c) // 2 for c in cos], dtype=np.int64)
    out = np.ones(len(cos), dtype=bool)
    keyed = np.flatnonzero(ns)
    if not len(keyed):
        return out
    x = np.concatenate([cos[i][0::2] for i in keyed]).astype(np.float64)
    counts = ns[keyed]
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    first = x[starts]
    expected = np.repeat(first - starts, counts) + np.arange(len(x))
    out[keyed] = np.logical_and.reduceat(x == expected, starts) & (first == np.round(first))
    return out


def read_hash(action, co_cache=None) -> str:
    """SHA-1 of what ``read_action`` reads from the action: equal read hashes give equal clips for every
    armature, bone list and frame range. The library keys an action's clip by it (``library.ActionKey``).

    ``read_action`` samples each F-curve on integer frames. On a curve whose keys sit on consecutive integer
    frames, with constant extrapolation and no modifiers (what motion capture and ``write_action`` give), every
    sample is a key's value whatever the interpolation, handles or easing: there the hash takes path, index,
    mute, extrapolation and the keys' ``co`` only, one ``foreach_get`` per F-curve where ``action_hash`` makes
    seven (``benchmarks/bench_find_similar.py``). Any other curve adds the interpolation, the handles when a
    key is Bézier (they also give a linear extrapolation's slope at a Bézier end), the easing and its
    parameters when a key eases, and every modifier's settings. The action's manual frame range and the fps
    and rotation modes ``write_action`` stores on it are hashed too. ``action_hash`` stays the record of every
    edit (the tests that sources are untouched use it)."""
    h = hashlib.sha1(_READ_HASH_VERSION)
    manual = getattr(action, "use_frame_range", False)
    rng = (float(action.frame_start), float(action.frame_end)) if manual else None
    stored = {k: action.get(k) for k in ("shapesig_fps", "shapesig_rotation_modes")}
    stored = {k: (v.to_dict() if hasattr(v, "to_dict") else v) for k, v in stored.items() if v is not None}
    h.update(repr((rng, sorted(stored.items()))).encode())
    curves = sorted(compat.all_action_fcurves(action), key=lambda f: (f.data_path, f.array_index))
    cos, plain = [], []  # each curve's keys (x0, y0, x1, ...); True: constant extrapolation, no modifiers
    for fc in curves:
        extrapolation, modifiers = fc.extrapolation, fc.modifiers
        kp = fc.keyframe_points
        n = len(kp)
        h.update(f"{fc.data_path}[{fc.array_index}]|{fc.mute}|{extrapolation}|{n}|".encode())
        if len(modifiers):
            h.update("|".join(_modifier_text(m) for m in modifiers).encode())
        co = co_cache.get(fc.as_pointer()) if co_cache else None
        if co is None:
            co = np.empty(2 * n, dtype=np.float32)  # the RNA float type
            if n:
                kp.foreach_get("co", co)
        h.update(co.tobytes())
        cos.append(co)
        plain.append(extrapolation == "CONSTANT" and not len(modifiers))
    for i in np.flatnonzero(~_keys_on_integer_frames(cos) | ~np.array(plain, dtype=bool)):
        kp, n = curves[i].keyframe_points, len(cos[i]) // 2
        interp = np.empty(n, dtype=np.int32)
        kp.foreach_get("interpolation", interp)
        h.update(f"{i}|".encode() + interp.tobytes())
        if (interp == _INTERP_BEZIER).any():  # also the slope of a linear extrapolation at a Bézier end
            for attr in ("handle_left", "handle_right"):
                buf = np.empty(2 * n, dtype=np.float32)
                kp.foreach_get(attr, buf)
                h.update(buf.tobytes())
        if (interp > _INTERP_BEZIER).any():
            for attr, dtype in (("easing", np.int32), ("back", np.float32), ("amplitude", np.float32),
                                ("period", np.float32)):
                buf = np.empty(n, dtype=dtype)
                kp.foreach_get(attr, buf)
                h.update(buf.tobytes())
    return h.hexdigest()
