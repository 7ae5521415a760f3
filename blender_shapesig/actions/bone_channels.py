"""The pose-bone channels of F-curves: which bone and property an F-curve animates (``pose.bones["B"].prop``).
The one parser of those data paths, for reading actions (``action_io``), their session fingerprints
(``action_changes``) and the .blend reader, and which property holds a rotation mode (``prop_for_mode``,
``mode_from_channels``, ``modes_lookup``: for reading and writing actions)."""

import re

from ..core.errors import ShapeSigError
from ..core.geometry.so3 import ROTATION_MODES

__all__ = ["PROPS", "bone_channels", "prop_for_mode", "mode_from_channels", "modes_lookup"]

# animated pose-bone properties and their array lengths
PROPS = {"rotation_quaternion": 4, "rotation_euler": 3, "rotation_axis_angle": 4, "location": 3, "scale": 3}
_MODE_PROP = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}
_PATH = re.compile(r'^pose\.bones\["((?:[^"\\]|\\.)*)"\]\.([A-Za-z_]+)$')


def _unescape(name):
    return re.sub(r"\\(.)", r"\1", name)


def bone_channels(fcurves):
    """{bone: {prop: {index: fcurve}}} for pose-bone F-curves (muted ones skipped), in order of appearance."""
    out = {}
    for fc in fcurves:
        if fc.mute:
            continue
        m = _PATH.match(fc.data_path)
        if not m:
            continue
        prop = m.group(2)
        if prop not in PROPS:
            continue
        index = fc.array_index
        if index >= PROPS[prop]:
            continue
        out.setdefault(_unescape(m.group(1)), {}).setdefault(prop, {})[index] = fc
    return out


def prop_for_mode(mode):
    """The pose-bone property that holds a rotation in ``mode`` (every Euler order: ``rotation_euler``)."""
    return _MODE_PROP.get(mode, "rotation_euler")


def mode_from_channels(chans):
    """The rotation mode that plays a bone's channels ({prop: ...}): quaternion first, then Euler (XYZ), then
    axis-angle; QUATERNION for none."""
    if "rotation_quaternion" in chans:
        return "QUATERNION"
    if "rotation_euler" in chans:
        return "XYZ"
    if "rotation_axis_angle" in chans:
        return "AXIS_ANGLE"
    return "QUATERNION"


def modes_lookup(rotation_modes, bones):
    """rotation_modes: None, one mode for all, a dict bone -> mode, or a sequence parallel to bones."""
    if rotation_modes is None:
        return {}
    if isinstance(rotation_modes, str):
        out = {b: rotation_modes for b in bones}
    elif isinstance(rotation_modes, dict):
        out = dict(rotation_modes)
    else:
        modes = list(rotation_modes)
        if len(modes) != len(bones):
            raise ShapeSigError(f"{len(modes)} rotation modes for {len(bones)} bones")
        out = dict(zip(bones, modes))
    bad = {m for m in out.values() if m not in ROTATION_MODES}
    if bad:
        raise ShapeSigError(f"unknown rotation mode(s) {', '.join(sorted(bad))}; use one of {', '.join(ROTATION_MODES)}")
    return out
