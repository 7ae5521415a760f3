"""Rigs: the canonical joint set (``JOINTS``), built-in bone-name tables (``FAMILIES``) and bone-map detection
(``detect_map``), saved maps (``load_map`` / ``save_map``), and the comparison space across rigs
(``to_comparison_space``: each mapped bone's world rotation relative to rest, the heading removed, bones named by
their joints) with the way back onto a rig (``onto_rig``) and coverage checks. See docs/rigs.md and
docs/model.md, "Comparison space across rigs".
"""

import json
import os
from dataclasses import replace
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .clip import skeleton
from .geometry import so3
from .clip.clip import Clip
from .errors import ParseError, ShapeSigError
from .rig_chains import chains_between, share_chains
from .rig_detect import LIMB_CHAINS, RigReport, analyse_rig, detect_map
from .rig_names import BODY, CANONICAL_PARENTS, FAMILIES, JOINTS, LIMBS, SIDES, detect_family, strip_prefix

__all__ = [
    "JOINTS", "BODY", "LIMBS", "SIDES", "FAMILIES", "BONE_MAP_MODES", "strip_prefix", "detect_map", "detect_family",
    "analyse_rig", "analyse_clip", "RigReport", "LIMB_CHAINS", "chains_covered", "joint_coverage", "coverage_report",
    "coverage_from", "below_minimum",
    "check_map", "parse_map", "load_map", "save_map", "map_json", "MAX_MAP_BYTES", "resolve_map", "world_rotations", "heading",
    "clip_heading", "rest_forward",
    "to_comparison_space", "rest_retarget", "rests_differ", "other_rigs", "REST_DEGREES", "apply_bone_map", "check_comparable", "coverage", "moving_count", "onto_rig",
    "MIN_COVERAGE", "TABLES_VERSION", "TRAVEL_RATIO", "CANONICAL_PARENTS",
]

BONE_MAP_MODES = ("auto", "none")
# bump when the tables or the comparison space change (it is part of every clip's cache key)
TABLES_VERSION = 4
# below this coverage (joints compared / canonical joints both rigs have; limb chains compared / limb chains both
# rigs have) comparisons and blends refuse
MIN_COVERAGE = 0.5
# A saved bone map is a small JSON object (a few KB for any rig); larger files are refused unread.
MAX_MAP_BYTES = 1 << 20


def check_map(mapping: Mapping[str, str], where: str = "bone map") -> Dict[str, str]:
    """A validated copy of a ``{bone: joint}`` map: joints must be canonical and used once."""
    if not isinstance(mapping, Mapping):
        raise ParseError("a bone map must be a JSON object {\"bone\": \"joint\", ...}", where)
    out, used = {}, {}
    for bone, joint in mapping.items():
        if not isinstance(bone, str) or not isinstance(joint, str):
            raise ParseError("bone map keys and values must be strings", where)
        if joint not in JOINTS:
            raise ParseError(f"unknown joint {joint!r} for bone {bone!r} (joints: {', '.join(JOINTS)})", where)
        if joint in used:
            raise ParseError(f"joint {joint!r} is given to two bones ({used[joint]!r}, {bone!r})", where)
        used[joint] = bone
        out[bone] = joint
    return out


def map_json(mapping: Mapping[str, str], rig: str = "") -> str:
    """The saved-map JSON text: ``{"bone": "joint", ...}`` (a ``"#rig"`` entry names the rig when given)."""
    body = dict(check_map(mapping))
    if rig:
        body = {"#rig": rig, **body}
    return json.dumps(body, indent=1, sort_keys=False) + "\n"


def save_map(path, mapping: Mapping[str, str], rig: str = "") -> str:
    """Write a saved map (``map_json``) to ``path``; returns the path."""
    path = os.fspath(path)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(map_json(mapping, rig))
    return path


