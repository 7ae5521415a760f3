"""Automatic bone maps by names and topology (``analyse_rig`` -> ``RigReport``; ``detect_map``). The words of the
names (``names.tokens``) say which bones belong to legs, arms and the body and on which side; the hierarchy
confirms it (two leg chains meeting at the hips, a spine up to the bone the two arms branch from, the neck and
head above it) and places the joints along each chain; the rest pose decides where names cannot (the upper arm
and forearm are the two longest consecutive segments of an arm, the thigh and shin of a leg), tells left from
right relative to the facing (the feet point forward) and refuses rigs whose spine is not above their legs.
The built-in tables (``names.FAMILIES``) stay as priors. See docs/rigs.md, "Automatic maps".
"""

from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .names import BODY, JOINTS, SIDES, detect_family, tokens, word_role

__all__ = ["RigReport", "analyse_rig", "detect_map", "LIMB_CHAINS", "SMALL_RIG"]

# the limb chains coverage counts (an arm: upper arm and forearm; a leg: thigh and shin)
LIMB_CHAINS = {f"{limb}.{s}": tuple(f"{j}.{s}" for j in joints) for s in SIDES
               for limb, joints in (("arm", ("upper_arm", "forearm")), ("leg", ("thigh", "shin")))}
# rigs with fewer bones are partial clips: when the topology finds no body they keep the name tables' map
SMALL_RIG = 8
_ARM = ("clavicle", "upper_arm", "forearm", "hand")
_LEG = ("thigh", "shin", "foot", "toe")
# a humanoid rest has its spine at about 180 degrees from its legs, a four-legged one at about 90: between
# 180 minus this and this the rig is refused
_SPINE_LEG_DEGREES = 135.0


@dataclass
class RigReport:
    """What detection found: ``mapping`` {bone: joint}; ``joints``: the canonical joints the rig has (its
    structure holds them, mapped or not; every joint when only names were read); ``refusal``: one line when
    the rig is not a humanoid (``mapping`` is then empty); ``family``: the table that served as prior;
    ``sides``: "rest" (from the rest pose), "names" or "" ."""

    mapping: Dict[str, str] = field(default_factory=dict)
    joints: Tuple[str, ...] = JOINTS
    refusal: str = ""
    family: Optional[str] = None
    sides: str = ""

    @property
    def unmapped(self) -> List[str]:
        """The joints the rig has that no bone is mapped to."""
        got = set(self.mapping.values())
        return [j for j in self.joints if j not in got]


class _NotHumanoid(Exception):
    pass


def _role(side, words):
    """``word_role``, where a "hip" without a side is the hips (with one it is a thigh)."""
    kind, role = word_role(words)
    if kind == "leg" and not role and side is None and "hip" in words:
        return "body", "hips"
    return kind, role


def _names_only(bones, prior) -> Dict[str, str]:
    """The tables' map filled with bones whose words name a joint and a side (no hierarchy to confirm)."""
    out = dict(prior)
    taken = set(out.values())
    for b in bones:
        if b in out:
            continue
        side, words = tokens(b)
        kind, role = _role(side, words)
        if not role or kind in ("skip", "twist"):
            continue
        joint = role if kind == "body" else (f"{role}.{side}" if side else None)
        if joint and joint not in taken:
            out[b] = joint
            taken.add(joint)
    return out


class _Tree:
    def __init__(self, bones, parents):
        self.bones = list(bones)
        held = set(self.bones)
        self.parent = {}
        for b in self.bones:  # the nearest ancestor the clip holds (a rig's unanimated bones are skipped)
            p, seen = parents.get(b), {b}
            while p is not None and p not in held and p not in seen:
                seen.add(p)
                p = parents.get(p)
            self.parent[b] = p if p in held else None
        self.children = {b: [] for b in self.bones}
        for b, p in self.parent.items():
            if p in self.children:
                self.children[p].append(b)

    def ancestors(self, b) -> List[str]:
        """b, its parent, ... up to its root."""
        out, seen = [], set()
        while b is not None and b not in seen:
            seen.add(b)
            out.append(b)
            b = self.parent.get(b)
        return out

    def lca(self, a, b):
        up = set(self.ancestors(a))
        return next((x for x in self.ancestors(b) if x in up), None)

    def path(self, top, tip) -> List[str]:
        """Bones from below ``top`` (exclusive) down to ``tip`` (inclusive)."""
        chain = self.ancestors(tip)
        return list(reversed(chain[:chain.index(top)])) if top in chain else list(reversed(chain))


