"""Mask a blend: per-bone-group weights through the bone map's canonical joints (``core.rigs``).

A mask is ``{name: weight}``, applied in order (a later entry wins where two overlap); a name is a group
(``GROUPS``, or a custom group ``{name: [joints or bones]}``), a canonical joint (``thigh.L``) or a bone name.
A bone belongs to the joint the bone map gives it (``rigs.resolve_map(..., "auto")``, or its own name in the
comparison space), else to the joint of its nearest mapped ancestor (fingers go with the hand, CMU's
``lhipjoint`` with the hips). Bones the mask does not name blend at the global weight. The root translation and
the timing follow the weight of the hips (in the ``legs`` group): an upper-body blend keeps A's travel.
"""

import numpy as np

from ..errors import ShapeSigError, check_number
from ..rigs import JOINTS, SIDES

__all__ = ["GROUPS", "parse_mask", "parse_groups", "bone_weights", "joint_of_bones"]


def _sided(*joints):
    return tuple(f"{j}.{s}" for s in SIDES for j in joints)


_ARM = ("clavicle", "upper_arm", "forearm", "hand")
_LEG = ("thigh", "shin", "foot", "toe")
GROUPS = {
    "legs": ("hips",) + _sided(*_LEG),
    "arms": _sided(*_ARM),
    "spine": ("spine", "spine_mid", "chest"),
    "head": ("neck", "head"),
    "upper": ("spine", "spine_mid", "chest", "neck", "head") + _sided(*_ARM),
    "left_arm": tuple(f"{j}.L" for j in _ARM), "right_arm": tuple(f"{j}.R" for j in _ARM),
    "left_leg": tuple(f"{j}.L" for j in _LEG), "right_leg": tuple(f"{j}.R" for j in _LEG),
}


def parse_mask(text):
    """``"upper=0.2,legs=0.8"`` -> ``{"upper": 0.2, "legs": 0.8}`` (order kept); ShapeSigError on a bad entry."""
    out = {}
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        name, sep, value = part.partition("=")
        if not sep or not name.strip():
            raise ShapeSigError(f"mask: expected NAME=WEIGHT entries separated by commas, got {part!r}")
        out[name.strip()] = check_number(_float(value, "mask"), f"mask weight of {name.strip()!r}", 0.0, 1.0)
    if not out:
        raise ShapeSigError("mask: no NAME=WEIGHT entry")
    return out


def _float(text, what):
    try:
        return float(text)
    except ValueError:
        raise ShapeSigError(f"{what}: {text.strip()!r} is not a number") from None


def parse_groups(texts):
    """Custom groups from ``NAME=j1+j2+...`` texts (joints or bone names) -> ``{NAME: (j1, j2, ...)}``."""
    out = {}
    for text in texts or ():
        name, sep, members = str(text).partition("=")
        items = tuple(m.strip() for m in members.split("+") if m.strip())
        if not sep or not name.strip() or not items:
            raise ShapeSigError(f"group: expected NAME=JOINT+JOINT+..., got {text!r}")
        out[name.strip()] = items
    return out


def joint_of_bones(clip):
    """{bone: canonical joint} for every bone of ``clip`` that maps, directly or through its nearest mapped
    ancestor (``meta["parents"]``)."""
    if clip.meta.get("rotation_space") == "comparison":
        return {b: b for b in clip.bones if b in JOINTS}
    from ..rigs import resolve_map

    mapping = resolve_map("auto", clip) or {}
    parents = clip.meta.get("parents") or {}
    out = {}
    for b in clip.bones:
        p, seen = b, set()
        while p is not None and p not in mapping and p not in seen:
            seen.add(p)
            p = parents.get(p)
        if p is not None and p in mapping:
            out[b] = mapping[p]
    return out


def bone_weights(clip, bones, mask, weight, groups=None):
    """(weights of ``bones`` (array, in that order), the hips' weight): the mask applied to ``clip``'s bones (see
    the module docstring); unnamed bones get ``weight``. ShapeSigError (one line) for a name that is no group,
    joint or bone of the clip."""
    if isinstance(mask, str):
        mask = parse_mask(mask)
    groups = dict(GROUPS, **(groups or {}))
    joint = joint_of_bones(clip)
    w = {b: float(weight) for b in clip.bones}
    for name, value in mask.items():
        value = check_number(value, f"mask weight of {name!r}", 0.0, 1.0)
        members = set(groups.get(name, (name,)))
        hit = [b for b in clip.bones if b in members or joint.get(b) in members]
        if not hit:
            if name not in groups and name not in JOINTS:
                raise ShapeSigError(f"mask: {name!r} is no group ({', '.join(sorted(groups))}), canonical joint or "
                                    f"bone of clip {clip.name!r}")
            raise ShapeSigError(f"mask: {name!r} names no bone of clip {clip.name!r} (its bones map to no such "
                                f"joint; give a bone map)")
        for b in hit:
            w[b] = value
    hips = [b for b in clip.bones if joint.get(b) == "hips" and b == clip.root_bone] or \
        [b for b in clip.bones if joint.get(b) == "hips"] or ([clip.root_bone] if clip.root_bone in w else [])
    hips_w = w[hips[0]] if hips else float(weight)
    return np.array([w[b] for b in bones], dtype=np.float64), hips_w
