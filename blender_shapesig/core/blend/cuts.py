"""Where clip A can hand over to clip B: the cost of every (A frame, B frame) pair as motion graphs define it
(Kovar, Gleicher & Pighin 2002), the point-cloud distance over a short window around both frames after the best
rigid 2-D fit on the ground (a turn about up and a ground translation, in closed form), plus the share of foot
contacts (heel and ball of each foot) that disagree over the window; the ranked local minima (``cut_costs``,
``rank_cuts``) and the fit of one pair (``ground_fit``). Positions are ``body.Body``'s: any rigs the bone maps join,
in leg lengths. See docs/transitions.md, "Best cuts".
"""

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import minimum_filter

from ..errors import ShapeSigError

__all__ = ["Cut", "CUT_FPS", "WINDOW", "CONTACT_WEIGHT", "cut_costs", "rank_cuts", "pair_cost", "ground_fit", "shared_joints"]

CUT_FPS = 30.0         # the grid of the cost matrix (samples per second of each clip)
WINDOW = 9             # samples of the window (at CUT_FPS: 0.3 s, centred on the cut)
CONTACT_WEIGHT = 0.25  # leg lengths of cost for a window whose contacts all disagree
NEIGHBOURS = 5         # a local minimum is the lowest in this many grid samples along either clip


@dataclass
class Cut:
    """One place where A can hand over to B: ``a_frame``, ``b_frame`` (0-based frame indices of each clip) and
    ``cost`` (leg lengths; lower is better)."""

    a_frame: int
    b_frame: int
    cost: float

    def as_dict(self):
        return {"a_frame": int(self.a_frame), "b_frame": int(self.b_frame), "cost": round(float(self.cost), 6)}


def shared_joints(ba, bb):
    """The joints (names) both bodies have; ShapeSigError when they share none."""
    joints = [j for j in ba.joints if j in bb.joints]
    if not joints:
        raise ShapeSigError("the clips share no joints (give clips of one rig or rigs the bone maps know)")
    return joints


def _offsets(fps):
    """Window sample offsets in frames of a clip at ``fps``."""
    half = (WINDOW - 1) // 2
    return np.arange(-half, half + 1) * (fps / CUT_FPS)


def _windows(body, centres, joints):
    """(H, Z, C): per centre frame, the window's ground coordinates centred on their mean (n, W*J, 2), heights
    (n, W*J) and contacts (n, W*4)."""
    frames = np.asarray(centres, dtype=np.float64)[:, None] + _offsets(body.fps)[None]
    pts, con = body.at(frames, joints)
    H = pts[..., :2].reshape(len(frames), -1, 2)
    H = H - H.mean(axis=1, keepdims=True)
    return H, pts[..., 2].reshape(len(frames), -1), con.reshape(len(frames), -1)


def _grid(body):
    """Centre frames on the CUT_FPS grid whose whole window lies inside the clip."""
    half = (WINDOW - 1) // 2 * body.fps / CUT_FPS
    last = body.frames - 1 - half
    if last < half:
        return np.zeros(0)
    step = body.fps / CUT_FPS
    return np.arange(half, last + 1e-9, step)


def _cost(wa, wb):
    """(na, nb) cost between windows of A and B (module docstring): sqrt of the mean squared point distance after
    the best turn and translation on the ground, plus CONTACT_WEIGHT times the share of disagreeing contacts."""
    Ha, Za, Ca = wa
    Hb, Zb, Cb = wb
    n = Ha.shape[1]
    # three products in single precision (the grid's ranking; the ranked cuts' costs are recomputed in double)
    A = np.concatenate([Ha[..., 0], Ha[..., 1]], axis=1).astype(np.float32)
    A90 = np.concatenate([Ha[..., 1], -Ha[..., 0]], axis=1).astype(np.float32)
    B = np.concatenate([Hb[..., 0], Hb[..., 1]], axis=1).astype(np.float32).T
    C, S = (A @ B).astype(np.float64), (A90 @ B).astype(np.float64)
    ZZ = (Za.astype(np.float32) @ Zb.astype(np.float32).T).astype(np.float64)
    sq = (np.sum(Ha ** 2, axis=(1, 2))[:, None] + np.sum(Hb ** 2, axis=(1, 2))[None]
          - 2.0 * np.sqrt(C * C + S * S)
          + np.sum(Za ** 2, axis=1)[:, None] + np.sum(Zb ** 2, axis=1)[None] - 2.0 * ZZ)
    cost = np.sqrt(np.maximum(sq, 0.0) / n)
    m = Ca.shape[1]
    if m:
        differ = Ca.sum(axis=1)[:, None] + Cb.sum(axis=1)[None] - 2.0 * Ca @ Cb.T
        cost = cost + CONTACT_WEIGHT * differ / m
    return cost