def _classify(tree, prior):
    """{bone: (kind, role, side)}; a helper's whole subtree is skipped (IK and pole bones, fingers, face)."""
    out = {}
    for b in tree.bones:
        side, words = tokens(b)
        kind, role = _role(side, words)
        joint = prior.get(b)
        if joint is not None:
            base, _, s = joint.partition(".")
            kind = "body" if joint in BODY else ("arm" if base in _ARM else "leg")
            role, side = base, (s or None)
        out[b] = (kind, role, side)
    for b in tree.bones:
        if any(out[a][0] == "skip" for a in tree.ancestors(b)[1:]) and out[b][0] != "skip":
            out[b] = ("skip", "", out[b][2])
    return out


def _limb_groups(tree, info, kind):
    """The limbs of one kind in the body's tree (the one holding most named bones): groups of tips (bones of that
    kind without one below them) joined when their common ancestor is of that kind too (a heel and a toe)."""
    roots = [tree.ancestors(b)[-1] for b, (k, _r, _s) in info.items() if k in ("arm", "leg", "body")]
    main = max(set(roots), key=roots.count) if roots else None  # bones outside the body's tree are helpers
    members = {b for b, (k, _r, _s) in info.items() if k == kind and tree.ancestors(b)[-1] == main}
    below = set()
    for b in members:
        below.update(a for a in tree.ancestors(b)[1:] if a in members)
    groups = []
    for tip in (b for b in tree.bones if b in members and b not in below):
        for g in groups:
            if tree.lca(g[0], tip) in members:
                g.append(tip)
                break
        else:
            groups.append([tip])
    return groups


def _head(heads, b):
    return None if heads is None or b not in heads else np.asarray(heads[b], dtype=np.float64)


def _segments(chain, heads, tails) -> Optional[List[float]]:
    """Each chain bone's length to the next one's head (the last: to its tail, else 0); None without heads."""
    pts = [_head(heads, b) for b in chain]
    if any(p is None for p in pts):
        return None
    out = [float(np.linalg.norm(pts[i + 1] - pts[i])) for i in range(len(pts) - 1)]
    tail = None if tails is None or chain[-1] not in tails else np.asarray(tails[chain[-1]], dtype=np.float64)
    out.append(0.0 if tail is None else float(np.linalg.norm(tail - pts[-1])))
    return out


def _place_limb(chain, roles, info, prior, heads, tails):
    """{bone: role} along one limb chain (top to tip): the tables' joints when two or more lie on it in order;
    else the rest pose (the main pair, upper arm/forearm or thigh/shin, is the longest two consecutive
    segments); else the words that name a joint; else positions (an arm of four bones starts at the clavicle)."""
    main = 1 if roles is _ARM else 0  # index in roles of the main pair's first joint
    anchors = [(i, roles.index(prior[b].partition(".")[0])) for i, b in enumerate(chain)
               if b in prior and prior[b].partition(".")[0] in roles]
    if len(anchors) >= 2 and all(a[0] < b[0] and a[1] < b[1] for a, b in zip(anchors, anchors[1:])):
        out = {chain[i]: roles[r] for i, r in anchors}
        for j in range(len(chain)):  # the bones the tables did not name: by their distance to the nearest one
            if chain[j] in out:
                continue
            i, r = min(anchors, key=lambda a: abs(a[0] - j))
            rr = r + j - i
            if 0 <= rr < len(roles) and roles[rr] not in out.values():
                out[chain[j]] = roles[rr]
        return out
    seg = _segments(chain, heads, tails)
    start = None
    if seg is not None and len(chain) >= 2:
        start = max(range(len(chain) - 1), key=lambda i: (seg[i] + seg[i + 1], -i)) - main
    if start is None:
        votes = [i - roles.index(info[b][1]) for i, b in enumerate(chain) if info[b][1] in roles]
        start = max(set(votes), key=votes.count) if votes else (0 if roles is _ARM and len(chain) >= 4 else -main)
    return {b: roles[i - start] for i, b in enumerate(chain) if 0 <= i - start < len(roles)}


