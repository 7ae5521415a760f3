"""Figures (matplotlib, Agg backend, imported only when a figure is drawn): MDS scatter plots and
dendrograms coloured by class."""

from .embedding import linkage_matrix, mds
from .scores import class_order

__all__ = ["pyplot", "class_styles", "plot_mds", "plot_dendrogram"]

_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:orange", "tab:purple", "tab:brown", "tab:pink",
            "tab:gray", "tab:olive", "tab:cyan")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")


def pyplot():
    """matplotlib.pyplot with the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def class_styles(labels):
    """``{class: (colour, marker)}`` in order of first appearance."""
    return {c: (_COLOURS[i % len(_COLOURS)], _MARKERS[i % len(_MARKERS)]) for i, c in enumerate(class_order(labels))}


def plot_mds(D, names, labels, path, title="MDS", annotate=True, coords=None):
    """Scatter plot of the 2-D metric MDS of D, coloured by label; returns ``path``."""
    plt = pyplot()
    X = mds(D, 2) if coords is None else coords
    labels = list(labels) if labels is not None else ["clip"] * len(names)
    styles = class_styles(labels)
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for c, (col, mark) in styles.items():
        idx = [i for i, l in enumerate(labels) if l == c]
        ax.scatter(X[idx, 0], X[idx, 1], c=col, marker=mark, label=c, s=36, edgecolors="k", linewidths=0.4)
    if annotate and len(names) <= 60:
        for i, n in enumerate(names):
            ax.annotate(n, (X[i, 0], X[i, 1]), fontsize=6, xytext=(3, 3), textcoords="offset points", alpha=0.75)
    ax.set_title(title)
    ax.set_aspect("equal", adjustable="datalim")
    if len(styles) > 1:
        ax.legend(fontsize=8, loc="best")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_dendrogram(D, names, labels, path, title="Dendrogram", method="average"):
    """Dendrogram (scipy, average linkage) with leaf labels coloured by class; returns ``path``."""
    plt = pyplot()
    from scipy.cluster.hierarchy import dendrogram

    Z = linkage_matrix(D, method)
    labels = list(labels) if labels is not None else None
    leaf_names = [f"{n} ({l})" for n, l in zip(names, labels)] if labels else list(names)
    fig, ax = plt.subplots(figsize=(max(6.4, 0.28 * len(names) + 2), 4.8))
    dendrogram(Z, labels=leaf_names, ax=ax, leaf_rotation=90, leaf_font_size=7, color_threshold=0,
               above_threshold_color="0.35")
    if labels:
        styles = class_styles(labels)
        by_name = dict(zip(leaf_names, labels))
        for tick in ax.get_xticklabels():
            tick.set_color(styles[by_name[tick.get_text()]][0])
    ax.set_title(title)
    ax.set_ylabel("distance")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