def parse_map(text, where: str = "bone map") -> Dict[str, str]:
    """A saved map's JSON text (str or UTF-8 bytes) as a validated map; keys starting with ``#`` are comments.
    Every defect is one ``ParseError`` naming ``where``: not UTF-8, over ``MAX_MAP_BYTES``, not JSON, nested too
    deeply for the parser, not an object of strings, unknown or repeated joints."""
    if len(text) > MAX_MAP_BYTES:
        raise ParseError(f"the bone map is larger than {MAX_MAP_BYTES // 2 ** 20} MB; a bone map is a small "
                         f"JSON object", where)
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ParseError(f"the bone map is not UTF-8 text (byte {exc.start})", where) from None
    try:
        data = json.loads(text)
    except RecursionError:
        raise ParseError("the bone map is nested too deeply to be a bone map", where) from None
    except json.JSONDecodeError as exc:
        raise ParseError(f"the bone map is not valid JSON ({exc.msg}, line {exc.lineno})", where) from None
    except ValueError as exc:  # e.g. a number too long to convert
        raise ParseError(f"the bone map is not valid JSON ({str(exc).splitlines()[0][:120]})", where) from None
    if isinstance(data, dict):
        data = {k: v for k, v in data.items() if not str(k).startswith("#")}
    return check_map(data, where)


def load_map(path) -> Dict[str, str]:
    """Read a saved map file (``parse_map``); files over ``MAX_MAP_BYTES`` and files that are not regular files
    (a FIFO, a device, a dangling link) are refused without being read."""
    from .io.files import open_regular  # a regular file only: a FIFO named .json never blocks

    path = os.fspath(path)
    try:
        if os.path.getsize(path) > MAX_MAP_BYTES:
            raise ParseError(f"the bone map is larger than {MAX_MAP_BYTES // 2 ** 20} MB; a bone map is a small "
                             f"JSON object", path)
        with open_regular(path, cap=False) as fh:
            data = fh.read(MAX_MAP_BYTES + 1)
    except OSError as exc:
        raise ParseError(f"cannot read the bone map ({exc.strerror or exc})", path) from None
    return parse_map(data, path)


def analyse_clip(clip: Clip) -> RigReport:
    """``analyse_rig`` of a clip's rig: its bones, hierarchy and rest skeleton (``meta``)."""
    m = clip.meta
    return analyse_rig(clip.bones, m.get("parents"), m.get(skeleton.REST_HEADS), m.get(skeleton.REST_TAILS))


def resolve_map(bone_map, clip: Clip, report: Optional[RigReport] = None) -> Optional[Dict[str, str]]:
    """The map to apply to ``clip`` for a ``bone_map`` option: "none" -> None (names as they are); a saved map
    (a path) or a dict -> its entries for the clip's bones, when it names any (a saved map is for the rig it
    names: clips of other rigs fall back to "auto"); "auto" -> the detected map (``analyse_clip``, or
    ``report`` when given; None when nothing maps)."""
    if bone_map is None or bone_map == "none":
        return None
    if bone_map != "auto":
        mapping = check_map(bone_map) if isinstance(bone_map, Mapping) else load_map(bone_map)
        present = {b: mapping[b] for b in clip.bones if b in mapping}
        if present:
            return present
    return (report or analyse_clip(clip)).mapping or None


def world_rotations(clip: Clip) -> np.ndarray:
    """(frames, joints, 3, 3): each bone's rotation relative to its rest pose in the armature's axes,
    ``W_b = W_parent X_b`` down the hierarchy (``meta["parents"]``; bones whose parent is not in the clip start
    their chain there). ``X`` are the clip's local rotations in armature axes."""
    parents = clip.meta.get("parents") or {}
    index = {b: j for j, b in enumerate(clip.bones)}
    W = np.empty_like(clip.rotations)
    done = {}

    def world(j):
        if j in done:
            return W[:, j]
        b = clip.bones[j]
        p, seen = parents.get(b), {b}
        while p is not None and p not in index and p not in seen:  # skip bones the clip does not hold
            seen.add(p)
            p = parents.get(p)
        if p is None or p not in index:
            W[:, j] = clip.rotations[:, j]
        else:
            W[:, j] = world(index[p]) @ clip.rotations[:, j]
        done[j] = True
        return W[:, j]

    for j in range(len(clip.bones)):
        world(j)
    return W


_Z = np.array([0.0, 0.0, 1.0])  # up in the comparison space (Blender's Z)
# a clip travels when its net horizontal displacement is at least this fraction of its horizontal path
TRAVEL_RATIO = 0.5


