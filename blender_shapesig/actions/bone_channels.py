"""The pose-bone channels of F-curves: which bone and property an F-curve animates (``pose.bones["B"].prop``).
The one parser of those data paths, for reading actions (``action_io``), their session fingerprints
(``action_changes``) and the .blend reader."""

import re

__all__ = ["PROPS", "bone_channels"]

# animated pose-bone properties and their array lengths
PROPS = {"rotation_quaternion": 4, "rotation_euler": 3, "rotation_axis_angle": 4, "location": 3, "scale": 3}
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
