#!/usr/bin/env python
"""Move modules of blender_shapesig and rewrite every import of them (a one-off refactoring tool, re-runnable).

    python tools/dev/move_modules.py [--apply] [FILE ...]

MOVES maps old dotted module paths (below ``blender_shapesig``) to new ones. Without FILE arguments the moves are
made with ``git mv`` and every .py file of the repository is rewritten; with FILE arguments only those files are
rewritten (for code written against the old layout after the move, e.g. a merged branch). Relative imports are
resolved from the file's new place, else from its old place, and written relative again; absolute names
(``blender_shapesig.core.x``, also inside strings) are mapped; ``from P import m`` of a moved module ``m`` is
split per new package. Without ``--apply`` it prints what it would change.
"""
import argparse
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
PKG = "blender_shapesig"
# The Blender layer in rooms (issue 40); the earlier table (core in subpackages) is in this file's git history.
ROOMS = {
    "actions": ["action_io", "action_hashes", "action_changes", "action_spaces", "bone_channels", "owners",
                "frame_rates", "scene_motion", "control_rigs", "write_blend_file"],
    "search": ["library", "rig_library", "rank_job", "result_rows", "results", "thumbnails"],
    "rigs": ["rigmap", "retarget"],
    "blend": ["blend_actions", "transitions"],
}
MOVES = {name: f"{room}.{name}" for room, names in ROOMS.items() for name in names}
NEW_PACKAGES = list(ROOMS)
FILE_MOVES = {}  # old file -> new file (relative to the package folder), for files that are not modules


def module_file(mod):
    return mod.replace(".", "/") + ".py"


def old_modules():
    return set(MOVES)


def new_modules():
    """Every module of the package as it is (after the moves) on disk."""
    out = set()
    for p in (ROOT / PKG).rglob("*.py"):
        if "__pycache__" in p.parts:
            continue
        parts = list(p.relative_to(ROOT / PKG).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.add(".".join(parts))
    return out


def resolve(level, module, pkg_of_file):
    base = pkg_of_file.split(".") if pkg_of_file else []
    if level - 1 > len(base):
        return None
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([module] if module else []))


def relative(target, pkg_of_file):
    """``target`` (dotted, below the package) written relative to a file in package ``pkg_of_file``."""
    a = pkg_of_file.split(".") if pkg_of_file else []
    b = target.split(".") if target else []
    i = 0
    while i < len(a) and i < len(b) and a[i] == b[i]:
        i += 1
    return "." * (len(a) - i + 1) + ".".join(b[i:])


FROM_RE = re.compile(r"^(?P<indent>[ \t]*)from (?P<dots>\.+)(?P<mod>[\w.]*) import "
                     r"(?P<names>\([^)]*\)|[^\n#]*?)(?P<tail>[ \t]*(#[^\n]*)?)$", re.M)
ABS_FROM_RE = re.compile(r"^(?P<indent>[ \t]*)from " + PKG + r"(?:\.(?P<mod>[\w.]+))? import "
                         r"(?P<names>\([^)]*\)|[^\n#]*?)(?P<tail>[ \t]*(#[^\n]*)?)$", re.M)
# an import inside a code string, after a quote or "; " and up to ";", a quote or an escaped newline
INLINE_FROM_RE = re.compile(r"(?:(?<=[\"';])|(?<=\\n))(?P<lead> ?)from " + PKG + r"(?:\.(?P<mod>[\w.]+))? import "
                            r"(?P<names>[\w ,]+?)(?=;|[\"']|\\n)")
DOTTED_RE = re.compile(r"(?<![\w.])(?<!from )" + PKG + r"\.([A-Za-z_][\w]*(?:\.[A-Za-z_][\w]*)*)")


def split_names(names):
    inner = names.strip()
    if inner.startswith("("):
        inner = inner[1:-1]
    return [n.strip() for n in re.sub(r"#[^\n]*", "", inner).split(",") if n.strip()]


def known(mod, existing):
    return mod in MOVES or mod in existing


def groups_for(target, items, existing):
    """[(new module, [names])] for ``from target import items`` (target in the old or the new layout)."""
    groups = {}
    for item in items:
        name, _, alias = item.partition(" as ")
        name, alias = name.strip(), alias.strip()
        sub = f"{target}.{name}" if target else name
        if sub in MOVES:
            new_pkg, _, new_name = MOVES[sub].rpartition(".")
            if new_name != name and not alias:
                alias = name
            key, entry = new_pkg, new_name + (f" as {alias}" if alias else "")
        elif sub in existing:
            key, entry = target, item
        else:
            key, entry = MOVES.get(target, target), item
        groups.setdefault(key, []).append(entry)
    return list(groups.items())