def heading(W_root: np.ndarray, root_translation: Optional[np.ndarray] = None,
            forward: Optional[np.ndarray] = None) -> np.ndarray:
    """The rotation about the vertical (Z) that ``to_comparison_space`` removes: where the take goes.

    * A clip that travels (net horizontal displacement of the root >= ``TRAVEL_RATIO`` of its horizontal path):
      the direction of travel, turned so that it becomes Blender's forward (-Y). Positions do not depend on
      rest poses or bone axes, so this heading is the same for the take on any rig.
    * Otherwise, with the rig's rest facing ``forward`` (3,) (``rest_forward``): where the body faces, the mean
      over the frames of ``W_root(t) forward``'s horizontal part, turned to -Y. Also a fact of positions: the
      same for a rig whose rest faces elsewhere (a whole rig turned about the vertical turns it along).
    * Without it: the circular mean over the frames of the root's yaw (its twist about Z), the facing relative
      to the rig's rest pose (only rigs whose rests face the same way agree)."""
    if root_translation is not None and len(root_translation) > 1:
        flat = np.asarray(root_translation, dtype=np.float64)[:, :2]
        net = flat[-1] - flat[0]
        path = np.linalg.norm(np.diff(flat, axis=0), axis=1).sum()
        if path > 0 and np.linalg.norm(net) >= TRAVEL_RATIO * path:
            return so3.exp((np.arctan2(net[1], net[0]) + np.pi / 2) * _Z)
    if forward is not None:
        # unnormalized: frames where the body lies (facing up or down) weigh less
        f = (np.asarray(W_root, dtype=np.float64) @ np.asarray(forward, dtype=np.float64))[:, :2].mean(axis=0)
        if np.linalg.norm(f) > 1e-6:
            return so3.exp(np.arctan2(f[0], -f[1]) * _Z)  # the turn about Z taking -Y to f
    yaw = so3.twist(W_root, _Z)
    return so3.exp(np.arctan2(np.sin(yaw).mean(), np.cos(yaw).mean()) * _Z)


def rest_forward(clip: Clip, by_joint: Mapping[str, str]) -> Optional[np.ndarray]:
    """The unit direction the rig's body faces at rest, in armature axes: left x up, left from the right to the
    left thigh's rest head (else the upper arms', the feet's), up from the hips (else the thighs' midpoint) to the
    neck (else the head, the chest); None without a rest skeleton or those joints."""
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    h = {j: np.asarray(heads[b], dtype=np.float64) for j, b in by_joint.items() if b in heads}
    left = next((h[f"{j}.L"] - h[f"{j}.R"] for j in ("thigh", "upper_arm", "foot")
                 if f"{j}.L" in h and f"{j}.R" in h), None)
    low = h.get("hips", 0.5 * (h["thigh.L"] + h["thigh.R"]) if "thigh.L" in h and "thigh.R" in h else None)
    top = next((h[j] for j in ("neck", "head", "chest") if j in h), None)
    if left is None or low is None or top is None:
        return None
    up = _unit(top - low)
    return None if up is None else _unit(np.cross(left - (left @ up) * up, up))


def clip_heading(clip: Clip, by_joint: Mapping[str, str], W: Optional[np.ndarray] = None) -> np.ndarray:
    """``heading`` of a clip read in armature axes with its map ``{joint: bone}``: of its hips (else its first
    mapped bone), its root translation and its rest facing (``rest_forward``). ``W``: ``world_rotations(clip)``
    when already computed."""
    W = world_rotations(clip) if W is None else W
    root = by_joint.get("hips", next((by_joint[j] for j in JOINTS if j in by_joint), None))
    return heading(W[:, clip.bones.index(root)], clip.root_translation, rest_forward(clip, by_joint))


def leg_length(clip: Clip, by_joint: Mapping[str, str]) -> Optional[float]:
    """The rig's leg (hip to ankle: the rest heads of the mapped thigh and foot, else the thigh's head and the
    shin's tail for a rig without a foot bone; mean over sides) in the clip's units, or None without a mapped leg
    or rest skeleton."""
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    tails = clip.meta.get(skeleton.REST_TAILS) or {}
    ankles = {s: heads.get(by_joint.get(f"foot.{s}"), tails.get(by_joint.get(f"shin.{s}"))) for s in SIDES}
    lengths = [np.linalg.norm(np.subtract(heads[by_joint[f"thigh.{s}"]], ankles[s])) for s in SIDES
               if by_joint.get(f"thigh.{s}") in heads and ankles[s] is not None]
    length = float(np.mean(lengths)) if lengths else 0.0
    return length if length > 0 else None