def _structure(tree, info):
    """(hips, spine chain, neck chain, head, {(kind, group index): chain}) of a humanoid; _NotHumanoid otherwise."""
    limbs, tops = {}, {}
    for kind, word in (("leg", "legs"), ("arm", "arms")):
        groups = _limb_groups(tree, info, kind)
        if len(groups) != 2:
            raise _NotHumanoid(f"{len(groups)} {word} found by the bone names (a humanoid has two)")
        tips = [max(g, key=lambda b: len(tree.ancestors(b))) for g in groups]
        top = tree.lca(*tips)
        if top is None:
            raise _NotHumanoid(f"the two {word} are not in one hierarchy")
        tops[kind] = top
        for k, tip in enumerate(tips):
            chain = [b for b in tree.path(top, tip) if info[b][0] != "twist"]
            if not chain:
                raise _NotHumanoid(f"the {word} share their bones")
            limbs[(kind, k)] = chain
    hips = tree.lca(tops["leg"], tops["arm"])
    if hips is None or hips == tops["arm"] or tops["arm"] in tree.ancestors(tops["leg"]):
        raise _NotHumanoid("the arms do not branch above the legs")
    spine = tree.path(hips, tops["arm"])
    arm_bones = {b for (k, _), c in limbs.items() if k == "arm" for b in c}
    heads = [b for b in tree.bones if info[b][1] == "head" and info[b][0] == "body"
             and tops["arm"] in tree.ancestors(b)[1:] and not arm_bones & set(tree.ancestors(b))]
    head = min(heads, key=lambda b: len(tree.ancestors(b))) if heads else None
    if head is None:  # no bone named head: the end of the longest chain above the arms' branch
        rest = [c for c in tree.children[tops["arm"]] if c not in arm_bones and info[c][0] != "skip"]
        chain = []
        while rest:
            chain.append(rest[0])
            rest = [c for c in tree.children[rest[0]] if info[c][0] != "skip"]
        head = chain[-1] if chain else None
    neck = tree.path(tops["arm"], head)[:-1] if head else []
    return hips, spine, neck, head, limbs


def _sides(limbs, roles, info, hips, chest, heads, tails):
    """{(kind, k): "L"/"R"} and where they came from ("rest" or "names"). From the rest pose when the feet
    give the facing (``_facing``): left = up x forward, up from the hips to the chest; else from the names."""
    named = {}
    for key, chain in limbs.items():
        sides = [info[b][2] for b in chain if info[b][2]]
        named[key] = max(set(sides), key=sides.count) if sides else None
    geo = {}
    h, c = _head(heads, hips), _head(heads, chest)
    left = None if h is None or c is None else _facing_left(limbs, roles, heads, tails, c - h)
    if left is not None:
        for kind in ("leg", "arm"):
            x = [float((np.mean([_head(heads, b) for b in limbs[(kind, k)]], axis=0) - h) @ left) for k in (0, 1)]
            if abs(x[0] - x[1]) > 1e-6 * (1 + abs(x[0]) + abs(x[1])):
                geo[(kind, 0)], geo[(kind, 1)] = ("L", "R") if x[0] > x[1] else ("R", "L")
    out, how = {}, []
    for kind in ("leg", "arm"):
        pair = [(kind, 0), (kind, 1)]
        if all(p in geo for p in pair):
            out.update({p: geo[p] for p in pair})
            how.append("rest")
        elif {named[p] for p in pair} == {"L", "R"}:
            out.update({p: named[p] for p in pair})
            how.append("names")
        else:
            raise _NotHumanoid(f"the names and the rest pose do not tell the left {kind} from the right one")
    return out, ("rest" if how == ["rest", "rest"] else "names")


