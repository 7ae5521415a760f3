"""Which copy of a near-duplicate cluster to keep (``dedupe``): what tells copies apart, from an index entry
(``copy_facts``: the clip's own frame rate, its length, the frames trimmed at its ends) and the rule that picks one
(``choose_keeper``: the longest, then the highest frame rate, then the least trimmed), with its reasons in words.
See docs/search.md, "Library report (dedupe)".
"""

from typing import Dict, List, Tuple

__all__ = ["KEEP_TIE", "COMMON_RATES", "copy_facts", "choose_keeper"]

_SAME = {"seconds": "length", "fps": "frame rate", "trimmed": "trim"}
# durations within this fraction of the longest are a tie (the next rule decides)
KEEP_TIE = 0.02


# the usual frame rates of motion files: a rate known to within the comparison time base's step snaps to one
COMMON_RATES = (24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 72.0, 90.0, 100.0, 120.0, 144.0, 180.0, 240.0, 250.0, 480.0)


def copy_facts(entry) -> Dict[str, float]:
    """What tells copies apart, from an index entry: ``fps`` (the clip's own rate), ``seconds`` (its length at that
    rate) and ``trimmed`` (rest-pose / ramp frames cut at its ends). The entry keeps the clip's frame count and the
    compared curve's, whose length is the clip's rounded down to the time base's step (1 / ``entry.fps``): the
    rate lies in an interval, and is the usual rate inside it (``COMMON_RATES``) when there is one."""
    step = 1.0 / entry.fps if entry.fps > 0 else 0.0
    lower = (entry.frames - 1) * step
    frames = entry.clip_frames or entry.frames
    if lower <= 0 or frames < 2:
        fps = 0.0
    else:
        lo, hi = (frames - 1) / (lower + step), (frames - 1) / lower
        usual = [r for r in COMMON_RATES if lo <= r <= hi]
        fps = min(usual, key=lambda r: abs(r - 0.5 * (lo + hi))) if usual else 0.5 * (lo + hi)
    t = tuple(entry.trimmed)
    trimmed = (t[0] - t[2]) + (t[3] - t[1]) if len(t) == 4 else 0
    return {"seconds": float((frames - 1) / fps) if fps else 0.0, "fps": float(fps), "trimmed": int(trimmed)}


def choose_keeper(entries) -> Tuple[int, List[str]]:
    """(index, reasons): the copy of a cluster to keep: the longest (durations within ``KEEP_TIE`` tie), then
    the highest frame rate (within 1 %), then the least trimmed; the reasons name the rule that decided and the
    ties before it, in words."""
    facts = [copy_facts(e) for e in entries]
    alive = list(range(len(entries)))
    reasons = []
    rules = (("seconds", "longest", lambda f: f"{f:.2f} s", KEEP_TIE, max),
             ("fps", "highest frame rate", lambda f: f"{f:.0f} fps", 0.01, max),
             ("trimmed", "least trimmed", lambda f: f"{f:.0f} frames cut", None, min))
    for key, word, fmt, tol, pick in rules:
        best = pick(facts[i][key] for i in alive)
        if tol is None:
            keep = [i for i in alive if facts[i][key] == best]
        else:
            keep = [i for i in alive if abs(facts[i][key] - best) <= tol * max(abs(best), 1e-9)]
        others = sorted({fmt(facts[i][key]) for i in alive if i not in keep})
        if others:
            reasons.append(f"{word}: {fmt(best)} (others {', '.join(others)})")
        elif len(alive) > 1:
            reasons.append(f"same {_SAME[key]} ({fmt(best)})")
        alive = keep
        if len(alive) == 1:
            break
    if len(alive) > 1:
        reasons.append("otherwise alike: the first in the library")
    return alive[0], reasons
