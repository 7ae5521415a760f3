"""Chains between written joints (``share_chains``): when a motion is written onto a rig whose chain between two
written joints holds bones the motion has no joint for (a Mixamo ``Spine1`` under a source with two spine bones, a
second neck bone), those bones share the chain's rotation instead of keeping their rest: the rotation from the
upper written joint to the lower one is split in equal steps (one geodesic step per bone) over the bones between
them and the lower joint, so the lower joint keeps its orientation. See docs/rigs.md, "Chains between joints".
"""

from typing import Dict, Iterable, List, Mapping, Optional, Sequence

import numpy as np

from ..geometry import so3

__all__ = ["chains_between", "share_chains"]


def chains_between(bones: Sequence[str], parents: Mapping[str, Optional[str]], written: Iterable[str],
                   free: Iterable[str]) -> Dict[str, List[str]]:
    """{lower written bone: [bones between it and the nearest written ancestor, top first]} for the chains whose
    bones are all ``free`` (held by the rig, no motion of their own); chains without a written ancestor and empty
    chains are left out. ``parents``: the rig's hierarchy (bones it lacks are skipped upwards)."""
    held, written, free = set(bones), set(written), set(free)
    out = {}
    for b in bones:
        if b not in written:
            continue
        chain, p, seen = [], parents.get(b), {b}
        while p is not None and p not in written and p not in seen:
            seen.add(p)
            if p in held:
                chain.append(p)
            p = parents.get(p)
        if p is None or p not in written or not chain or not all(c in free for c in chain):
            continue
        out[b] = chain[::-1]
    return out


def share_chains(X: np.ndarray, bones: Sequence[str], chains: Mapping[str, List[str]]) -> np.ndarray:
    """Local rotations ``X`` (frames, bones, 3, 3; armature axes, ``X_b = W_parent^T W_b``) with each chain of
    ``chains`` (``chains_between``) sharing the rotation its lower bone carries: with ``Q = X_lower`` (the chain's
    bones at rest, so ``Q`` is the whole rotation from the upper written joint to the lower one), every chain bone
    and the lower bone take ``exp(log(Q) / (n + 1))``; their product is ``Q`` again, so the lower bone's
    orientation (and everything under it) is unchanged."""
    X = X.copy()
    index = {b: i for i, b in enumerate(bones)}
    for lower, chain in chains.items():
        q = so3.log(X[:, index[lower]])
        step = so3.exp(q / (len(chain) + 1))
        for b in chain + [lower]:
            X[:, index[b]] = step
    return X