def emit(m, groups, items, write_mod):
    """One ``from`` line per new package, the package itself first, then its subpackages by name; a ``noqa``
    comment is kept on every line."""
    if len(groups) == 1 and groups[0][1] == items:
        return m["indent"] + f"from {write_mod(groups[0][0])} import {m['names']}" + m["tail"]
    lines = [m["indent"] + f"from {write_mod(key)} import {', '.join(names)}"
             for key, names in sorted(groups, key=lambda g: (g[0] != "", g[0]))]
    if "noqa" in m["tail"]:
        return "\n".join(line + m["tail"] for line in lines)
    return "\n".join(lines) + m["tail"]


def rewrite_text(text, file_mod_new, file_mod_old, is_init, existing):
    pkg_new = file_mod_new if is_init else (file_mod_new or "").rpartition(".")[0]
    pkg_old = file_mod_old if is_init else (file_mod_old or "").rpartition(".")[0]

    def rel_sub(m):
        level, mod = len(m["dots"]), m["mod"]
        items = split_names(m["names"])
        cands = [resolve(level, mod, pkg_old), resolve(level, mod, pkg_new)] if pkg_old != pkg_new else \
            [resolve(level, mod, pkg_new)]
        target = next((t for t in cands if t is not None and known(t, existing)), None)
        if target is None:
            return m.group(0)
        out = emit(m, groups_for(target, items, existing), items, lambda k: relative(k, pkg_new))
        return out

    def abs_sub(m):
        items = split_names(m["names"])
        return emit(m, groups_for(m["mod"] or "", items, existing), items, lambda k: f"{PKG}.{k}" if k else PKG)

    def inline_sub(m):
        items = split_names(m["names"])
        groups = sorted(groups_for(m["mod"] or "", items, existing), key=lambda g: (g[0] != "", g[0]))
        if len(groups) == 1 and groups[0][1] == items:
            return m["lead"] + f"from {PKG}{'.' + groups[0][0] if groups[0][0] else ''} import {m['names']}"
        return m["lead"] + "; ".join(f"from {PKG}{'.' + k if k else ''} import {', '.join(names)}"
                                     for k, names in groups)

    def dotted_sub(m):
        parts = m.group(1).split(".")
        if ".".join(parts) in existing and ".".join(parts) not in MOVES:
            return m.group(0)
        for k in range(len(parts), 0, -1):
            prefix = ".".join(parts[:k])
            if prefix in MOVES:
                if k < len(parts):
                    nxt = f"{prefix}.{parts[k]}"
                    if nxt in existing and nxt not in MOVES:
                        return m.group(0)
                return f"{PKG}." + ".".join([MOVES[prefix]] + parts[k:])
        return m.group(0)

    if file_mod_new is not None:
        text = FROM_RE.sub(rel_sub, text)
    text = ABS_FROM_RE.sub(abs_sub, text)
    text = INLINE_FROM_RE.sub(inline_sub, text)
    return DOTTED_RE.sub(dotted_sub, text)


def file_modules(path):
    rel = path.relative_to(ROOT / PKG)
    parts = list(rel.with_suffix("").parts)
    is_init = parts[-1] == "__init__"
    if is_init:
        parts = parts[:-1]
    new = ".".join(parts)
    inverse = {v: k for k, v in MOVES.items()}
    old = inverse.get(new, new)
    return new, old, is_init


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--apply", action="store_true")
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    if not args.files and args.apply:
        for pkg in NEW_PACKAGES:
            (ROOT / PKG / pkg.replace(".", "/")).mkdir(parents=True, exist_ok=True)
        for old, new in list(FILE_MOVES.items()) + [(module_file(o), module_file(n)) for o, n in MOVES.items()
                                                    if (ROOT / PKG / module_file(o)).exists()]:
            src, dst = ROOT / PKG / old, ROOT / PKG / new
            if src.exists() and not dst.exists():
                dst.parent.mkdir(parents=True, exist_ok=True)
                subprocess.run(["git", "mv", str(src), str(dst)], cwd=ROOT, check=True)
        for pkg in NEW_PACKAGES:
            init = ROOT / PKG / pkg.replace(".", "/") / "__init__.py"
            if not init.exists():
                init.write_text("")
                subprocess.run(["git", "add", str(init)], cwd=ROOT, check=True)
    existing = new_modules()
    files = [pathlib.Path(f).resolve() for f in args.files] if args.files else sorted(
        p for p in ROOT.rglob("*.py") if "__pycache__" not in p.parts and not any(
            part.startswith(".venv") or part == ".git" for part in p.relative_to(ROOT).parts))
    changed = 0
    for path in files:
        text = path.read_text(encoding="utf-8")
        if (ROOT / PKG) in path.parents:
            new, old, is_init = file_modules(path)
        else:
            new = old = None
            is_init = False
        out = rewrite_text(text, new, old, is_init, existing)
        if out != text:
            changed += 1
            if args.apply:
                path.write_text(out, encoding="utf-8")
            else:
                print(f"--- {path.relative_to(ROOT)}")
                import difflib
                sys.stdout.writelines(difflib.unified_diff(text.splitlines(True), out.splitlines(True), n=0))
    print(f"{changed} files {'rewritten' if args.apply else 'would change'}", file=sys.stderr)


if __name__ == "__main__":
    main()
