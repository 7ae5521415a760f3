"""The local search's entries as types: ``LocalEntry`` (one clip's compact arrays and what a row needs to name it),
``Refusal`` (a clip the local features cannot read, and the one line why) and ``Take`` (the whole take's
signature, ``take.take_entry``; a ``LocalEntry`` carries the same three fields). Every entry has ``refused``: ""
for an entry, the reason for a refusal. The store keeps them (``local.store``), the library file maps their arrays
(``local.library``). See docs/search.md, "One engine shape".
"""

from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

__all__ = ["LocalEntry", "Refusal", "Take", "ARRAYS", "JOINT_LISTS", "meta_fields"]

# an entry's arrays and their types on disk (an older recipe's entries lack the optional ones: None)
ARRAYS = {"windows": np.float16, "sequence": np.float16, "path": np.float32, "take": np.float32,
          "take_mask": np.uint8, "describe": np.float32}
# the joint lists a row's coverage is computed from (``rigs.coverage_from``)
JOINT_LISTS = ("joints", "still", "rig_joints")


@dataclass(eq=False)
class Take:
    """``take`` (take.DIM,) float32: the whole take's level-2 log-signature; ``take_mask`` (len(take.JOINTS),)
    uint8: the canonical joints it has; ``seconds``: its span."""

    take: np.ndarray
    take_mask: np.ndarray
    seconds: float


@dataclass(eq=False)
class LocalEntry:
    """One clip's entry: ``windows`` (N, DIM) float16, the windows' descriptors (the first stage); ``sequence``
    (T', C) float16, the pose every few samples (the second stage); ``path`` (10,) float32, the whole clip's path;
    ``describe`` (description.PARTS,) float32, what happens in it; the whole take (``take``, ``take_mask``,
    ``seconds``: ``Take``'s); the clip's ``name``, ``frames``, ``first`` frame (None in older entries), ``bones``,
    ``trimmed`` (``trim_record``) and
    joint lists (``JOINT_LISTS``). ``rows``: where its arrays lie in the library file it was read from (its id,
    first and end window row, clip row), else None. Optional arrays are None in an older recipe's entries."""

    windows: np.ndarray
    sequence: np.ndarray
    path: np.ndarray
    describe: Optional[np.ndarray] = None
    take: Optional[np.ndarray] = None
    take_mask: Optional[np.ndarray] = None
    seconds: float = 0.0
    name: str = ""
    frames: int = 0
    first: Optional[int] = None
    bones: int = 0
    trimmed: Tuple[int, ...] = ()
    joints: Tuple[str, ...] = ()
    still: Tuple[str, ...] = ()
    rig_joints: Tuple[str, ...] = ()
    rows: Optional[tuple] = field(default=None, repr=False)

    refused = ""  # not a field: a refusal's says why

    def arrays(self) -> dict:
        """{name: array} of the arrays it has (``ARRAYS``' names)."""
        return {k: getattr(self, k) for k in ARRAYS if getattr(self, k) is not None}

    def nbytes(self) -> int:
        return int(sum(np.asarray(v).nbytes for v in self.arrays().values()))


@dataclass(frozen=True, eq=False)
class Refusal:
    """A clip the local features refuse (``name``), and the one line why (``refused``)."""

    name: str
    refused: str


def meta_fields(meta) -> dict:
    """``LocalEntry``'s fields other than its arrays and ``seconds`` from the entry's stored ``meta`` (an entry
    file's or the library file's): name, frames, ``first`` (None when an older entry has none), bones, trimmed and
    the joint lists."""
    first = meta.get("first")
    lists = {k: meta.get(k, ()) for k in JOINT_LISTS}  # (a library file's are tuples already)
    return dict(name=meta["name"], frames=int(meta.get("frames", 0)),
                first=int(first) if isinstance(first, int) and not isinstance(first, bool) else None,
                bones=int(meta.get("bones", 0)), trimmed=tuple(int(f) for f in meta.get("trimmed", ())),
                **{k: v if isinstance(v, tuple) else tuple(str(j) for j in v) for k, v in lists.items()})
