"""The library report of ``dedupe``: ``report.json`` and a self-contained ``report.html`` (the clusters, the
distances of every pair in each, one PNG per cluster embedded as a data URI, the near misses, the skipped
sources). matplotlib (Agg, through ``evaluation.plots.pyplot``) is imported only when plots are drawn."""

import base64
import html
import io
import json
import os

import numpy as np

from ..core.search.dedupe_keeper import choose_keeper, copy_facts
from ..core.measure_words import MEASURES
from ..core.io.sources import clip_address
from ..core.io.text import plot_name

__all__ = ["write_report", "clip_label", "speed_trace", "PAIR_HEADERS"]

NEAR_MISSES = 20
# the pair tables' headers: the measures' columns (core.measure_words), for the JSON keys sim, elastic, relative, take
PAIR_HEADERS = ("a", "b") + tuple(MEASURES[key].column for key in ("sim", "elastic", "relative", "take")) + (
    "near-duplicate",)


def clip_label(item, entry):
    """The path of a clip as given (``FILE#ACTION`` for a clip of a whole file that holds several)."""
    text = item.source or item.path or entry.name
    if item.path and item.action is None:
        return clip_address(item.path, entry.name, entry.source)[0]
    return text


def speed_trace(entry):
    """``(seconds, speed)``: the clip's summed joint angular speed (rad/s) per frame interval, from its
    increments: a time signature of the motion that re-timed and trimmed copies share up to a warp."""
    inc = np.asarray(entry.increments, np.float64)
    speed = np.linalg.norm(inc, axis=-1).sum(axis=1) * entry.fps
    t = (np.arange(speed.size) + 0.5) / entry.fps
    return t, speed