def hips_path(clip: Clip, by_joint: Mapping[str, str], W: np.ndarray) -> Optional[Tuple[np.ndarray, float]]:
    """(path, leg): the hips joint's head (frames, 3) in the armature's axes in **leg lengths**, and the rig's leg
    (``leg_length``) in its units; None when it cannot be had (no root translation, not in armature axes, no rest
    skeleton, no hips or legs mapped).

    Rigs translate different bones (a floor-level ``RL_BoneRoot`` in Character Creator, the pelvis in Daz and
    CMU), in different units (metres for Acclaim, centimetres in these BVH files) and for bodies of other sizes,
    so a root path is comparable across rigs as the hips' in leg lengths (the root's head plus
    ``skeleton.chain_offset`` to the hips, over ``leg_length``): retargeted so, a blend's hips keep the height
    and stride that fit the rig it is written onto. ``onto_rig`` inverts it."""
    if clip.root_translation is None or clip.meta.get("rotation_space") != "armature":
        return None
    off = skeleton.chain_offset(clip, W, by_joint.get("hips"))
    leg = leg_length(clip, by_joint)
    if off is None or leg is None:
        return None
    return (clip.root_translation + off) / leg, leg


def to_comparison_space(clip: Clip, mapping: Mapping[str, str]) -> Clip:
    """The clip in the comparison space: the mapped bones only, renamed to their joints (canonical order),
    rotations ``H^T W_b(t)`` (``world_rotations``, ``clip_heading``: of the hips or the first mapped bone, and the
    rig's rest facing). The root
    translation is the hips' path in leg lengths (``hips_path``; ``meta["root_path"] = "hips_legs"``, else the
    root's translation as read), turned with the heading. ``meta["bone_map"]`` keeps ``{joint: bone}``."""
    mapping = {b: j for b, j in mapping.items() if b in clip.bones}
    if not mapping:
        raise ShapeSigError(f"clip {clip.name!r}: no bone maps to a canonical joint")
    W = world_rotations(clip)
    index = {b: i for i, b in enumerate(clip.bones)}
    by_joint = {j: b for b, j in mapping.items()}
    joints = [j for j in JOINTS if j in by_joint]
    H = clip_heading(clip, by_joint, W)
    R = H.T[None, None] @ W[:, [index[by_joint[j]] for j in joints]]
    hips = hips_path(clip, by_joint, W)
    rt = clip.root_translation if hips is None else hips[0]
    rt = None if rt is None else rt @ H
    meta = dict(clip.meta, bone_map={j: by_joint[j] for j in joints}, rotation_space="comparison",
                rig_bones=len(clip.bones))
    if hips is not None:
        meta["root_path"] = "hips_legs"
    meta.pop("parents", None)
    return replace(clip, bones=tuple(joints), rotations=R, root_translation=rt, root_bone="hips",
                   rotation_modes=(), meta=meta)


# the canonical joint whose rest head a joint's rest bone points at (the first one the rig maps)
_CHILDREN = {"spine": ("spine_mid", "chest"), "spine_mid": ("chest",), "chest": ("neck", "head"), "neck": ("head",),
             "clavicle": ("upper_arm",), "upper_arm": ("forearm",), "forearm": ("hand",), "thigh": ("shin",),
             "shin": ("foot",), "foot": ("toe",)}


def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else None


def _rest_heads_by_joint(clip: Clip) -> Dict[str, np.ndarray]:
    heads = clip.meta.get(skeleton.REST_HEADS) or {}
    return {j: np.asarray(heads[b], dtype=np.float64) for j, b in (clip.meta.get("bone_map") or {}).items()
            if b in heads}


def _body_frame(h: Mapping[str, np.ndarray]) -> Optional[np.ndarray]:
    """The rest body frame (columns: left, forward, up) from the rest heads by joint: up from the hips to the
    neck (or head, chest), left from the right thigh to the left one; None when those are not mapped."""
    top = next((h[j] for j in ("neck", "head", "chest") if j in h), None)
    if "hips" not in h or top is None or "thigh.L" not in h or "thigh.R" not in h:
        return None
    up, left = _unit(top - h["hips"]), h["thigh.L"] - h["thigh.R"]
    left = None if up is None else _unit(left - (left @ up) * up)
    if left is None:
        return None
    return np.column_stack([left, np.cross(up, left), up])


