#!/usr/bin/env python
"""Ranking on the rig data set from the command line: 1-NN by label, leave-one-out, over its humanoid clips.

  .venv/bin/python experiments/rank_rigs.py --data ../shared/data/rigs [--cache DIR] [--metric local|sim3|...]
      [--extra FILE,LABEL ...] [--markdown]

Reads ``index.csv`` under ``--data`` (``file,label,family,...``; ``file`` may be ``FILE#ANIMATION``). Every humanoid
clip (families other than ``nonhuman``, files the readers can read) whose label another clip shares queries a
library of all the other humanoid clips through the command line's ``rank`` (in this process: ``cli.main``, the
default search unless ``--metric``, JSON rows), and counts whether its first result has its label; per class and
in all, with the first result of each query. ``--extra FILE,LABEL`` adds clips outside the data set (the same
take in another format, e.g. a CMU BVH beside the AMASS ``CMU_01_01.npz``).
"""

import argparse
import contextlib
import csv
import io
import json
import os
import sys
from collections import Counter, defaultdict

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from blender_shapesig.cli import main as cli_main  # noqa: E402


def humanoid_rows(data, extra=()):
    """[(path, label, family)] of the humanoid clips of ``data/index.csv`` the readers can read (probed by
    ``rank`` itself: a clip it refuses is left out), plus ``extra``."""
    with open(os.path.join(data, "index.csv"), newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh) if r["family"] != "nonhuman"]
    out = [(os.path.join(data, r["file"]), r["label"], r["family"]) for r in rows]
    out += [(p, lab, "extra") for p, lab in extra]
    return out


def rank_json(query, library, args):
    argv = ["rank", query, *library, "--json", "--no-progress", "--cache", args.cache]
    if args.metric:
        argv += ["--metric", args.metric]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli_main(argv)
    if code != 0:
        return None, err.getvalue().strip().splitlines()[-1:]
    return json.loads(out.getvalue()), err.getvalue().strip().splitlines()


def address(row):
    return row["path"] + (f"#{row['action']}" if row.get("action") else "")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", required=True, help="the rig data folder (with index.csv)")
    p.add_argument("--cache", default=os.path.join(ROOT, "out", "rank_rigs_cache"), help="signature cache folder")
    p.add_argument("--metric", default=None, help="rank's --metric (default: its default search)")
    p.add_argument("--extra", action="append", default=[], metavar="FILE,LABEL", help="a clip outside the data set")
    p.add_argument("--markdown", action="store_true", help="print the per-class table as Markdown")
    args = p.parse_args(argv)
    extra = [tuple(e.rsplit(",", 1)) for e in args.extra]
    rows = humanoid_rows(args.data, extra)
    # which clips rank can read: ranking the first against all (a refused file is a warning, no row)
    probe, _warn = rank_json(rows[0][0], [r[0] for r in rows[1:]], args)
    readable = {os.path.abspath(address(r)) for r in probe["results"]} | {os.path.abspath(rows[0][0])}
    label_of = {}
    for path, label, family in rows:
        a = os.path.abspath(path)
        if a in readable or os.path.abspath(path.split("#")[0]) in readable:
            label_of[a] = (label, family)
    counts = Counter(lab for lab, _f in label_of.values())
    per = defaultdict(lambda: [0, 0])
    lines = []
    for q, (label, family) in label_of.items():
        if counts[label] < 2:
            continue
        library = [x for x in label_of if x != q]
        got, _warn = rank_json(q, library, args)
        if got is None or not got["results"]:
            lines.append(f"{os.path.relpath(q, args.data)}: no result")
            per[label][1] += 1
            continue
        first = got["results"][0]
        key = os.path.abspath(address(first))
        nl = label_of.get(key, label_of.get(os.path.abspath(first["path"]), ("?", "?")))
        ok = nl[0] == label
        per[label][0] += ok
        per[label][1] += 1
        lines.append(f"{'+' if ok else '-'} {os.path.relpath(q, args.data)} ({label}) -> "
                     f"{os.path.relpath(key, args.data)} ({nl[0]}, {nl[1]}) {first['distance']:.3g}")
    print("\n".join(lines))
    hit, total = sum(v[0] for v in per.values()), sum(v[1] for v in per.values())
    if args.markdown:
        print("\n| class | queries | 1-NN same label |\n|---|---|---|")
        for label, (h, n) in sorted(per.items(), key=lambda kv: -kv[1][1]):
            print(f"| {label} | {n} | {h}/{n} |")
        print(f"| **all** | **{total}** | **{hit}/{total} ({hit / total:.0%})** |")
    else:
        print(f"1-NN by label: {hit}/{total}", dict(per))


if __name__ == "__main__":
    main()
