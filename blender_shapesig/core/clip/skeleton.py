"""Rest skeletons and forward kinematics on Clip data, without bpy: the readers put the rest skeleton in
``clip.meta`` by one recipe (``rest_meta``: ``rest_heads``, ``rest_tails``, ``parents``), and forward kinematics
turns a clip's rotations into joint positions; also the clip's up vector (``up_vector``) and its unit
(``unit_meters``). See docs/dev/rotations.md, "Forward kinematics".
"""

import math
from dataclasses import dataclass, replace
from typing import Optional, Tuple

import numpy as np

from ..geometry import so3
from .clip import Clip
from ..errors import ShapeSigError

__all__ = ["REST_HEADS", "REST_TAILS", "UNIT_METERS", "Rest", "rest_meta", "map_rest_meta", "to_world_axes", "from_world_axes", "rest_of",
           "aligned_rotations", "from_aligned", "root_heads", "root_translation_from_heads",
           "forward_kinematics", "chain_offset", "CARRIER_SHARE", "fold_root_motion", "up_vector", "root_up", "parse_up", "estimate_up_axis", "unit_meters", "LEG_METERS"]

REST_HEADS = "rest_heads"
REST_TAILS = "rest_tails"
UNIT_METERS = "unit_meters"  # metres per unit of the clip's positions, when the reader knows it
# an adult's thigh + shin (hip to ankle), to guess the unit of files that do not say it (BVH, Blender scenes)
LEG_METERS = 0.85
_UNITS = (1.0, 0.1, 0.0254, 0.01, 0.001)  # m, dm, inch, cm, mm: the candidates of the guess


def rest_meta(names, heads, tails=None) -> dict:
    """The meta entries of a rest skeleton: ``{"rest_heads": {bone: (x, y, z)}, "rest_tails": {...}}``."""
    out = {REST_HEADS: {n: tuple(float(v) for v in h) for n, h in zip(names, np.asarray(heads, float))}}
    if tails is not None:
        out[REST_TAILS] = {n: tuple(float(v) for v in t) for n, t in zip(names, np.asarray(tails, float))}
    return out


def map_rest_meta(meta: dict, matrix, scale: float = 1.0) -> dict:
    """The rest entries of ``meta`` mapped by ``scale * matrix @ x`` (a change of axes and units)."""
    A = np.asarray(matrix, dtype=np.float64)
    out = {}
    for key in (REST_HEADS, REST_TAILS):
        if key in meta:
            out[key] = {n: tuple(float(v) for v in scale * (A @ np.asarray(p, float))) for n, p in meta[key].items()}
    return out


def _world_parts(clip: Clip, matrix):
    """(M, A): the 4x4 ``matrix`` and its rotation (the matrix's 3x3 part over its uniform scale); ShapeSigError
    for a mirroring or degenerate matrix."""
    M = np.asarray(matrix, dtype=np.float64)
    det = float(np.linalg.det(M[:3, :3]))
    if not det > 1e-30:
        raise ShapeSigError(f"clip {clip.name!r}: its armature is {'mirrored' if det < 0 else 'scaled to nothing'} "
                            f"in the scene (a negative or zero scale)")
    return M, so3.nearest_rotation(M[:3, :3] / det ** (1.0 / 3.0))


def _map_axes(clip: Clip, A, L, t, meta) -> Clip:
    """Rotations and rest orientations turned by A, positions mapped by x -> L x + t."""
    for key in (REST_HEADS, REST_TAILS):
        if key in meta:
            meta[key] = {n: tuple(float(v) for v in L @ np.asarray(p, float) + t) for n, p in meta[key].items()}
    if "rest_rotations" in meta:
        meta["rest_rotations"] = A[None] @ np.asarray(meta["rest_rotations"], dtype=np.float64)
    rt = clip.root_translation
    rt = None if rt is None else rt @ L.T + t
    R = A[None, None] @ clip.rotations @ A.T[None, None]
    return replace(clip, rotations=R, root_translation=rt, meta=meta)