def _best_twist(axis, M):
    """The angle t maximizing tr(Rot(axis, t)^T M): f(t) = a cos t + b sin t + c, read off at 0, pi/2, pi."""
    f = [np.trace(so3.exp(axis * t).T @ M) for t in (0.0, 0.5 * np.pi, np.pi)]
    c = 0.5 * (f[0] + f[2])
    return float(np.arctan2(f[1] - c, f[0] - c))


def rest_retarget(clip: Clip, like: Clip, samples: int = 64) -> Clip:
    """``clip`` (comparison space) with its rotations relative to the rest pose of ``like``'s rig: for a blend.

    A comparison-space rotation is relative to its rig's rest, ``W(t) = F(t) F_rest^T`` (F the segment's
    orientation), so the same motion on rigs with other rest poses (T- or A-pose, a rest lying down, other
    facing, other bone-axis conventions) differs by a constant right factor ``K_j`` per joint. Comparisons do
    not see it; a blend does (two rotations half a turn apart have no sensible midpoint: a Character Creator
    walk blended with a Daz run crossed its legs). Here ``W_j K_j``:

    * ``G`` turns ``like``'s rest body frame (``_body_frame``: hips to neck, right to left thigh) onto
      ``clip``'s;
    * a joint with a next joint in both rigs (``_CHILDREN``: thigh -> shin, ...) turns, after ``G``, by the
      smallest rotation that takes ``like``'s rest bone (head to the next joint's head) onto ``clip``'s, or not
      (rigs place joints differently: the same rest can give bones 20-40 degrees apart), whichever makes the two
      motions agree better; the rotation about the bone itself, which rest positions cannot give, is the angle
      that best matches them (``_best_twist`` of ``sum_t (W_B(t) K)^T W_A(t)`` over normalized time);
    * a joint without one (hips, hands, feet without toes, head) takes the rotation that best matches the two
      motions (``so3.nearest_rotation`` of ``M``: orthogonal Procrustes), which also takes up the mean difference of its orientation between them.

    ``clip`` is returned unchanged when either rig has no rest skeleton or body frame."""
    from .geometry.curves import geodesic_interpolate, uniform_times

    ha, hb = _rest_heads_by_joint(like), _rest_heads_by_joint(clip)
    fa, fb = _body_frame(ha), _body_frame(hb)
    if fa is None or fb is None:
        return clip
    G = fb @ fa.T
    u = np.linspace(0.0, 1.0, samples)
    RA = geodesic_interpolate(like.rotations, uniform_times(like.frames), u)
    RB = geodesic_interpolate(clip.rotations, uniform_times(clip.frames), u)
    R = clip.rotations.copy()
    for k, j in enumerate(clip.bones):
        if j not in like.bones:
            continue
        WA = RA[:, like.bones.index(j)]
        base, side = (j[:-2], j[-2:]) if j[-2:] in (".L", ".R") else (j, "")
        child = next((c + side for c in _CHILDREN.get(base, ()) if c + side in ha and c + side in hb), None)
        ra = None if child is None or j not in ha else _unit(ha[child] - ha[j])
        rb = None if child is None or j not in hb else _unit(hb[child] - hb[j])
        M = (np.swapaxes(RB[:, k], -1, -2) @ WA).sum(axis=0)  # tr(K^T M): how well W_B K matches W_A
        if ra is None or rb is None:
            K = so3.nearest_rotation(M)
        else:
            # the body frame alone or with the rest bones' swing (joints are placed differently by rigs: a
            # clavicle's rest bone may point 20-40 degrees elsewhere on a rig whose rest is the same), each
            # with its best twist; the one under which the motions agree better
            turns = [G, so3.align(G @ ra, rb) @ G]
            turns = [T @ so3.exp(ra * _best_twist(ra, T.T @ M)) for T in turns]
            K = max(turns, key=lambda T: np.trace(T.T @ M))
        R[:, k] = R[:, k] @ K
    return replace(clip, rotations=R, meta=dict(clip.meta, rest_of=like.name))


# bones of one name pointing further apart than this in two rests: another rest pose (an A-pose against a T-pose
# turns the upper arms about 45 degrees); the ASF skeletons of CMU subjects 07, 09 and 16 differ by 9.5-16.5
REST_DEGREES = 25.0


