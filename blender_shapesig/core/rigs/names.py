"""Bone names: the canonical joint set (``JOINTS``, ``BODY``, ``LIMBS``, ``SIDES``, ``CANONICAL_PARENTS``), the
built-in bone-name tables (``FAMILIES``, the priors of detection) and the words of bone names (``tokens``: prefixes,
sides, camelCase; ``word_role``: the limb words of common conventions). ``core.rigs`` re-exports the public names;
``core.rigs.detect`` confirms names with the hierarchy and the rest pose. See docs/rigs.md.
"""

import re
from typing import Dict, Iterable, List, Optional, Tuple

BODY = ("hips", "spine", "spine_mid", "chest", "neck", "head")
LIMBS = ("clavicle", "upper_arm", "forearm", "hand", "thigh", "shin", "foot", "toe")
SIDES = ("L", "R")
JOINTS = BODY + tuple(f"{j}.{s}" for s in SIDES for j in LIMBS)
# the canonical parent of each joint (skeleton drawing, documentation)
CANONICAL_PARENTS = {
    "hips": None, "spine": "hips", "spine_mid": "spine", "chest": "spine_mid", "neck": "chest", "head": "neck",
    **{f"clavicle.{s}": "chest" for s in SIDES}, **{f"upper_arm.{s}": f"clavicle.{s}" for s in SIDES},
    **{f"forearm.{s}": f"upper_arm.{s}" for s in SIDES}, **{f"hand.{s}": f"forearm.{s}" for s in SIDES},
    **{f"thigh.{s}": "hips" for s in SIDES}, **{f"shin.{s}": f"thigh.{s}" for s in SIDES},
    **{f"foot.{s}": f"shin.{s}" for s in SIDES}, **{f"toe.{s}": f"foot.{s}" for s in SIDES},
}

# Family tables: joint -> bone name after strip_prefix, compared case-insensitively. "{s}" is the side as the
# family writes it ("sides": the left and right spelling; "alt_sides": a second spelling), "{h}" the lower-case
# side letter. A list tries names in order.
FAMILIES = {
    "cmu_asf": {  # CMU ASF/AMC and BVH conversions that keep its names (MotionBuilder 16_15)
        "sides": ("l", "r"),
        "joints": {"hips": "root", "spine": "lowerback", "spine_mid": "upperback", "chest": "thorax",
                   "neck": "lowerneck", "head": "head", "clavicle": "{s}clavicle", "upper_arm": "{s}humerus",
                   "forearm": "{s}radius", "hand": "{s}hand", "thigh": "{s}femur", "shin": "{s}tibia",
                   "foot": "{s}foot", "toe": "{s}toes"}},
    "daz": {  # cgspeed "Daz-friendly" CMU BVH (hip, abdomen, chest, rCollar, rShldr, ...)
        "sides": ("l", "r"),
        "joints": {"hips": "hip", "spine": "abdomen", "chest": "chest", "neck": "neck", "head": "head",
                   "clavicle": "{s}Collar", "upper_arm": "{s}Shldr", "forearm": "{s}ForeArm", "hand": "{s}Hand",
                   "thigh": "{s}Thigh", "shin": "{s}Shin", "foot": "{s}Foot", "toe": "{s}Toe"}},
    "cmu_max": {  # cgspeed "3ds Max-friendly" CMU BVH (Hips, LHipJoint, LeftHip, LeftKnee, ..., Chest, Chest2)
        "sides": ("Left", "Right"),
        "joints": {"hips": "Hips", "spine": "lowerback", "spine_mid": "Chest", "chest": "Chest2",
                   "neck": "lowerneck", "head": "Head", "clavicle": "{s}Collar", "upper_arm": "{s}Shoulder",
                   "forearm": "{s}Elbow", "hand": ["{h}hand"], "thigh": "{s}Hip", "shin": "{s}Knee",
                   "foot": "{s}Ankle", "toe": "{s}Toe"}},
    "humanik": {  # MotionBuilder / HumanIK and Mixamo (after the mixamorig: prefix)
        "sides": ("Left", "Right"),
        "joints": {"hips": "Hips", "spine": "Spine", "spine_mid": "Spine1", "chest": ["Spine2", "Spine1"],
                   "neck": "Neck", "head": "Head", "clavicle": "{s}Shoulder", "upper_arm": "{s}Arm",
                   "forearm": "{s}ForeArm", "hand": "{s}Hand", "thigh": "{s}UpLeg", "shin": "{s}Leg",
                   "foot": "{s}Foot", "toe": "{s}ToeBase"}},
    "cc": {  # iClone / Character Creator (after the CC_Base_ prefix)
        "sides": ("L_", "R_"),
        "joints": {"hips": "Hip", "spine": "Waist", "spine_mid": "Spine01", "chest": "Spine02",
                   "neck": "NeckTwist01", "head": "Head", "clavicle": "{s}Clavicle", "upper_arm": "{s}Upperarm",
                   "forearm": "{s}Forearm", "hand": "{s}Hand", "thigh": "{s}Thigh", "shin": "{s}Calf",
                   "foot": "{s}Foot", "toe": "{s}ToeBase"}},
    "rigify": {  # Rigify deform / metarig bones (after DEF- / ORG-)
        "sides": (".L", ".R"),
        "joints": {"hips": "spine", "spine": "spine.001", "spine_mid": "spine.002", "chest": "spine.003",
                   "neck": "spine.004", "head": "spine.006", "clavicle": "shoulder{s}", "upper_arm": "upper_arm{s}",
                   "forearm": "forearm{s}", "hand": "hand{s}", "thigh": "thigh{s}", "shin": "shin{s}",
                   "foot": "foot{s}", "toe": "toe{s}"}},
    "smpl": {  # SMPL / SMPL-H / AMASS joint names (left_hip, ... or L_Hip, ...)
        "sides": ("left_", "right_"), "alt_sides": ("L_", "R_"),
        "joints": {"hips": "pelvis", "spine": "spine1", "spine_mid": "spine2", "chest": "spine3", "neck": "neck",
                   "head": "head", "clavicle": "{s}collar", "upper_arm": "{s}shoulder", "forearm": "{s}elbow",
                   "hand": "{s}wrist", "thigh": "{s}hip", "shin": "{s}knee", "foot": "{s}ankle", "toe": "{s}foot"}},
}