def to_world_axes(clip: Clip, matrix) -> Clip:
    """A clip in its armature's axes re-expressed in the world's through the armature object's ``matrix`` (4x4,
    rotation times a uniform scale plus a translation: the object's world matrix, parents included): rotations
    and rest orientations turned by the rotation A (``A X A^T``, ``A B``), rest heads/tails and the root
    translation mapped by the whole matrix (the file's units times its scales); ``meta["axes"]`` becomes
    "world". ShapeSigError for a mirroring or degenerate matrix. ``from_world_axes`` is its inverse."""
    M, A = _world_parts(clip, matrix)
    meta = dict(clip.meta, rotation_space="armature", up_axis="Z", axes="world")
    return _map_axes(clip, A, M[:3, :3], M[:3, 3], meta)


def from_world_axes(clip: Clip, matrix) -> Clip:
    """The inverse of ``to_world_axes``: a clip in the world's axes back in the axes of the armature whose object
    has the world ``matrix`` (what is written onto that armature)."""
    M, A = _world_parts(clip, matrix)
    inv = np.linalg.inv(M[:3, :3])
    meta = dict(clip.meta, rotation_space="armature", axes="armature")
    meta.pop("up_axis", None)
    return _map_axes(clip, A.T, inv, -inv @ M[:3, 3], meta)


@dataclass
class Rest:
    """The rest skeleton of a clip, parallel to ``clip.bones``: ``ancestor`` (index of the nearest ancestor the
    clip holds, -1 for none), ``heads`` and ``tails`` (bones, 3) in world-aligned axes."""

    bones: Tuple[str, ...]
    ancestor: np.ndarray
    heads: np.ndarray
    tails: np.ndarray
    root: Optional[int]

    def index(self, bone):
        return self.bones.index(bone)


def rest_of(clip: Clip) -> Rest:
    """The clip's rest skeleton from its meta (ShapeSigError naming what is missing)."""
    heads = clip.meta.get(REST_HEADS)
    parents = clip.meta.get("parents")
    if not heads or parents is None:
        raise ShapeSigError(f"clip {clip.name!r} carries no rest skeleton (meta rest_heads/parents): "
                            f"read it from a file or with its armature")
    missing = [b for b in clip.bones if b not in heads]
    if missing:
        raise ShapeSigError(f"clip {clip.name!r}: no rest head for bone(s) {', '.join(missing[:5])}")
    tails = clip.meta.get(REST_TAILS) or {}
    index = {b: i for i, b in enumerate(clip.bones)}
    anc = np.full(len(clip.bones), -1)
    for i, b in enumerate(clip.bones):
        p, seen = parents.get(b), {b}
        while p is not None and p not in index and p not in seen:
            seen.add(p)
            p = parents.get(p)
        anc[i] = index.get(p, -1) if p is not None else -1
    H = np.array([heads[b] for b in clip.bones], dtype=np.float64)
    T = np.array([tails.get(b, heads[b]) for b in clip.bones], dtype=np.float64)
    root = index.get(clip.root_bone) if clip.root_bone is not None else None
    return Rest(clip.bones, anc, H, T, root)


def _rest_rotations(clip):
    B = clip.meta.get("rest_rotations")
    if B is None or np.shape(B) != (len(clip.bones), 3, 3):
        raise ShapeSigError(f"clip {clip.name!r} is in pose space without meta rest_rotations")
    return np.asarray(B, dtype=np.float64)


def aligned_rotations(clip: Clip) -> np.ndarray:
    """X (frames, bones, 3, 3): each bone's rotation relative to its rest in world-aligned axes."""
    space = clip.meta.get("rotation_space", "pose")
    if space in ("armature", "asf"):
        return clip.rotations
    if space == "pose":
        B = _rest_rotations(clip)
        return B[None] @ clip.rotations @ np.swapaxes(B, -1, -2)[None]
    raise ShapeSigError(f"clip {clip.name!r}: no forward kinematics in the {space!r} space (use the rig's clip)")