def rests_differ(heads_a: Mapping[str, Iterable[float]], parents_a: Mapping[str, Optional[str]],
                 heads_b: Mapping[str, Iterable[float]], parents_b: Mapping[str, Optional[str]],
                 degrees: float = REST_DEGREES) -> bool:
    """True when two rigs with bone names in common hold them in other rest poses: some bone present in both
    with the same parent points (parent's head to its head, armature axes) more than ``degrees`` elsewhere.
    Such rigs blend through the comparison space and ``rest_retarget``, not in their local rotations (which are
    relative to each rest). False when either rest skeleton is missing."""
    cos = np.cos(np.radians(degrees))
    for bone, parent in parents_a.items():
        if parent is None or parents_b.get(bone) != parent:
            continue
        if not all(x in h for x in (bone, parent) for h in (heads_a, heads_b)):
            continue
        da = _unit(np.subtract(heads_a[bone], heads_a[parent], dtype=np.float64))
        db = _unit(np.subtract(heads_b[bone], heads_b[parent], dtype=np.float64))
        if da is not None and db is not None and da @ db < cos:
            return True
    return False


def other_rigs(a: Clip, b: Clip) -> bool:
    """True when clips ``a`` and ``b`` are of two rigs for a blend: other bones, or the same bones in other rest
    poses (``rests_differ``)."""
    if tuple(a.bones) != tuple(b.bones):
        return True
    return rests_differ(a.meta.get(skeleton.REST_HEADS) or {}, a.meta.get("parents") or {},
                        b.meta.get(skeleton.REST_HEADS) or {}, b.meta.get("parents") or {})


def apply_bone_map(clip: Clip, bone_map="auto") -> Clip:
    """The front door's comparison-space step (``sources.read``): the clip mapped by ``resolve_map`` and moved
    to the comparison space, with ``meta["rig_joints"]`` (the canonical joints its rig has, ``analyse_clip``)
    and ``meta["unmapped_joints"]`` (those of them no bone is mapped to); a clip "auto" cannot map is returned as
    it is, marked ``meta["unmapped"]`` and, for a rig that is not a humanoid, ``meta["not_humanoid"]`` (one line;
    comparing it with a mapped clip is refused by ``check_comparable``)."""
    if clip.meta.get("rotation_space") == "comparison":
        return clip
    if bone_map in (None, "none"):
        return clip
    report = analyse_clip(clip)
    mapping = resolve_map(bone_map, clip, report)
    if mapping is None:
        meta = dict(clip.meta, unmapped=True)
        if report.refusal:
            meta["not_humanoid"] = report.refusal
        return replace(clip, meta=meta)
    out = to_comparison_space(clip, mapping)
    has = [j for j in JOINTS if j in set(report.joints) | set(out.bones)] if report.joints else list(out.bones)
    out.meta.update(rig_joints=tuple(has), unmapped_joints=tuple(j for j in has if j not in out.bones))
    return out


def _names(bones, limit=12):
    return ", ".join(bones[:limit]) + (f", ... ({len(bones)} bones)" if len(bones) > limit else "")


def check_comparable(*clips: Clip) -> None:
    """ShapeSigError (one line, naming the unmapped bones, or why the rig is not a humanoid) when some clips are
    in the comparison space and another's bones could not be mapped to the canonical joints."""
    mapped = [c for c in clips if c.meta.get("rotation_space") == "comparison"]
    if not mapped:
        return
    for c in clips:
        if c.meta.get("rotation_space") != "comparison" and not set(c.bones) & set(mapped[0].bones):
            why = c.meta.get("not_humanoid")
            if why:
                raise ShapeSigError(f"clip {c.name!r} is {why}; it is compared only with clips of its own rig "
                                    f"(or give a bone map)")
            raise ShapeSigError(f"clips {mapped[0].name!r} and {c.name!r} share no bones: no bone of {c.name!r} "
                                f"maps to a canonical joint (unmapped bones: {_names(list(c.bones))}); give a bone "
                                f"map")


def moving_count(clip: Clip) -> int:
    """The clip's moving joints (``Clip.still_bones``: the one stillness rule)."""
    return len(clip.bones) - len(clip.still_bones())