def _facing_left(limbs, roles, heads, tails, up):
    """The rig's left in the rest pose (up x forward), the forward from the feet (foot to toe head, or the foot's
    head to its tail without a toe); None unless both feet point within 60 degrees of the floor (``up``
    removed) and agree: rests whose feet point down or along the body (some BVH zero poses) do not tell it."""
    n = np.linalg.norm(up)
    if n == 0:
        return None
    up = up / n
    fwd = []
    for (kind, k), chain in limbs.items():
        if kind != "leg":
            continue
        by_role = {r: b for b, r in roles[(kind, k)].items()}
        foot, toe = by_role.get("foot"), by_role.get("toe")
        a = _head(heads, foot) if foot else None
        b = _head(heads, toe) if toe else (None if tails is None or foot not in tails else
                                           np.asarray(tails[foot], dtype=np.float64))
        if a is None or b is None or np.linalg.norm(b - a) == 0:
            return None
        v = (b - a) / np.linalg.norm(b - a)
        flat = v - (v @ up) * up
        if np.linalg.norm(flat) < 0.5:
            return None
        fwd.append(flat / np.linalg.norm(flat))
    if len(fwd) != 2 or fwd[0] @ fwd[1] < 0.5:
        return None
    f = fwd[0] + fwd[1]
    return np.cross(up, f / np.linalg.norm(f))


def _check_upright(limbs, hips, chest, heads):
    """_NotHumanoid when the rest pose puts the spine across the legs (45-135 degrees: a four-legged rig), not
    above them; rests with the spine along the legs (some BVH zero poses point every bone one way) pass."""
    h, c = _head(heads, hips), _head(heads, chest)
    feet = [_head(heads, chain[-1]) for (kind, _), chain in limbs.items() if kind == "leg"]
    if h is None or c is None or any(f is None for f in feet):
        return
    spine, legs = c - h, np.mean(feet, axis=0) - h
    ns, nl = np.linalg.norm(spine), np.linalg.norm(legs)
    if ns == 0 or nl == 0:
        return
    angle = np.degrees(np.arccos(np.clip(spine @ legs / (ns * nl), -1.0, 1.0)))
    if 180.0 - _SPINE_LEG_DEGREES < angle < _SPINE_LEG_DEGREES:
        raise _NotHumanoid(f"its spine leaves the hips {angle:.0f} degrees from its legs, not above them "
                           f"(a four-legged rig?)")


# a hand or foot hanging elsewhere (an IK bone parented to the root) belongs to the limb whose last bone's rest tail
# is within this fraction of that bone's length of its rest head
_AT_TAIL = 0.1


def _reattached(bones, parents, heads, tails, prior) -> Mapping[str, Optional[str]]:
    """``parents`` with each hand, foot or toe (by its words or the tables) whose parent is not a bone of its limb
    hung under the limb bone whose rest tail sits at its rest head (``_AT_TAIL``; same side when both say one):
    IK-foot rigs (a glTF robot's ``FootL`` parented to the root) keep the foot in the leg. Bones without a rest
    skeleton, or with no such bone, keep their parent; ``parents`` itself is not changed."""
    if heads is None or tails is None:
        return parents
    held = [b for b in bones if b in heads and b in tails]
    kinds = {}
    for b in held:
        side, words = tokens(b)
        kind, role = _role(side, words)
        joint = prior.get(b)
        if joint is not None:
            base, _, s = joint.partition(".")
            kind, role, side = ("body" if joint in BODY else ("arm" if base in _ARM else "leg")), base, (s or None)
        kinds[b] = (kind, role, side)
    out = None
    for b in held:
        kind, role, side = kinds[b]
        if role not in ("hand", "foot", "toe") or kinds.get(parents.get(b), (None,))[0] == kind:
            continue
        head = np.asarray(heads[b], dtype=np.float64)
        best, gap = None, np.inf
        for c in held:
            k, _r, s = kinds[c]
            if c == b or k != kind or (side and s and s != side):
                continue
            tail, top = np.asarray(tails[c], dtype=np.float64), np.asarray(heads[c], dtype=np.float64)
            d = float(np.linalg.norm(tail - head))
            if d <= _AT_TAIL * float(np.linalg.norm(tail - top)) and d < gap and b not in _lineage(c, parents):
                best, gap = c, d
        if best is not None:
            out = dict(parents) if out is None else out
            out[b] = best
    return parents if out is None else out