def from_aligned(clip: Clip, X: np.ndarray) -> np.ndarray:
    """The inverse of ``aligned_rotations``: world-aligned rotations X back in the clip's rotation space."""
    if clip.meta.get("rotation_space", "pose") == "pose":
        B = _rest_rotations(clip)
        return np.swapaxes(B, -1, -2)[None] @ X @ B[None]
    return X


def root_heads(clip: Clip, rest: Rest) -> Optional[np.ndarray]:
    """(frames, 3) the root bone's head (world-aligned), or None without a root translation."""
    if clip.root_translation is None or rest.root is None:
        return None
    if clip.meta.get("rotation_space", "pose") == "pose":
        B = _rest_rotations(clip)[rest.root]
        return rest.heads[rest.root] + clip.root_translation @ B.T
    return clip.root_translation


def root_translation_from_heads(clip: Clip, rest: Rest, heads: np.ndarray) -> np.ndarray:
    """The inverse of ``root_heads``: the clip's root translation that puts the root's head at ``heads``."""
    if clip.meta.get("rotation_space", "pose") == "pose":
        B = _rest_rotations(clip)[rest.root]
        return (heads - rest.heads[rest.root]) @ B
    return heads


def forward_kinematics(clip: Clip, rest: Optional[Rest] = None, X: Optional[np.ndarray] = None,
                       root: Optional[np.ndarray] = None):
    """(heads, tails, W): every bone's head and tail (frames, bones, 3) and world rotation (frames, bones, 3, 3)
    in world-aligned axes and the clip's units (module docstring). ``X``/``root``: other aligned rotations /
    root heads than the clip's (e.g. during IK)."""
    rest = rest_of(clip) if rest is None else rest
    X = aligned_rotations(clip) if X is None else X
    root = root_heads(clip, rest) if root is None else root
    F, n = X.shape[0], X.shape[1]
    W = np.empty_like(X)
    heads = np.empty((F, n, 3))
    done = np.zeros(n, dtype=bool)

    def solve(j):
        if done[j]:
            return
        a = rest.ancestor[j]
        if a < 0:
            W[:, j] = X[:, j]
            heads[:, j] = root if (j == rest.root and root is not None) else rest.heads[j]
        else:
            solve(a)
            W[:, j] = W[:, a] @ X[:, j]
            heads[:, j] = heads[:, a] + W[:, a] @ (rest.heads[j] - rest.heads[a])
        done[j] = True

    for j in range(n):
        solve(j)
    tails = heads + np.einsum("fnij,nj->fni", W, rest.tails - rest.heads)
    return heads, tails, W


def chain_offset(clip: Clip, W: np.ndarray, bone: str) -> Optional[np.ndarray]:
    """(frames, 3): ``bone``'s head minus the root bone's head, in world-aligned axes and the clip's units, by
    forward kinematics up its chain (``head_b - head_a = W_a (h_b - h_a)``, a the nearest ancestor the clip holds;
    ``W``: the world rotations (frames, bones, 3, 3) parallel to ``clip.bones``). None when the clip has no rest
    skeleton or ``bone``'s chain does not reach the root bone. Only the chain is walked (cheap on 100-bone rigs)."""
    heads, parents = clip.meta.get(REST_HEADS), clip.meta.get("parents")
    index = {b: i for i, b in enumerate(clip.bones)}
    if not heads or parents is None or bone not in index or clip.root_bone not in index:
        return None
    off = np.zeros((W.shape[0], 3))
    b = bone
    while b != clip.root_bone:
        p = parents.get(b)
        while p is not None and p not in index:
            p = parents.get(p)
        if p is None or b not in heads or p not in heads:
            return None
        off += W[:, index[p]] @ (np.asarray(heads[b], dtype=np.float64) - np.asarray(heads[p], dtype=np.float64))
        b = p
    return off


