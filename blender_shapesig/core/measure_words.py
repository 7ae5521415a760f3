"""The search's engines, measures and options in an animator's words: the one source of every name the panel, the
operators' reports, the results' status lines, the settings' tooltips and the demo report show for them (``ENGINES``,
``MEASURES``, ``OPTIONS``: a ``Words`` each, keyed by the metric's base name; ``measure_words`` for a results
column; ``PANEL_NAME``). Labels, column headers and status words never hold a thesis symbol (sim^n, d_S*, ...):
those are in the tooltips (``Words.tooltip``) and the docs only (``Words.symbol``). See docs/search.md."""

from dataclasses import dataclass

__all__ = ["Words", "ENGINES", "MEASURES", "OPTIONS", "PANEL_NAME", "measure_words", "THESIS_SYMBOLS"]

# the sidebar panel's name
PANEL_NAME = "Motion Search"


@dataclass(frozen=True)
class Words:
    """What a person reads of one engine, measure or option."""

    label: str         # its name on a button, an option or a value line ("Similarity")
    column: str        # a results column's header (short)
    status: str        # in a sentence: "sorted by <status>"
    tooltip: str       # its tooltip (may name the thesis' symbol)
    symbol: str = ""   # the thesis' symbol: tooltips and docs only


# what Find Similar calls the same motion (the panel's Similarity choice, and Moments)
ENGINES = {
    "local": Words(
        "Motion and pose (default)", "Score", "motion and pose",
        "The local search: windows of the body's key-point positions and motion, each described by its mean pose and "
        "its level-2 log-signature normalized part by part (the normalized log-signature similarity, eq. 9.1, window "
        "by window), then the best 20 re-scored by dynamic time warping of the pose; across rigs, crops and start "
        "phases; the same take in another file first (its whole-take log-signature)", "local"),
    "sim": Words(
        "Motion only (signatures)", "Similarity", "motion only",
        "sim^n: the normalized log-signature similarity (eq. 9.1) of the whole clips' joint rotations at Detail n, "
        "optionally re-ranked by the elastic distance d_S* (Timing Check); motion only, whole clips", "sim^n"),
    "moments": Words(
        "Moments", "Similarity", "moments",
        "Rank moments inside the clips: every place a take does the motion, by pose and motion (a free-window DTW "
        "of the local search's key points, refined by the elastic distance d_S* inside each window; clips without "
        "legs: the level-2 signature similarity sim^2); Assign, Preview and Blend use the window", "sim^2"),
}

# the numbers in the results' columns
MEASURES = {
    "local": Words("Score", "Score", "score",
                   "How different the motion and pose are (0: the same): the local search's score, its window "
                   "distance combined with the dynamic time warping of the pose", "local score"),
    "sim": Words("Similarity", "Similarity", "similarity",
                 "How different the motions are (0: the same): the normalized log-signature distance sim^n "
                 "(eq. 9.1; sim^2 for moments)", "sim^n"),
    "elastic": Words("Timing-aligned difference", "Timing-aligned", "timing-aligned difference",
                     "How different the motions are once their timing is aligned: the elastic distance d_S* "
                     "(computed for the best rows by Timing Check)", "d_S*"),
}

# the search's options
OPTIONS = {
    "similarity": Words("Similarity", "Similarity", "similarity", "What Find Similar calls the same motion"),
    "level": Words("Detail", "Detail", "detail",
                   "How fine the motion description is: the log-signature level n of the similarity sim^n (eq. 9.1); "
                   "higher sees finer detail, costs more", "n"),
    "rerank": Words("Timing Check", "Timing Check", "timing check",
                    "Re-order the best K by the timing-aligned difference (the elastic distance d_S*, 0: off)", "K"),
    "depth": Words("Timing Freedom", "Timing Freedom", "timing freedom",
                   "How far the timing alignment may stretch in one step (the elastic DP search depth)", "D"),
}

# what no label, column header, status line or report may hold (tests/test_ui_words.py)
THESIS_SYMBOLS = (r"sim\^", r"sim[²³⁴]", r"\bsim\d", r"d_S", r"d_P", r"\bρ", r"σ", r"\brho\b", r"\bsigma\b",
                  r"comparison space", r"eq\. \d")


def measure_words(column: str) -> Words:
    """The words of a results column (``ShapeSigResults.order_by``: a measure's key, "sim", "elastic" or "local")."""
    return MEASURES.get(column, MEASURES["sim"])