def _cluster_png(members, entries, labels):
    """Two panels: each member's joint speed on its own seconds, and its time map onto the first member
    (``core.search.dedupe_check.time_map``: the diagonal for a copy, a curve for a re-timed or trimmed one)."""
    from ..core.search.dedupe_check import time_map
    from ..core.errors import ShapeSigError
    from ..evaluation.plots import pyplot

    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.6, 2.8), gridspec_kw={"width_ratios": [2, 1]})
    first = members[0]
    for n in members:
        t, s = speed_trace(entries[n])
        line, = ax.plot(t, s, lw=1.0, label=plot_name(os.path.basename(labels[n])[:40]))
        try:
            ta, tb = time_map(entries[first], entries[n])
        except ShapeSigError:
            continue
        bx.plot(ta, tb, lw=1.2, color=line.get_color())
    ax.set_xlabel("seconds")
    ax.set_ylabel("joint speed (rad/s)")
    ax.legend(fontsize=7, loc="upper right")
    bx.set_xlabel(f"seconds of {plot_name(os.path.basename(labels[first])[:24])}")
    bx.set_ylabel("matched seconds")
    bx.set_title("time map (elastic alignment)", fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _pair_row(e, labels, result, clustered=True):
    """A checked pair: its distances, whether it passed, and else which test it failed (``DedupeResult.failed``;
    a pair that passed but sits in two clusters failed the complete linkage)."""
    row = {"a": labels[e.i], "b": labels[e.j], "sim": _num(e.sim), "elastic": _num(e.elastic),
           "relative": _num(e.relative), "take": _num(e.take), "confirmed": bool(result.confirmed(e))}
    row["failed"] = result.failed(e) or ("" if clustered else "complete linkage: a member of the other's cluster "
                                                              "differs from it")
    return row


def _num(x):
    return None if x is None or not np.isfinite(x) else float(x)


def _fmt(x):
    return "-" if x is None else f"{x:.4g}"


def _strip_uri(item, name, store):
    """The clip's picture of key poses (``core.search.thumbnails``) as base64 PNG, or its one-line reason."""
    from ..core.errors import ShapeSigError
    from ..core.search.thumbnails import picture_bytes

    try:
        return base64.b64encode(picture_bytes(item, store, name)).decode("ascii"), ""
    except ShapeSigError as exc:
        return None, str(exc)


def write_report(out_dir, pairs, entries, result, info, plots=True, store=None):
    """Write ``report.json`` and ``report.html`` into ``out_dir``; returns the JSON dict (with the paths). Each
    cluster names the copy to keep (``choose_keeper``) and shows each clip's strip of key poses (made through
    ``store``, the signature cache, when given)."""
    labels = [clip_label(item, e) for item, e in pairs]
    pair_of = {(e.i, e.j): e for e in list(result.edges) + list(result.extra) if e.relative is not None}
    html_path = os.path.join(out_dir, "report.html")
    clusters = []
    for members in result.clusters:
        inside = [pair_of[(a, b)] for x, a in enumerate(members) for b in members[x + 1:] if (a, b) in pair_of]
        keeper, reasons = choose_keeper([entries[n] for n in members])
        clusters.append({"members": [labels[n] for n in members],
                         "pairs": [_pair_row(e, labels, result) for e in inside],
                         "keep": {"clip": labels[members[keeper]], "reasons": reasons},
                         "facts": [copy_facts(entries[n]) for n in members]})
    checked = sorted(pair_of.values(), key=lambda e: (e.relative, e.sim))
    cluster_of = {n: c for c, members in enumerate(result.clusters) for n in members}
    together = {(e.i, e.j): cluster_of.get(e.i, -1 - e.i) == cluster_of.get(e.j, -2 - e.j) for e in checked}
    misses = [_pair_row(e, labels, result, together[(e.i, e.j)]) for e in checked
              if not together[(e.i, e.j)]][:NEAR_MISSES]
    biggest = max((len(c) for c in result.clusters), default=0)
    out = {"clusters": [c["members"] for c in clusters], "report": html_path,
           "json": os.path.join(out_dir, "report.json"), "clips": len(entries), "all_clips": labels,
           "largest_cluster_share": biggest / len(entries) if entries else 0.0,
           "sim_threshold": result.sim_threshold, "threshold": result.threshold, "rule": result.rule,
           "checked_pairs": len(pair_of), "graph_edges": len(result.edges), "linkage_checks": len(result.extra),
           "chain_components": [[labels[n] for n in c] for c in result.components],
           "cluster_pairs": [c["pairs"] for c in clusters], "keep": [c["keep"] for c in clusters],
           "near_misses": misses, **info}
    images = [_cluster_png(m, entries, labels) if plots else None for m in result.clusters]
    for c, members in zip(clusters, result.clusters):  # a strip of key poses per clip (data URIs)
        c["strips"] = [_strip_uri(pairs[n][0], entries[n].name, store) for n in members]
    # both files complete under temporary names, then renamed: never a report.json without its report.html
    # (names that are not UTF-8 are kept as \udcNN escapes in both files)
    written = []
    try:
        for path, text in ((out["json"], json.dumps(out, indent=1)), (html_path, _html(out, clusters, images, labels))):
            tmp = os.path.join(out_dir, f".{os.path.basename(path)}.shapesig-{os.getpid()}.tmp")
            written.append((tmp, path))
            with open(tmp, "w", encoding="utf-8", errors="backslashreplace") as f:
                f.write(text)
        for tmp, path in written:
            os.replace(tmp, path)
    finally:
        for tmp, _path in written:
            if os.path.exists(tmp):
                os.remove(tmp)
    return out


def _shortener(labels):
    """``short(label)``: the label relative to the folder all labels share (the report names it once)."""
    files = [os.path.abspath(x.split("#")[0]) for x in labels]
    try:
        root = os.path.commonpath(files) if len(files) > 1 else os.path.dirname(files[0]) if files else ""
    except ValueError:  # paths on different drives
        root = ""
    if root in files:
        root = os.path.dirname(root)
    if root and os.path.dirname(root) == root:  # only the filesystem root in common: full paths read better
        root = ""

    def short(label):
        path = os.path.abspath(label.split("#")[0])
        return os.path.relpath(path, root) + label[len(label.split("#")[0]):] if root else label

    return root, short


def _table(rows, short):
    head = "<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in PAIR_HEADERS) + "</tr>"
    body = "".join(f"<tr><td>{html.escape(short(r['a']))}</td><td>{html.escape(short(r['b']))}</td>"
                   f"<td>{_fmt(r['sim'])}</td><td>{_fmt(r['elastic'])}</td><td>{_fmt(r['relative'])}</td>"
                   f"<td>{_fmt(r.get('take'))}</td><td>{'yes' if r['confirmed'] and not r.get('failed') else 'no'}"
                   f"{(': ' + html.escape(r['failed'])) if r.get('failed') else ''}</td></tr>" for r in rows)
    return f"<table>{head}{body}</table>"


def _members(c, short):
    """The cluster's clips: name, length, rate, trim and the strip of key poses of each."""
    e = html.escape
    rows = []
    for m, f, (uri, why) in zip(c["members"], c["facts"], c.get("strips") or [(None, "")] * len(c["members"])):
        pic = (f"<img alt='key poses of {e(short(m))}' src='data:image/png;base64,{uri}'>" if uri
               else e(why or "no picture"))
        keep = " (keep)" if m == c["keep"]["clip"] else ""
        rows.append(f"<tr><td>{e(short(m))}{keep}</td><td>{f['seconds']:.2f} s</td><td>{f['fps']:.0f}</td>"
                    f"<td>{f['trimmed']}</td><td>{pic}</td></tr>")
    return ("<table><tr><th>clip</th><th>length</th><th>fps</th><th>frames trimmed</th><th>key poses</th></tr>"
            + "".join(rows) + "</table>")


def _html(out, clusters, images, labels):
    e = html.escape
    root, short = _shortener(labels)
    secs = ", ".join(f"{k} {v:.1f} s" for k, v in out["seconds"].items())
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Library report</title><style>"
        "body{font-family:sans-serif;margin:2em;max-width:70em}table{border-collapse:collapse;margin:.5em 0}"
        "td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}th{background:#eee}</style></head><body>",
        "<h1>Library report: near-duplicates</h1>",
        (f"<p>{out['clips']} clips in <code>{e(root)}</code> (paths below are relative to it), " if root
         else f"<p>{out['clips']} clips, ") + f"{len(clusters)} "
        f"clusters (largest: {out['largest_cluster_share']:.0%} of the library), {out['graph_edges']} k-NN edges "
        f"(k = {out['k']}), {out['checked_pairs']} pairs checked by the {MEASURES['elastic'].status}. "
        f"Scheduler: {e(out['scheduler'])}; "
        f"{secs}.</p>",
        f"<p>Rule: {e(out['rule'])}. Clusters: complete linkage (every pair in a cluster passes both gates). "
        "Plots: each member's joint speed over its own seconds, and its time map onto the first member (the "
        "elastic alignment: a straight line for a copy, a curve for a re-timed one).</p>",
    ]
    for n, (c, img) in enumerate(zip(clusters, images), 1):
        parts.append(f"<h2>Cluster {n} ({len(c['members'])} clips)</h2>")
        parts.append(f"<p><b>Keep {e(short(c['keep']['clip']))}</b>: {e('; '.join(c['keep']['reasons']))}.</p>")
        parts.append(_members(c, short))
        if img:
            parts.append(f"<img alt='joint speed and time map of each member' src='data:image/png;base64,{img}'>")
        parts.append(_table(c["pairs"], short))
    parts.append("<h2>Near misses (checked, not near-duplicates)</h2>" + _table(out["near_misses"], short))
    if out["skipped"]:
        parts.append("<h2>Skipped sources</h2><ul>" + "".join(f"<li>{e(s)}</li>" for s in out["skipped"])
                     + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)