# a bone's translations carry the root motion when they move by at least this share of the most moving ones
CARRIER_SHARE = 0.1


def fold_root_motion(parents, X, root_path, moves):
    """(root path, carrier): the root bone's head path (frames, 3, world-aligned axes) that puts the **carrier**'s
    head where translations of bones below the root put it, and the carrier's index (None: the root's path as given).
    Only bones whose subtree holds more than half of the bones take part (hands, props and IK targets never do).

    Exports with a static reference root above the hips (Unity, MotionBuilder: six BVH channels on every joint) move
    the body by the hips' translations. The carrier is the deepest bone whose translations move (by
    ``CARRIER_SHARE`` of the most moving ones) and whose subtree holds more than half of the bones; the translations
    on the way down to it fold into the root's path: forward kinematics with the rest offsets then puts the carrier
    and every bone below it where they are played (the root's own head moves with them). ``parents``: each bone's
    parent index (-1 for a root); ``X``: the aligned local rotations (frames, bones,
    3, 3); ``root_path``: the root's head as its own channels place it; ``moves``: {bone: (frames, 3) its head's
    displacement from its rest offset, in its parent's aligned frame}."""
    n = len(parents)
    size, depth = np.ones(n, dtype=int), np.zeros(n, dtype=int)
    for j in range(n):
        a = parents[j]
        while a >= 0:  # every ancestor's subtree holds j
            size[a] += 1
            depth[j] += 1
            a = parents[a]
    # the bones holding most of the skeleton (the chain from the root to where it branches) and how far they move
    ranges = {j: float(np.ptp(np.asarray(d), axis=0).max()) for j, d in moves.items() if len(d) and 2 * size[j] > n}
    most = max(ranges.values(), default=0.0)
    moving = [j for j, r in ranges.items() if r > 0 and r >= CARRIER_SHARE * most]
    if not moving:
        return root_path, None
    carrier = max(moving, key=lambda j: (depth[j], -j))
    chain = [carrier]
    while parents[chain[-1]] >= 0:
        chain.append(parents[chain[-1]])
    chain.reverse()  # root ... carrier
    p = np.array(root_path, dtype=np.float64)
    W = X[:, chain[0]]
    for j in chain[1:]:
        if j in moves:
            p = p + np.einsum("fij,fj->fi", W, np.asarray(moves[j], dtype=np.float64))
        W = W @ X[:, j]
    return p, carrier


_AXES = {"X": 0, "Y": 1, "Z": 2}