def cut_costs(ba, bb):
    """(cost (na, nb), centres of A, centres of B): the cost matrix on the CUT_FPS grid (fractional frames of each
    clip, windows inside the clips)."""
    joints = shared_joints(ba, bb)
    ca, cb = _grid(ba), _grid(bb)
    if not len(ca) or not len(cb):
        short = ba if not len(ca) else bb
        raise ShapeSigError(f"a clip is too short for a cut: {short.frames} frames, a cut needs "
                            f"{WINDOW / CUT_FPS:.2f} s")
    return _cost(_windows(ba, ca, joints), _windows(bb, cb, joints)), ca, cb


def _pair_costs(wa, wb):
    """(n,) ``_cost`` of the pairs (window k of A, window k of B)."""
    Ha, Za, Ca = wa
    Hb, Zb, Cb = wb
    C = np.sum(Ha * Hb, axis=(1, 2))
    S = np.sum(Ha[..., 1] * Hb[..., 0] - Ha[..., 0] * Hb[..., 1], axis=1)
    sq = (np.sum(Ha ** 2, axis=(1, 2)) + np.sum(Hb ** 2, axis=(1, 2)) - 2.0 * np.sqrt(C * C + S * S)
          + np.sum((Za - Zb) ** 2, axis=1))
    cost = np.sqrt(np.maximum(sq, 0.0) / Ha.shape[1])
    if Ca.shape[1]:
        cost = cost + CONTACT_WEIGHT * np.sum(np.abs(Ca - Cb), axis=1) / Ca.shape[1]
    return cost


def _refine(ba, bb, joints, pairs):
    """Per (A centre, B frame) pair: the A frame within +-half a grid step of the centre (whole frames, window
    inside A) of least cost against B at that frame; [(A frame, cost)], all pairs in one batch."""
    half = (WINDOW - 1) // 2 * ba.fps / CUT_FPS
    reach = int(np.ceil(ba.fps / CUT_FPS / 2.0)) + 1
    lo, hi = np.ceil(half - 1e-9), ba.frames - 1 - half + 1e-9
    fa = np.array([int(round(a)) for a, _b in pairs])
    cands = fa[:, None] + np.arange(-reach, reach + 1)[None]
    ok = (cands >= lo) & (cands <= hi)
    cands = np.where(ok, cands, fa[:, None])
    fb = np.repeat([b for _a, b in pairs], cands.shape[1])
    costs = _pair_costs(_windows(ba, cands.ravel(), joints), _windows(bb, fb, joints)).reshape(cands.shape)
    k = np.argmin(costs, axis=1)
    rows = np.arange(len(pairs))
    return [(int(a), float(c)) for a, c in zip(cands[rows, k], costs[rows, k])]


def rank_cuts(ba, bb, top=5):
    """The ``top`` local minima of ``cut_costs`` as ``Cut``s, best first: B's frame on the grid rounded to a whole
    frame, A's frame refined to the whole frame of least cost near it."""
    cost, ca, cb = cut_costs(ba, bb)
    joints = shared_joints(ba, bb)
    low = minimum_filter(cost, size=NEIGHBOURS, mode="nearest")
    ii, jj = np.nonzero(cost <= low + 1e-12)
    order = np.argsort(cost[ii, jj], kind="stable")
    pairs = []
    for k in order[:4 * top]:
        fb = int(round(cb[jj[k]]))
        pairs.append((ca[ii[k]], min(max(fb, int(np.ceil(cb[0] - 1e-9))), int(np.floor(cb[-1] + 1e-9)))))
    out, seen = [], set()
    for (fa, c), (_a, fb) in zip(_refine(ba, bb, joints, pairs) if pairs else [], pairs):
        if (fa, fb) not in seen:
            seen.add((fa, fb))
            out.append(Cut(fa, fb, c))
    out.sort(key=lambda x: x.cost)
    return out[:top]


def pair_cost(ba, bb, a_frame, b_frame):
    """The cost of one pair of frames (windows reaching outside a clip hold its end frames)."""
    joints = shared_joints(ba, bb)
    return float(_pair_costs(_windows(ba, [a_frame], joints), _windows(bb, [b_frame], joints))[0])


def ground_fit(ba, bb, a_frame, b_frame):
    """(angle, shift): the turn about up (radians) and ground translation (leg lengths, ground frame of the bodies)
    that carry B's window at ``b_frame`` onto A's at ``a_frame``: ``p_a ~ R(angle) p_b + shift``."""
    joints = shared_joints(ba, bb)
    frames_a = a_frame + _offsets(ba.fps)
    frames_b = b_frame + _offsets(bb.fps)
    pa = ba.at(frames_a, joints)[0][..., :2].reshape(-1, 2)
    pb = bb.at(frames_b, joints)[0][..., :2].reshape(-1, 2)
    ma, mb = pa.mean(axis=0), pb.mean(axis=0)
    a, b = pa - ma, pb - mb
    C = np.sum(a * b)
    S = np.sum(a[:, 1] * b[:, 0] - a[:, 0] * b[:, 1])
    angle = float(np.arctan2(S, C))
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    return angle, ma - R @ mb
