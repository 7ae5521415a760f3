"""The search's engines, measures and options in an animator's words: the one source of every name the panel, the
operators' reports, the results' status lines, the settings' tooltips, the command line's help and text output,
the dedupe report's headers and the demo report show for them (``ENGINES``, ``MEASURES``, ``OPTIONS``: a ``Words``
each, keyed by its id, for an engine and a measure the metric's base name; ``measure_words`` for a results column,
``metric_words`` and ``metric_phrase`` for a metric name; ``PANEL_NAME``). Labels, column headers, status words and descriptions never
hold a thesis symbol (sim^n, d_S*, ...): those are in the tooltips (``Words.tooltip``) and the docs only
(``Words.symbol``; ``SYMBOLS`` finds them). See docs/search.md."""

from dataclasses import dataclass

from .metric_names import parse_metric_spec

__all__ = ["Words", "ENGINES", "MEASURES", "OPTIONS", "PANEL_NAME", "measure_words", "metric_words",
           "metric_phrase", "SYMBOLS", "THESIS_SYMBOLS"]

# the sidebar panel's name
PANEL_NAME = "Motion Search"


@dataclass(frozen=True)
class Words:
    """What a person reads of one engine, measure or option."""

    key: str           # its id (an engine's or a measure's: the metric's base name, public: never renamed)
    label: str         # its name on a button, an option or a value line ("Similarity")
    column: str        # a results column's header (short)
    status: str        # in a sentence: "sorted by <status>"
    tooltip: str       # its tooltip (may name the thesis' symbol)
    description: str   # one line for the command line's help and the reports (no symbol)
    symbol: str = ""   # the thesis' symbol: tooltips and docs only

    @property
    def short(self) -> str:
        """The label without its parenthesis ("Motion and pose (default)" -> "Motion and pose")."""
        return self.label.split(" (")[0]


def _table(*words):
    return {w.key: w for w in words}


# what Find Similar calls the same motion (the panel's Similarity choice, and Moments)
ENGINES = _table(
    Words(
        "local", "Motion and pose (default)", "Score", "motion and pose",
        "The local search: windows of the body's key-point positions and motion, each described by its mean pose and "
        "its level-2 log-signature normalized part by part (the normalized log-signature similarity, eq. 9.1, window "
        "by window), then the best 20 re-scored by dynamic time warping of the pose; across rigs, crops and start "
        "phases; the same take in another file first (its whole-take log-signature)",
        "the same motion and pose anywhere in the clips, window by window, across rigs, crops and start phases; the "
        "best 20 re-scored by time-warping the poses; the same take in another file first"),
    Words(
        "sim", "Motion only (signatures)", "Similarity", "motion only",
        "sim^n: the normalized log-signature similarity (eq. 9.1) of the whole clips' joint rotations at Detail n, "
        "optionally re-ranked by the elastic distance d_S* (Timing Check); motion only, whole clips",
        "whole clips compared by the log-signatures of their joint rotations, without the pose", "sim^n"),
    Words(
        "moments", "Moments", "Similarity", "moments",
        "Rank moments inside the clips: every place a take does the motion, by pose and motion (a free-window DTW "
        "of the local search's key points, refined by the elastic distance d_S* inside each window; clips without "
        "legs: the level-2 signature similarity sim^2); Assign, Preview and Blend use the window",
        "every place inside the clips where a take does the query's motion, each with its frames", "sim^2"),
)