def parse_up(up):
    """'X'/'Y'/'Z' (optionally signed) or a 3-vector -> unit vector, or None."""
    if up is None:
        return None
    if isinstance(up, str):
        s = up.strip().upper().lstrip("+-")
        if s not in _AXES:
            raise ShapeSigError(f"up_axis: expected X, Y, Z or a 3-vector, got {up!r}")
        v = np.zeros(3)
        v[_AXES[s]] = 1.0
        return v
    v = np.asarray(up, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-9:
        raise ShapeSigError(f"up_axis: expected X, Y, Z or a non-zero 3-vector, got {up!r}")
    return v / np.linalg.norm(v)


def estimate_up_axis(root_rotations, root_translations=()):
    """Guess the vertical axis (in the root's parent space) of one or more clips.

    ``root_rotations``: a list of root-rotation curves (frames, 3, 3); ``root_translations``: the
    matching root translations (frames, 3) (or empty). Two cues, pooled over the clips:

    * the vertical is perpendicular to the direction of travel: each clip that travels (net
      displacement more than three times the spread of its positions across it) removes its
      travel direction from the candidates (a second direction only when it is more than about
      20 degrees from the first: then the vertical is their normal);
    * among what is left, the vertical is the axis of the root's largest rotation oscillation
      about its mean orientation (pelvic rotation in gait, turns).

    The result is snapped to the nearest coordinate axis when it lies within 20 degrees of it (the
    usual case for capture data and rigs). A guess: pass ``up_axis`` to ``blend_clips`` when the
    vertical is known. Returns a unit vector.
    """
    S = np.zeros((3, 3))
    for R in root_rotations:
        R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
        r = so3.log(R @ so3.nearest_rotation(R.sum(axis=0)).T)  # about the mean orientation
        S += r.T @ r / max(len(r), 1)
    P = np.eye(3)
    for p in root_translations:
        if p is None:
            continue
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        d = p[-1] - p[0]
        line = p[0] + np.outer(np.linspace(0.0, 1.0, len(p)), d)
        spread = np.sqrt(np.mean(np.sum((p - line) ** 2, axis=1)))
        if np.linalg.norm(d) <= 3.0 * spread or np.linalg.norm(d) < 1e-9:
            continue
        r = P @ d
        if np.linalg.norm(r) < 0.35 * np.linalg.norm(d):
            continue
        r /= np.linalg.norm(r)
        P = P - np.outer(r, r)
        if np.trace(P) < 1.5:
            break
    if np.trace(P) < 1.5:
        # Two travel directions: the vertical is their normal (the one left in P).
        vals, vecs = np.linalg.eigh(P)
    else:
        vals, vecs = np.linalg.eigh(P @ S @ P)
    u = vecs[:, -1]
    if vals[-1] <= 1e-15:
        u = np.array([0.0, 0.0, 1.0])
    axis = int(np.argmax(np.abs(u)))
    if abs(u[axis]) >= math.cos(math.radians(20.0)):
        u = np.zeros(3)
        u[axis] = 1.0
    return u / np.linalg.norm(u)


def up_vector(clip: Clip) -> np.ndarray:
    """The world's up in the clip's world-aligned axes (where forward kinematics and the planted feet work):
    ``meta["up_axis"]`` ('Y' for ASF axes), else Blender's Z."""
    up = parse_up(clip.meta.get("up_axis"))
    if up is not None:
        return up
    return np.eye(3)[1] if clip.meta.get("rotation_space") == "asf" else np.eye(3)[2]


def root_up(clips, up_axis=None) -> np.ndarray:
    """The world's up in the frame of the clips' root translations (where a blend moves the root): ``up_axis``
    when given (the Blender layer passes it for pose-space actions: ``action_spaces.up_in_bone_frame``), else the
    first ``meta["up_axis"]``, else Y for Acclaim data, else ``estimate_up_axis`` on the clips' roots. For
    clips in world-aligned axes it is ``up_vector``."""
    for cand in [up_axis] + [c.meta.get("up_axis") for c in clips]:
        up = parse_up(cand)
        if up is not None:
            return up
    if all(c.meta.get("format") == "acclaim" or c.meta.get("rotation_space") == "asf" for c in clips):
        return np.eye(3)[1]
    rooted = [c for c in clips if c.root_bone in c.bones]
    if not rooted:
        return np.eye(3)[2]
    return estimate_up_axis([c.rotations[:, c.bones.index(c.root_bone)] for c in rooted],
                            [c.root_translation for c in rooted])


def unit_meters(clip: Clip, legs=None) -> float:
    """Metres per unit of the clip's positions: ``meta["unit_meters"]`` when the reader knows it (Acclaim), else
    the unit among m, dm, inch, cm, mm that makes the rest legs (``legs``: pairs of (thigh, foot) bone indices of
    ``rest_of(clip)``) closest to ``LEG_METERS`` (log scale); 1 without legs."""
    known = clip.meta.get(UNIT_METERS)
    if known:
        return float(known)
    if not legs:
        return 1.0
    rest = rest_of(clip)
    length = float(np.mean([np.linalg.norm(rest.heads[t] - rest.heads[f]) for t, f in legs]))
    if length <= 0:
        return 1.0
    return min(_UNITS, key=lambda u: abs(np.log(u * length / LEG_METERS)))

