"""The shape of the package: modules of a readable size (every line counted), functions that fit on a screen or two,
the layering rule that core never reaches into the Blender layer (checked statically here; tests/core/test_no_bpy.py
imports every core module with bpy blocked) and no import cycles."""

import ast
import pathlib
import re

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "blender_shapesig"
MAX_MODULE_LINES = 450      # every line, blank ones too
MAX_FUNCTION_LINES = 120    # lines from 'def' to the last line of the body
BLENDER_LAYER = ("bpy", "mathutils", "bpy_extras", "addon_utils")


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _rel(path):
    return path.relative_to(PACKAGE.parent).as_posix()


@pytest.mark.parametrize("path", _modules(), ids=_rel)
def test_module_size(path):
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_MODULE_LINES, f"{_rel(path)}: {len(lines)} lines"


def test_function_sizes():
    long = []
    for path in _modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{_rel(path)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, "functions over the limit: " + "; ".join(long)


def test_core_imports_nothing_from_the_blender_layer():
    """No import of bpy & co. in core, nor of the package's Blender-layer modules, not even named in a string (the
    Blender layer registers its readers with ``core.io.registry`` itself)."""
    bad = []
    for path in sorted((PACKAGE / "core").rglob("*.py")):
        depth = len(path.parent.relative_to(PACKAGE).parts)  # core/x.py: 1, core/search/x.py: 2
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [(a.name, 0) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [(node.module or "", node.level)]
            else:
                continue
            for name, level in names:
                outside = level > depth or (level == 0 and name.startswith("blender_shapesig")
                                             and not name.startswith("blender_shapesig.core"))
                if name.split(".")[0] in BLENDER_LAYER and level == 0 or outside:
                    bad.append(f"{_rel(path)}:{node.lineno} imports {'.' * level}{name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and " " not in node.value and re.search(
                    r"(^|\.|\})(readers|operators|panels|library|action_io)[.:]\w", node.value):
                bad.append(f"{_rel(path)}:{node.lineno} names the Blender layer in {node.value!r}")
    assert not bad, "; ".join(bad)


def _import_graph():
    """{module: modules of the package it imports}, for every import statement of every module (module level and
    inside functions); ``from P import m`` of a submodule ``m`` is an edge to ``P.m``, and an import of ``a.b.c``
    is an edge to the packages ``a.b`` and ``a`` too (their ``__init__`` runs first) unless the importer is inside
    them."""
    root = PACKAGE.parent
    files = {}
    for p in _modules():
        parts = list(p.relative_to(root).with_suffix("").parts)
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    edges = {}
    for mod, path in files.items():
        base = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    pkg = base.split(".")[:len(base.split(".")) - (node.level - 1)]
                    src = ".".join(pkg + ([node.module] if node.module else []))
                else:
                    src = node.module or ""
                names = [f"{src}.{a.name}" if f"{src}.{a.name}" in files else src for a in node.names]
            else:
                continue
            for t in names:
                while t and t not in files:
                    t = t.rpartition(".")[0]
                if t and t != mod:
                    targets.add(t)
                    # importing a.b.c runs a/__init__ and a/b/__init__ first: edges to the target's packages
                    # that are not the importer's own (those are already being imported)
                    pkg = t.rpartition(".")[0]
                    while pkg and not (mod == pkg or mod.startswith(pkg + ".")):
                        if pkg in files:
                            targets.add(pkg)
                        pkg = pkg.rpartition(".")[0]
        edges[mod] = targets
    return edges


def _cycles(edges):
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for start in edges:
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def test_no_import_cycles():
    """No two modules of the package import each other, directly or round a loop, not even inside functions."""
    cycles = _cycles(_import_graph())
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_finder_finds_a_cycle():
    """The check above can fail: a loop of three and a pair are found, a chain is not."""
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d"}, "f": {"a"}}
    assert sorted(_cycles(edges)) == [["a", "b", "c"], ["d", "e"]]


def test_an_import_of_a_submodule_counts_its_packages():
    """``from .index import local`` in core/metrics.py runs core/search/__init__.py first: an edge to the package
    (the cycle of the old metrics hub, metrics -> index.local -> index/__init__ -> rank -> metrics, went unseen)."""
    edges = _import_graph()
    assert {"blender_shapesig.core.search.local.features", "blender_shapesig.core.search"} <= edges["blender_shapesig.core.metrics"]
    assert "blender_shapesig.core" not in edges["blender_shapesig.core.metrics"]  # its own package: no edge


def test_nothing_in_core_imports_the_metrics_facade():
    """``core.metrics`` is the facade for the command line, the Blender layer and scripts; core imports the owners
    (``metric_names``, ``distances``, the engines), so the facade may import every engine."""
    importers = sorted(m for m, targets in _import_graph().items()
                       if "blender_shapesig.core.metrics" in targets and m.startswith("blender_shapesig.core"))
    assert not importers, importers
