"""Every relative link and image in README.md and docs/**/*.md points at a file that exists, and every
``#anchor`` at a heading of the target page (GitHub's anchor rule: lower case, punctuation dropped, spaces to
hyphens)."""

import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^(```|~~~)")


def _pages():
    pages = [os.path.join(ROOT, "README.md")]
    for folder, _dirs, files in os.walk(os.path.join(ROOT, "docs")):
        pages += [os.path.join(folder, f) for f in files if f.endswith(".md")]
    return sorted(pages)


def _prose(path, keep_code=False):
    """(line number, line) of the page outside fenced code blocks, inline code removed (kept as text with
    ``keep_code``: GitHub's heading anchors include it)."""
    out, fenced = [], False
    with open(path, encoding="utf-8") as fh:
        for no, line in enumerate(fh, start=1):
            if FENCE.match(line.strip()):
                fenced = not fenced
                continue
            if not fenced:
                out.append((no, line.replace("`", "") if keep_code else re.sub(r"`[^`]*`", "", line)))
    return out


def _anchor(heading):
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(path):
    found = set()
    for _no, line in _prose(path, keep_code=True):
        m = re.match(r"^#{1,6}\s+(.*)", line)
        if m:
            found.add(_anchor(m.group(1)))
    return found


def _links(path):
    for no, line in _prose(path):
        for target in LINK.findall(line):
            if not re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto: are not checked here
                yield no, target


def test_anchor_rule():
    assert _anchor("Blender 5.2 LTS beside 5.0") == "blender-52-lts-beside-50"
    assert _anchor("Time base: seconds, not frames") == "time-base-seconds-not-frames"


@pytest.mark.parametrize("page", _pages(), ids=lambda p: os.path.relpath(p, ROOT))
def test_relative_links_resolve(page):
    bad = []
    for no, target in _links(page):
        path, _, anchor = target.partition("#")
        dest = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
        if not os.path.exists(dest):
            bad.append(f"line {no}: {target} (no such file)")
        elif anchor and dest.endswith(".md") and anchor not in _anchors(dest):
            bad.append(f"line {no}: {target} (no such heading)")
    assert not bad, f"{os.path.relpath(page, ROOT)}: " + "; ".join(bad)


def test_the_guide_is_reachable_from_the_readme():
    targets = {t for _no, t in _links(os.path.join(ROOT, "README.md"))}
    assert "docs/README.md" in targets
    index = {t.partition("#")[0] for _no, t in _links(os.path.join(ROOT, "docs", "README.md"))}
    for page in ("install.md", "search.md", "blending.md", "cli.md", "rigs.md", "faq.md", "performance.md",
                 "architecture.md", "dev/README.md"):
        assert page in index


def _architecture_paths():
    """The package paths docs/architecture.md names: every `code` span that is a module or package path
    (``core/clip/skeleton.py``, ``core/rigs/``, ``scratch.py``) and, in the layer drawing, every ``*.py`` name and
    every package or module at the start of a line (under ``core/`` where indented so)."""
    text = open(os.path.join(ROOT, "docs", "architecture.md"), encoding="utf-8").read()
    names = set(re.findall(r"`([\w./]+(?:\.py|/))`", text))
    drawing = re.search(r"```\n(blender_shapesig/.*?)```", text, re.S).group(1)
    for line in drawing.splitlines()[1:]:
        first = line.split()[0] if line.strip() else ""
        if line.startswith("  ") and not line.startswith(" " * 15) and (first.endswith("/") or first.endswith(".py")):
            names.add(("core/" if line.startswith("    ") else "") + first)
        names |= set(re.findall(r"\b\w+\.py\b", line))
    return sorted(names)


def test_architecture_names_modules_that_exist():
    """Every module or package docs/architecture.md names exists: a path from the package, its core or the
    repository; a bare module name somewhere in the package. The layout it describes is the one on disk."""
    pkg = os.path.join(ROOT, "blender_shapesig")
    on_disk = {f for _d, _s, files in os.walk(pkg) for f in files}
    names = _architecture_paths()
    assert len(names) > 40
    missing = [n for n in names if ("/" in n.rstrip("/") or n.endswith("/")) and not any(
        os.path.exists(os.path.join(base, n.rstrip("/"))) for base in (pkg, ROOT, os.path.join(pkg, "core")))
        or "/" not in n and n not in on_disk]
    assert not missing, missing


def test_architecture_is_a_short_read():
    """docs/architecture.md stays a five-minute read: under 1,500 words."""
    words = len(open(os.path.join(ROOT, "docs", "architecture.md"), encoding="utf-8").read().split())
    assert words < 1500, words
