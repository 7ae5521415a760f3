"""What the package's and the tools' modules cite exists (issue 40: ``core/__init__.py`` cited a file that does
not exist): every repository path a module names (``docs/...``, ``tests/...``, ``tools/...``, ``benchmarks/...``,
``experiments/...``, ``blender_shapesig/...``) is a file or folder of the repository, no citation of the package
reaches outside it (``../``; the tools' default data folders beside the repository are arguments), every ````core.x.y```` name of core and the command line resolves to a module or an attribute, and the
packages and modules ``core/__init__.py`` lists are core's."""

import importlib
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "blender_shapesig"
PATH = re.compile(r"(?<![\w/.-])((?:\.\./)*(?:docs|tests|tools|benchmarks|experiments|blender_shapesig|shared)/"
                  r"[\w/.\-]*[\w/])")
DOTTED = re.compile(r"``((?:blender_shapesig\.)?(?:core|cli|dedupe|evaluation)\.[\w.]*\w)``")


def _modules():
    return sorted(PACKAGE.rglob("*.py")) + sorted((ROOT / "tools").glob("*.py"))


def cited_paths(text):
    return [m.group(1).rstrip(".") for m in PATH.finditer(text)]


def _resolves(name):
    parts = ("" if name.startswith("blender_shapesig.") else "blender_shapesig.") + name
    parts = parts.split(".")
    for n in range(len(parts), 1, -1):
        try:
            obj = importlib.import_module(".".join(parts[:n]))
        except ImportError:
            continue
        try:
            for attr in parts[n:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return False
        return True
    return False


def test_the_checks_find_a_bad_citation():
    assert cited_paths("beside the repository: ../shared/interfaces.md") == ["../shared/interfaces.md"]
    assert cited_paths("see docs/search.md. And tools/demo.py") == ["docs/search.md", "tools/demo.py"]
    assert cited_paths("a/docs/x.md, ``core.index``") == []
    assert _resolves("core.clip.clip.Clip") and _resolves("core.search.rank_clips")
    assert not _resolves("core.Clip") and not _resolves("core.rigs.no_such_name")


def test_every_cited_path_is_in_the_repository():
    found = []
    for path in _modules():
        for cited in cited_paths(path.read_text(encoding="utf-8")):
            if cited.startswith("../"):  # the tools' data folders beside the repository are arguments, not citations
                if PACKAGE in path.parents:
                    found.append(f"{path.relative_to(ROOT)}: {cited} (outside the repository)")
            elif not (ROOT / cited).exists():
                found.append(f"{path.relative_to(ROOT)}: {cited}")
    assert not found, "\n".join(found)


def test_every_dotted_name_resolves():
    found = [f"{path.relative_to(ROOT)}: {name}" for path in sorted(PACKAGE.rglob("*.py"))
             for name in DOTTED.findall(path.read_text(encoding="utf-8")) if not _resolves(name)]
    assert not found, "\n".join(found)


def test_core_lists_its_own_packages_and_modules():
    import blender_shapesig.core as core

    listed = re.findall(r"``(\w+)``", core.__doc__)
    assert len(listed) >= 12
    missing = [n for n in listed if not ((PACKAGE / "core" / n).is_dir() or (PACKAGE / "core" / f"{n}.py").exists())
               and n != "Clip"]
    assert not missing
