"""The experiment harness (outside the maths core): labelled clip sets from an index CSV (``index``), leave-one-out
1-NN (plain and two-stage), mAP, silhouette and confusion tables (``scores``), MDS / SMACOF / Procrustes and
linkage (``embedding``), figures (``plots``, matplotlib imported when a figure is drawn), reports (``report``) and
``evaluate`` (``run``). Distances come from ``core.pairwise``, metric names from ``core.metrics``.
See docs/evaluation.md.
"""

from .embedding import classical_mds, linkage_matrix, mds, procrustes_error, smacof
from .index import IndexEntry, cut_clip, entry_loader, entry_spec, labels_from_csv, read_index, readable_entries, unique_names
from .plots import class_styles, plot_dendrogram, plot_mds, pyplot
from .report import format_report, safe_name, write_matrix, write_summary
from .run import CROP_FRACTION, DEFAULT_METRICS, EXTRA_METRICS, evaluate, load_entries
from .scores import (check_square, class_order, confusion_table, format_confusion, loo_1nn,
                     mean_average_precision, silhouette, two_stage_1nn)

__all__ = [
    "DEFAULT_METRICS", "EXTRA_METRICS", "CROP_FRACTION", "cut_clip", "IndexEntry", "read_index", "unique_names", "labels_from_csv",
    "entry_spec", "entry_loader", "readable_entries", "load_entries", "check_square", "class_order", "loo_1nn", "two_stage_1nn",
    "mean_average_precision", "silhouette", "confusion_table", "format_confusion", "classical_mds", "smacof",
    "mds", "procrustes_error", "linkage_matrix", "pyplot", "class_styles", "plot_mds", "plot_dendrogram",
    "safe_name", "write_matrix", "write_summary", "format_report", "evaluate",
]