def _lineage(b, parents):
    out, seen = [], set()
    while b is not None and b not in seen:
        seen.add(b)
        out.append(b)
        b = parents.get(b)
    return out


def analyse_rig(bones: Sequence[str], parents: Optional[Mapping[str, Optional[str]]] = None,
                heads: Optional[Mapping] = None, tails: Optional[Mapping] = None) -> RigReport:
    """The automatic map of a rig and what it has (``RigReport``): names, confirmed by the hierarchy
    (``parents``) and the rest pose (``heads``/``tails``: bone -> position, armature axes) when given."""
    bones = list(bones)
    family, prior = detect_family(bones)
    if not parents or not any(parents.get(b) for b in bones):
        m = _names_only(bones, prior)
        return RigReport(mapping={b: m[b] for b in bones if b in m} if len(m) >= min(3, len(bones)) else {},
                         family=family, sides="names")
    tree = _Tree(bones, _reattached(bones, parents, heads, tails, prior))
    info = _classify(tree, prior)
    if not any(k in ("arm", "leg") for k, _r, _s in info.values()):  # nothing to map (not a refusal)
        m = _names_only(bones, prior)
        return RigReport(mapping={b: m[b] for b in bones if b in m} if len(m) >= min(3, len(bones)) else {},
                         family=family, sides="names")
    try:
        hips, spine, neck, head, limbs = _structure(tree, info)
        chest = spine[-1]
        _check_upright(limbs, hips, chest, heads)
        roles = {key: _place_limb(chain, _ARM if key[0] == "arm" else _LEG, info, prior, heads, tails)
                 for key, chain in limbs.items()}
        sides, how = _sides(limbs, roles, info, hips, chest, heads, tails)
    except _NotHumanoid as exc:
        if len(bones) < SMALL_RIG:  # a partial clip (a few bones): the names alone
            m = _names_only(bones, prior)
            return RigReport(mapping={b: m[b] for b in bones if b in m} if len(m) >= min(3, len(bones)) else {},
                             family=family, sides="names")
        return RigReport(mapping={}, joints=(), refusal=f"not a humanoid rig: {exc}", family=family)
    out = {hips: "hips"}
    if len(spine) == 1:
        out[spine[0]] = "chest"
    elif spine:
        out.update({spine[0]: "spine", spine[-1]: "chest"})
        if len(spine) >= 3:
            out[spine[len(spine) // 2]] = "spine_mid"
    if neck:
        out[neck[0]] = "neck"
    if head is not None:
        out[head] = "head"
    for key, placed in roles.items():
        for b, role in placed.items():
            if b not in out:
                out[b] = f"{role}.{sides[key]}"
    joints = tuple(j for j in JOINTS if j in set(out.values()))
    return RigReport(mapping={b: out[b] for b in bones if b in out}, joints=joints, family=family, sides=how)


def detect_map(bones: Sequence[str], parents: Optional[Mapping[str, Optional[str]]] = None,
               heads: Optional[Mapping] = None, tails: Optional[Mapping] = None) -> Dict[str, str]:
    """The automatic bone map ``{bone: joint}`` (``analyse_rig``); empty when nothing maps or the rig is not a
    humanoid."""
    return analyse_rig(bones, parents, heads, tails).mapping
