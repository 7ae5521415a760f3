"""What an evaluation writes: matrices (CSV with names + .npy), ``summary.json`` and ``report.md``
(accuracy table and one confusion table per metric)."""

import csv
import json
import os
import re

import numpy as np

from ..core.measure_words import metric_phrase
from .scores import format_confusion

__all__ = ["safe_name", "write_matrix", "write_summary", "format_report"]


def safe_name(name):
    """A metric name as a file stem ('sim3+elastic5' -> 'sim3_elastic5')."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def write_matrix(D, names, out_dir, stem="matrix"):
    """Write ``stem.csv`` (header row and first column = names) and ``stem.npy``; returns their paths."""
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, f"{stem}.csv")
    npy_path = os.path.join(out_dir, f"{stem}.npy")
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["clip"] + list(names))
        for n, row in zip(names, np.asarray(D)):
            w.writerow([n] + [repr(float(v)) for v in row])
    np.save(npy_path, np.asarray(D, dtype=np.float64))
    return {"csv": csv_path, "npy": npy_path}


def format_report(summary):
    """``report.md``'s text: one line per metric (its name and its words, ``core.measure_words``; 1-NN accuracy,
    mAP, silhouette, seconds), then every metric's confusion table."""
    n = summary["clips"]
    classes = summary["classes"]
    lines = ["# Evaluation summary", "", f"{n} clips, classes: {', '.join(classes)}", "",
             "| metric | measure | 1-NN accuracy | mAP | silhouette | seconds |", "|---|---|---|---|---|---|"]
    sections = []
    for name, row in summary["metrics"].items():
        extra = " | ".join(f"{row[k]:.3f}" if k in row else "" for k in ("map", "silhouette"))
        lines.append(f"| {name} | {metric_phrase(name)} | {row['accuracy']:.3f} ({row['correct']}/{n}) | {extra} | "
                     f"{row['seconds']:.2f} |")
        table = format_confusion(row["confusion"]["classes"], row["confusion"]["table"])
        sections.append(f"## {name} ({metric_phrase(name)})\n\n1-NN accuracy {row['accuracy']:.3f} "
                        f"({row['correct']}/{n}), "
                        f"{row['seconds']:.2f} s\n\n{table}\n")
    return "\n".join(lines) + "\n\n" + "\n".join(sections)


def write_summary(summary, out_dir):
    """Write ``summary.json`` and ``report.md`` into ``out_dir``; returns their paths."""
    paths = {"json": os.path.join(out_dir, "summary.json"), "report": os.path.join(out_dir, "report.md")}
    with open(paths["json"], "w", encoding="utf-8") as fh:
        json.dump(summary, fh, indent=1)
    with open(paths["report"], "w", encoding="utf-8") as fh:
        fh.write(format_report(summary))
    return paths
