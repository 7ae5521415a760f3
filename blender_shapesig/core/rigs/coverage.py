"""Coverage of a comparison: the joints compared over the canonical joints both rigs have (``joint_coverage``), the
limb chains compared (``chains_covered``), the report of two clips (``coverage_report`` / ``coverage_from``) and
the rule below which comparisons and blends refuse (``MIN_COVERAGE``, ``below_minimum``). See docs/rigs.md.
"""

from typing import Iterable, List, Mapping, Tuple

from ..clip.clip import Clip
from .detect import LIMB_CHAINS
from .names import JOINTS

__all__ = ["MIN_COVERAGE", "moving_count", "joint_coverage", "chains_covered", "coverage_from", "below_minimum",
           "coverage", "coverage_report"]

# below this coverage (joints compared / canonical joints both rigs have; limb chains compared / limb chains both
# rigs have) comparisons and blends refuse
MIN_COVERAGE = 0.5


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
