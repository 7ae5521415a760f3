"""Humanoid skeletons written as BVH text by the tests (Y up, facing +Z, the character's left at +X): a canonical
layout whose joints a test renames (or leaves out), with a moving pose per frame, so that bone-map detection and
coverage are checked on rigs of any naming without shipping files."""

import numpy as np

# canonical joint -> (parent joint, offset from the parent's head); ".S" is the side (+X for L)
LAYOUT = [
    ("hips", None, (0.0, 95.0, 0.0)), ("spine", "hips", (0.0, 10.0, 0.0)), ("spine_mid", "spine", (0.0, 12.0, 0.0)),
    ("chest", "spine_mid", (0.0, 12.0, 0.0)), ("neck", "chest", (0.0, 15.0, 0.0)), ("head", "neck", (0.0, 10.0, 0.0)),
    ("clavicle.S", "chest", (3.0, 10.0, 0.0)), ("upper_arm.S", "clavicle.S", (12.0, 0.0, 0.0)),
    ("forearm.S", "upper_arm.S", (28.0, 0.0, 0.0)), ("hand.S", "forearm.S", (25.0, 0.0, 0.0)),
    ("thigh.S", "hips", (9.0, -5.0, 0.0)), ("shin.S", "thigh.S", (0.0, -42.0, 0.0)),
    ("foot.S", "shin.S", (0.0, -40.0, 0.0)), ("toe.S", "foot.S", (0.0, -8.0, 12.0)),
]
END = {"head": (0.0, 15.0, 0.0), "hand": (8.0, 0.0, 0.0), "toe": (0.0, 0.0, 5.0), "foot": (0.0, -8.0, 12.0),
       "forearm": (25.0, 0.0, 0.0)}


def _joints():
    out = []
    for joint, parent, off in LAYOUT:
        if ".S" not in joint:
            out.append((joint, parent, np.array(off)))
            continue
        for s, sign in (("L", 1.0), ("R", -1.0)):
            p = parent.replace(".S", "." + s) if parent and ".S" in parent else parent
            out.append((joint.replace(".S", "." + s), p, np.array(off) * [sign, 1.0, 1.0]))
    return out


def bvh_text(names, root=None, frames=40, extras=()):
    """BVH text of a humanoid whose canonical joints are called ``names[joint]`` (joints not in ``names`` are
    left out: their children hang from the nearest kept ancestor, offsets summed); ``root``: a bone above the
    hips at the origin; ``extras``: (name, parent name, offset) bones added (twist or helper bones). Every
    joint turns by a sinusoid of its own phase."""
    kept, offsets, parents = [], {}, {}
    for joint, parent, off in _joints():
        total = off.copy()
        while parent is not None and parent not in names:
            total += next(o for j, _p, o in _joints() if j == parent)
            parent = next(p for j, p, _o in _joints() if j == parent)
        if joint in names:
            kept.append(names[joint])
            offsets[names[joint]] = total
            parents[names[joint]] = names[parent] if parent else root
        # a left-out joint passes its offset to its children (handled by the loop above)
    for name, parent, off in extras:
        kept.append(name)
        offsets[name] = np.asarray(off, dtype=float)
        parents[name] = parent
    ends = {names[j]: END[j.split(".")[0]] for j in names if j.split(".")[0] in END}
    order, lines = [], []

    def write(bone, depth):
        pad = "  " * depth
        order.append(bone)
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {bone}")
        lines.append(pad + "{")
        off = offsets.get(bone, np.zeros(3))
        lines.append(f"{pad}  OFFSET {off[0]:.4f} {off[1]:.4f} {off[2]:.4f}")
        pos = "Xposition Yposition Zposition " if depth == 0 else ""
        lines.append(f"{pad}  CHANNELS {6 if depth == 0 else 3} {pos}Zrotation Xrotation Yrotation")
        kids = [b for b in kept if parents.get(b) == bone]
        for k in kids:
            write(k, depth + 1)
        if not kids:
            e = ends.get(bone, (0.0, 5.0, 0.0))
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET {e[0]} {e[1]} {e[2]}", pad + "  }"])
        lines.append(pad + "}")

    top = root if root is not None else names["hips"]
    if root is not None:
        offsets[root] = np.zeros(3)
    write(top, 0)
    t = np.arange(frames) / 30.0
    rows = []
    for f in range(frames):
        vals = []
        for k, b in enumerate(order):
            if k == 0:
                vals += [0.0, 0.0 if root is not None else 95.0, 30.0 * t[f]]
            a = 20.0 * np.sin(2 * np.pi * t[f] + 0.7 * k)
            vals += [a, 0.5 * a, 0.25 * a]
        rows.append(" ".join(f"{v:.4f}" for v in vals))
    return "HIERARCHY\n" + "\n".join(lines) + f"\nMOTION\nFrames: {frames}\nFrame Time: 0.0333333\n" + "\n".join(rows) + "\n"


def write_bvh(path, names, **kw):
    path.write_text(bvh_text(names, **kw))
    return path


def side_names(body, limbs):
    """``names`` for ``bvh_text``: ``body`` {joint: name}, ``limbs`` {joint base: pattern with {s}} and the
    sides' spellings as the pattern's ``{s}`` ("L"/"R" replaced by the caller's choice)."""
    out = dict(body)
    for base, (pattern, sides) in limbs.items():
        for s, word in zip(("L", "R"), sides):
            out[f"{base}.{s}"] = pattern.format(s=word)
    return out


# three exporters' names for the layout's joints (Unity's humanoid, Biovision's BVH, Blender's .L/.R-style)
UNITY = side_names({"hips": "Hips", "spine": "Spine", "chest": "Chest", "neck": "Neck", "head": "Head"},
                   {"clavicle": ("Shoulder_{s}", "LR"), "upper_arm": ("UpperArm_{s}", "LR"),
                    "forearm": ("LowerArm_{s}", "LR"), "hand": ("Hand_{s}", "LR"), "thigh": ("UpperLeg_{s}", "LR"),
                    "shin": ("LowerLeg_{s}", "LR"), "foot": ("Foot_{s}", "LR"), "toe": ("Toes_{s}", "LR")})
BIOVISION = side_names({"hips": "Hips", "spine": "Ab", "chest": "Chest", "neck": "Neck", "head": "Head"},
                       {"clavicle": ("{s}Collar", ("Left", "Right")), "upper_arm": ("{s}Shoulder", ("Left", "Right")),
                        "forearm": ("{s}Elbow", ("Left", "Right")), "hand": ("{s}Wrist", ("Left", "Right")),
                        "thigh": ("{s}Hip", ("Left", "Right")), "shin": ("{s}Knee", ("Left", "Right")),
                        "foot": ("{s}Ankle", ("Left", "Right"))})
BLENDER_LR = side_names({"hips": "Hips", "spine": "Abdomen", "chest": "Torso", "neck": "Neck", "head": "Head"},
                        {"upper_arm": ("UpperArm.{s}", "LR"), "forearm": ("LowerArm.{s}", "LR"),
                         "hand": ("Hand.{s}", "LR"), "thigh": ("UpperLeg.{s}", "LR"), "shin": ("LowerLeg.{s}", "LR"),
                         "foot": ("Foot.{s}", "LR"), "toe": ("Toe.{s}", "LR")})