_PREFIX_RE = re.compile(r"^(?:.*[:|]|mixamorig\d*_|CC_Base_|(?:DEF|ORG)-|Bip0?1[ _])", re.IGNORECASE)


def strip_prefix(name: str) -> str:
    """The bone name without rig prefixes: namespaces (``mixamorig:``, ``mixamorig1:``, ``Armature|``),
    ``mixamorig_``, ``CC_Base_``, ``DEF-`` / ``ORG-``, ``Bip01 ``."""
    return _PREFIX_RE.sub("", name, count=1)


def _family_names(family: dict) -> Dict[str, List[str]]:
    """joint -> candidate bone names (lower case, after strip_prefix) of a family table."""
    out = {}
    for joint, names in family["joints"].items():
        names = names if isinstance(names, list) else [names]
        if joint in BODY:
            out[joint] = [n.lower() for n in names]
            continue
        for side, word in zip(SIDES, family["sides"]):
            spellings = [word] + ([family["alt_sides"][SIDES.index(side)]] if "alt_sides" in family else [])
            out[f"{joint}.{side}"] = [n.replace("{s}", w).replace("{h}", side[0].lower()).lower()
                                      for n in names for w in spellings]
    return out


_TABLES = {name: _family_names(f) for name, f in FAMILIES.items()}


def _match(bones: Iterable[str], table: Dict[str, List[str]]) -> Dict[str, str]:
    """{bone: joint} by one family table; each joint takes the first candidate name present."""
    lookup = {}
    for b in bones:
        lookup.setdefault(strip_prefix(b).lower(), b)
    out = {}
    for joint, names in table.items():
        for n in names:
            b = lookup.get(n)
            if b is not None and b not in out:
                out[b] = joint
                break
    return out




def detect_family(bones: Iterable[str]) -> Tuple[Optional[str], Dict[str, str]]:
    """(family name, {bone: joint}) of the table that maps most bones; (None, {}) when the best maps fewer than
    three bones, unless it maps every bone (a clip of one or two bones, e.g. only ``root``)."""
    bones = list(bones)
    best, best_map = None, {}
    for name, table in _TABLES.items():
        m = _match(bones, table)
        if len(m) > len(best_map):
            best, best_map = name, m
    if len(best_map) < min(3, len(bones)):
        return None, {}
    return best, best_map


# ------------------------------------------------------------------------------------------- name words

# Rig prefixes before the words of a name: namespaces (``mixamorig:``, ``Armature|``), ``mixamorig7`` glued or with
# ``_``, ``CC_Base_``, ``DEF-``/``ORG-``/``MCH-`` (or ``_``), ``Bip01 ``, ``joint_``, ``Character1_``, ``J_Bip_``,
# ``Skeleton_``, the fox's ``b_``, Truebones' ``BN_``.
_WORD_PREFIX_RE = re.compile(
    r"^(?:.*[:|]|mixamorig\d*_?|CC_Base_|(?:DEF|ORG|MCH)[-_]|Bip0?\d[ _]|joint_|Character\d*_|J_Bip_|Skeleton_"
    r"|b_|BN_)+", re.IGNORECASE)