def joint_coverage(shared: Iterable[str], still_both: Iterable[str], has_a: Iterable[str],
                   has_b: Iterable[str]) -> Tuple[float, List[str]]:
    """(coverage, unmapped) from the joints compared (``shared``: in both clips, moving in either), the joints
    still in both clips and the canonical joints each rig has: compared / the joints both rigs have (those still
    in both left out), and the joints both rigs have that are not compared, in ``JOINTS`` order."""
    shared, still = set(shared), set(still_both)
    both = (set(has_a) & set(has_b) | shared) - still
    unmapped = [j for j in JOINTS if j in both and j not in shared]
    return (1.0 if not both else len(shared & both) / len(both)), unmapped


def chains_covered(present_a: Iterable[str], present_b: Iterable[str], has_a: Iterable[str],
                   has_b: Iterable[str]) -> Tuple[int, int]:
    """(limb chains compared, limb chains both rigs have) (``LIMB_CHAINS``: an arm is its upper arm and forearm,
    a leg its thigh and shin; compared when both clips hold both joints)."""
    pa, pb, ha, hb = set(present_a), set(present_b), set(has_a), set(has_b)
    both = [c for c, js in LIMB_CHAINS.items() if all(j in ha and j in hb for j in js)]
    return sum(all(j in pa and j in pb for j in LIMB_CHAINS[c]) for c in both), len(both)


def coverage_from(bones_a: Iterable[str], still_a: Iterable[str], has_a: Iterable[str], bones_b: Iterable[str],
                  still_b: Iterable[str], has_b: Iterable[str]) -> dict:
    """``coverage_report``'s dict from each clip's bones, still bones and canonical joints its rig has (empty:
    unknown, e.g. a clip read by name): the shared bones that move in either clip, over the canonical joints both
    rigs have (``joint_coverage``) when both rigs are known, else over the moving bones of the smaller clip."""
    bones_a, bones_b, has_a, has_b = tuple(bones_a), tuple(bones_b), tuple(has_a or ()), tuple(has_b or ())
    sa, sb = set(still_a) & set(bones_a), set(still_b) & set(bones_b)
    in_b = set(bones_b)
    shared = [x for x in bones_a if x in in_b and not (x in sa and x in sb)]
    if has_a and has_b:
        cov, unmapped = joint_coverage(shared, sa & sb, has_a, has_b)
        chains, total = chains_covered(bones_a, bones_b, has_a, has_b)
        return {"bones": len(shared), "coverage": cov, "chains": chains, "chains_total": total, "unmapped": unmapped}
    smaller = min(len(bones_a) - len(sa), len(bones_b) - len(sb))
    cov = 1.0 if smaller == 0 else min(1.0, len(shared) / smaller)
    return {"bones": len(shared), "coverage": cov, "chains": 0, "chains_total": 0, "unmapped": []}


def below_minimum(got: Mapping) -> str:
    """Why a ``coverage_report`` dict is below the comparison rule (``MIN_COVERAGE`` of the joints, and of the limb
    chains both rigs have), as a short phrase; "" when it passes."""
    if got["coverage"] < MIN_COVERAGE:
        return f"coverage {got['coverage']:.2f} < {MIN_COVERAGE}"
    if got["chains_total"] and got["chains"] < MIN_COVERAGE * got["chains_total"]:
        return f"{got['chains']} of the {got['chains_total']} arms and legs both rigs have compared"
    return ""


def coverage(a: Clip, b: Clip) -> Tuple[int, float]:
    """(joints compared, coverage): the shared bones that move in either clip, over the canonical joints both
    rigs have (``meta["rig_joints"]``, ``joint_coverage``) for mapped clips, else over the moving joints of the
    smaller clip (the one with fewer moving joints); 0..1 (1 when nothing moves)."""
    got = coverage_report(a, b)
    return got["bones"], got["coverage"]


def coverage_report(a: Clip, b: Clip) -> dict:
    """``{"bones", "coverage", "chains", "chains_total", "unmapped"}`` of two clips (``coverage_from``): the
    coverage, the limb chains compared (``chains_covered``) and the canonical joints both rigs have that are not
    compared."""
    return coverage_from(a.bones, a.still_bones(), a.meta.get("rig_joints") or (), b.bones, b.still_bones(),
                         b.meta.get("rig_joints") or ())