# the numbers in the results' columns: the command line's measures (every metric base of core.metric_names), and
# dedupe's relative timing-aligned difference and whole takes' distance (the same-take test)
MEASURES = _table(
    Words("local", "Score", "Score", "score",
          "How different the motion and pose are (0: the same): the local search's score, its window "
          "distance combined with the dynamic time warping of the pose",
          "the local search's score: its window distance combined with the time-warped pose distance (0: the same)"),
    Words("sim", "Similarity", "Similarity", "similarity",
          "How different the motions are (0: the same): the normalized log-signature distance sim^n "
          "(eq. 9.1; sim^2 for moments)",
          "the normalized log-signature distance of the whole clips' joint rotations (0: the same)", "sim^n"),
    Words("elastic", "Timing-aligned difference", "Timing-aligned", "timing-aligned difference",
          "How different the motions are once their timing is aligned: the elastic distance d_S* "
          "(computed for the best rows by Timing Check)",
          "how different the motions are once their timing is aligned (an elastic alignment)", "d_S*"),
    Words("l2", "Frame-by-frame difference", "Frame-by-frame", "frame-by-frame difference",
          "How different the motions are frame by frame, their timing not aligned: the L2 distance d_P* of their "
          "square-root velocity transforms",
          "how different the motions are frame by frame, their timing not aligned", "d_P*"),
    Words("group", "Signature difference (group)", "Group signature", "group signature difference",
          "The distance rho^n of the clips' signatures in the signature group (eqs. 8.1-8.3)",
          "the distance of the clips' signatures in the signature group", "rho^n"),
    Words("concat", "Signature difference (concatenated)", "Concatenated signature",
          "concatenated signature difference",
          "The log-concatenation distance sigma_*^n: the log-signatures of each clip followed by the other "
          "reversed (eq. 8.5)",
          "the log-signatures of each clip followed by the other reversed", "sigma_*^n"),
    Words("linear", "Signature difference (linear)", "Linear signature", "linear signature difference",
          "The linear distance sigma_L^n: the length of the difference of the clips' log-signatures (eq. 8.6)",
          "the length of the difference of the clips' log-signatures", "sigma_L^n"),
    Words("relative", "Relative timing-aligned difference", "Timing-aligned (relative)",
          "relative timing-aligned difference",
          "The timing-aligned difference over the pair's size: d_S* / sqrt(|q_0|^2 + |q_1|^2) of the clips' "
          "square-root velocity transforms, about 1 for unrelated motions (dedupe's copy test)",
          "the timing-aligned difference over the pair's size, about 1 for unrelated motions", "d_S*"),
    Words("take", "Whole-take difference", "Whole take", "whole-take difference",
          "How different the whole takes are: the distance of their level-2 log-signatures of the body's key points "
          "(the same-take test of the default search and of dedupe)",
          "how different the whole takes are (the same-take test)"),
)

# the search's options
OPTIONS = _table(
    Words("similarity", "Similarity", "Similarity", "similarity", "What Find Similar calls the same motion",
          "what Find Similar calls the same motion"),
    Words("level", "Detail", "Detail", "detail",
          "How fine the motion description is: the log-signature level n of the similarity sim^n (eq. 9.1); "
          "higher sees finer detail, costs more", "how fine the motion description is (the log-signature level)",
          "n"),
    Words("rerank", "Timing Check", "Timing Check", "timing check",
          "Re-order the best K by the timing-aligned difference (the elastic distance d_S*, 0: off)",
          "re-order the best K by the timing-aligned difference", "K"),
    Words("depth", "Timing Freedom", "Timing Freedom", "timing freedom",
          "How far the timing alignment may stretch in one step (the elastic DP search depth)",
          "how far the timing alignment may stretch in one step (the elastic search depth)", "D"),
)

# the thesis' symbols: no label, column header, status line, description or report holds one (tests/test_ui_words.py)
SYMBOLS = (r"sim\^", r"sim[²³⁴]", r"d_S", r"d_P", r"\bρ", r"σ", r"\brho\b", r"\bsigma", r"comparison space",
           r"eq\. \d", r"eqs\. \d")
# ... nor, inside Blender, a metric's name (sim3): the command line's ids are its user's own words (interfaces.md)
THESIS_SYMBOLS = SYMBOLS + (r"\bsim\d",)


def measure_words(column: str) -> Words:
    """The words of a results column (``ShapeSigResults.order_by``: a measure's key, "sim", "elastic" or "local")."""
    return MEASURES.get(column, MEASURES["sim"])


def metric_words(name) -> Words:
    """The words of a metric name ('sim3', 'elastic', 'sim3+elastic10': its first stage's measure, 'local')."""
    return MEASURES[parse_metric_spec(name).base]


def metric_phrase(name) -> str:
    """A metric name in words: 'local' -> its engine's ('Motion and pose'), 'sim3' -> 'Similarity',
    'sim3+elastic10' -> 'Similarity, the best 10 re-ranked by the timing-aligned difference'."""
    spec = parse_metric_spec(name)
    text = ENGINES[spec.base].short if spec.base == "local" else MEASURES[spec.base].label
    if spec.rerank:
        text += f", the best {spec.rerank} re-ranked by the {MEASURES['elastic'].status}"
    return text