_CAMEL_RE = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")
# compound words (tokens joined) and single words -> (kind, role): kind "arm", "leg", "body" or "skip"
# (helpers, fingers, face, cloth: never a canonical joint) or "twist" (a joint's twist/roll/share bone);
# role a canonical joint name, or "" when the word names only the limb (``shoulder``, ``arm``, ``leg``, ``hip``).
_WORDS = {
    **dict.fromkeys(("clavicle", "clav", "collar", "collarbone"), ("arm", "clavicle")),
    **dict.fromkeys(("upperarm", "uparm", "humerus", "bicep", "shldr"), ("arm", "upper_arm")),
    **dict.fromkeys(("forearm", "lowerarm", "loarm", "elbow", "radius", "ulna"), ("arm", "forearm")),
    **dict.fromkeys(("hand", "wrist", "palm"), ("arm", "hand")),
    **dict.fromkeys(("shoulder", "arm"), ("arm", "")),
    **dict.fromkeys(("thigh", "upleg", "upperleg", "femur"), ("leg", "thigh")),
    **dict.fromkeys(("shin", "calf", "knee", "tibia", "lowerleg", "loleg"), ("leg", "shin")),
    **dict.fromkeys(("foot", "ankle"), ("leg", "foot")),
    **dict.fromkeys(("toe", "toes", "ball", "toebase"), ("leg", "toe")),
    **dict.fromkeys(("leg", "hip"), ("leg", "")),
    **dict.fromkeys(("pelvis", "hips"), ("body", "hips")),
    **dict.fromkeys(("spine", "abdomen", "ab", "abs", "waist", "lowerback", "belly"), ("body", "spine")),
    **dict.fromkeys(("chest", "thorax", "upperback", "torso", "ribcage"), ("body", "chest")),
    **dict.fromkeys(("neck", "lowerneck", "upperneck"), ("body", "neck")),
    **dict.fromkeys(("head", "skull"), ("body", "head")),
    **dict.fromkeys(("twist", "roll", "share", "bend"), ("twist", "")),
    **dict.fromkeys(("ik", "fk", "pole", "target", "tgt", "ctrl", "control", "mch", "helper", "corrective", "end",
                     "nub", "site", "eye", "eyes", "jaw", "tongue", "teeth", "hair", "tail",
                     "ear", "nose", "brow", "eyebrow", "lip", "cheek", "thumb", "index", "middle", "ring", "pinky",
                     "pinkie", "little", "finger", "fingers", "fingerbase", "digit", "metacarpal", "proximal",
                     "intermediate", "distal", "carpal", "prop", "weapon", "skirt", "cloth", "breast", "bust",
                     "sode", "mune", "suso", "ribbon", "trunk", "wing"), ("skip", "")),
}
_JOINED = {("upper", "arm"): "upperarm", ("lower", "arm"): "lowerarm", ("fore", "arm"): "forearm",
           ("up", "arm"): "uparm", ("upper", "leg"): "upperleg", ("lower", "leg"): "lowerleg", ("up", "leg"): "upleg",
           ("lower", "back"): "lowerback", ("upper", "back"): "upperback", ("toe", "base"): "toebase",
           ("lower", "neck"): "lowerneck", ("upper", "neck"): "upperneck", ("collar", "bone"): "collarbone"}
_SIDE_WORDS = {"l": "L", "left": "L", "r": "R", "right": "R"}


def tokens(name: str) -> Tuple[Optional[str], Tuple[str, ...]]:
    """(side "L"/"R"/None, lower-case words) of a bone name: rig prefixes dropped, split at separators, camelCase
    and digits (numbers dropped), side words taken out (``_L .L L_ Left l_ _l .l left_``, glued ``lThigh``,
    ``lhumerus``), two-word compounds joined (``upper arm`` -> ``upperarm``)."""
    rest = _WORD_PREFIX_RE.sub("", name) or name
    raw = [w for part in re.split(r"[\s._\-:|]+", rest) for w in _CAMEL_RE.findall(part)]
    words, side = [], None
    for w in raw:
        low = w.lower()
        if low.isdigit():
            continue
        if low in _SIDE_WORDS:
            side = side or _SIDE_WORDS[low]
            continue
        if low[0] in "lr" and len(low) > 2 and low[1:] in _WORDS and low not in _WORDS:
            side = side or _SIDE_WORDS[low[0]]
            low = low[1:]
        words.append(low)
    joined, i = [], 0
    while i < len(words):
        pair = tuple(words[i:i + 2])
        if pair in _JOINED:
            joined.append(_JOINED[pair])
            i += 2
        else:
            joined.append(words[i])
            i += 1
    return side, tuple(joined)


def word_role(words) -> Tuple[Optional[str], str]:
    """(kind, role) of a name's words (``_WORDS``): a helper or finger word anywhere makes it "skip"; else the
    last word that names a joint (``role``) or only a limb decides; (None, "") when no word is known."""
    kinds = [_WORDS[w] for w in words if w in _WORDS]
    for kind in ("skip", "twist"):
        if any(k == kind for k, _ in kinds):
            return kind, ""
    named = [kr for kr in kinds if kr[1]]
    if named:
        return named[-1]
    return kinds[-1] if kinds else (None, "")