def onto_rig(clip: Clip, rig: Clip, mapped: Clip) -> Clip:
    """A comparison-space clip (e.g. a blend of ``mapped`` with a clip of another rig) written back onto the
    rig of ``rig`` (the same source as ``mapped``, read with ``bone_map="none"``): local rotations in armature
    axes ``X_b = W_parent^T W_b`` for every bone of the rig, where a joint of ``clip`` sets ``W_b = H W~_b``
    (``H``: ``mapped``'s heading) and every other bone keeps ``rig``'s own motion (local rotation, re-timed
    to ``clip``'s frames by geodesic interpolation). ``meta["kept_bones"]`` lists the rig's bones that kept
    their motion (no counterpart in ``clip``)."""
    from .geometry.curves import geodesic_interpolate, uniform_times

    bone_map = mapped.meta.get("bone_map") or {}
    unblended = set(clip.meta.get("unmatched_a", ()))  # joints a blend copied from A: A's local motion stays
    joint_of = {b: j for j, b in bone_map.items() if j in clip.bones and j not in unblended}
    parents = rig.meta.get("parents") or {}
    H = clip_heading(rig, {j: b for j, b in bone_map.items() if b in rig.bones})
    X_rig = geodesic_interpolate(rig.rotations, uniform_times(rig.frames), uniform_times(clip.frames))
    index = {b: i for i, b in enumerate(rig.bones)}
    W = np.empty_like(X_rig)
    X = np.empty_like(X_rig)
    done = set()

    def parent_world(b):
        p = parents.get(b)
        while p is not None and p not in index:
            p = parents.get(p)
        return None if p is None else world(index[p])

    def world(i):
        if i in done:
            return W[:, i]
        b = rig.bones[i]
        Wp = parent_world(b)
        if b in joint_of:
            W[:, i] = H[None] @ clip.rotations[:, clip.bones.index(joint_of[b])]
            X[:, i] = W[:, i] if Wp is None else np.swapaxes(Wp, -1, -2) @ W[:, i]
        else:
            X[:, i] = X_rig[:, i]
            W[:, i] = X[:, i] if Wp is None else Wp @ X[:, i]
        done.add(i)
        return W[:, i]

    for i in range(len(rig.bones)):
        world(i)
    # bones between two written body joints with no motion of their own share the chain's rotation (a Mixamo
    # Spine1 under a source with two spine bones): core.rig_chains
    body = [b for b, j in joint_of.items() if j in BODY]
    still = [b for b in rig.bones if b not in joint_of and np.allclose(X_rig[:, index[b]], np.eye(3))]
    chains = chains_between(rig.bones, parents, body, still)
    if chains:
        X = share_chains(X, rig.bones, chains)
        W = _forward(X, rig.bones, parents)
    rt = None if clip.root_translation is None else clip.root_translation @ H.T
    if rt is not None and mapped.meta.get("root_path") == "hips_legs":
        # the blended hips (leg lengths) -> the rig's root head: hips_path inverted with the blend's rotations
        off = skeleton.chain_offset(rig, W, bone_map.get("hips"))
        leg = leg_length(rig, bone_map)
        if off is None or leg is None:
            raise ShapeSigError(f"clip {rig.name!r}: cannot place its root under the blended hips (no rest skeleton)")
        rt = rt * leg - off
    kept = tuple(b for b in rig.bones if b not in joint_of and not np.allclose(X_rig[:, index[b]], np.eye(3)))
    meta = dict(rig.meta, kept_bones=kept, chain_bones=tuple(b for c in chains.values() for b in c))
    # the blend's timing and weights (core.blend.feet carries the sources' contacts through them)
    meta.update({k: clip.meta[k] for k in ("weight", "weights", "warp", "time_map", "source_times") if k in clip.meta})
    return replace(rig, name=clip.name, rotations=X, root_translation=rt, frame_start=clip.frame_start,
                   fps=clip.fps, meta=meta)


def _forward(X: np.ndarray, bones: Sequence[str], parents: Mapping[str, Optional[str]]) -> np.ndarray:
    """World rotations ``W_b = W_parent X_b`` of local rotations ``X`` (``world_rotations`` of a bare array)."""
    clip = Clip(name="", bones=tuple(bones), rotations=X, fps=1.0, meta={"parents": dict(parents)})
    return world_rotations(clip)
