"""The automatic bone map of every family of a rig data set, as the table of docs/rigs.md.

    .venv/bin/python tools/rig_table.py --data ../shared/data/rigs [--json]

Reads ``index.csv`` (``file,label,family,format,...``) under ``--data``, reads one clip of each family with the
package's readers (every format the reader registry knows: families whose files it cannot read are listed as
such) and prints per family: the bones, the canonical joints detected (of 22), the joints the rig's structure
does not have, where left and right came from, or the one-line refusal of a non-humanoid.
"""

import argparse
import csv
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from blender_shapesig.core import rigs  # noqa: E402
from blender_shapesig.core.errors import ShapeSigError, error_line  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402


def family_rows(data):
    """One row (dict) per family of ``data/index.csv``: its first readable clip's detection."""
    with open(os.path.join(data, "index.csv"), newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    firsts = {}
    for r in rows:
        firsts.setdefault((r["family"], os.path.dirname(r["file"].split("#")[0])), []).append(r)
    out = []
    for (family, folder), members in firsts.items():
        row = {"family": folder, "format": members[0]["format"], "clips": len(members)}
        for m in members:
            try:
                clip = sources.read(sources.ClipSpec.parse(os.path.join(data, m["file"]), bone_map="none",
                                                           trim="none"))[0]
            except (ShapeSigError, OSError) as exc:
                row["error"] = error_line(exc)
                continue
            report = rigs.analyse_clip(clip)
            got = set(report.mapping.values())
            row.pop("error", None)
            row.update(file=m["file"], bones=len(clip.bones), detected=len(got), has=len(report.joints),
                       absent=[j for j in rigs.JOINTS if j not in report.joints] if report.joints else [],
                       missed=report.unmapped, sides=report.sides, refusal=report.refusal)
            break
        out.append(row)
    return out


def markdown(rows):
    lines = ["| family | format | bones | detected | not in the rig | sides | result |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| `{r['family']}` | {r['format']} | | | | | not read here: {r['error']} |")
            continue
        if r["refusal"]:
            lines.append(f"| `{r['family']}` | {r['format']} | {r['bones']} | 0 | | | refused: {r['refusal']} |")
            continue
        absent = ", ".join(r["absent"]) or "—"
        lines.append(f"| `{r['family']}` | {r['format']} | {r['bones']} | {r['detected']} of 22 | {absent} | "
                     f"{r['sides']} | {r['detected']}/{r['has']} of its joints |")
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", required=True, help="the rig data folder (with index.csv)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = p.parse_args(argv)
    rows = family_rows(args.data)
    print(json.dumps(rows, indent=1) if args.json else markdown(rows))


if __name__ == "__main__":
    main()
