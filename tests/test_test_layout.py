"""The shape of the tests: shared helpers live in the package ``tests/helpers/`` (imported as ``tests.helpers.x``),
no test module imports another test module or a loose module under tests/, and every Python file under tests/ is
a test module, a conftest.py, a helper or the Blender runner (checked statically on every import, module-level
or inside a function)."""

import ast
import pathlib

TESTS = pathlib.Path(__file__).resolve().parent
HELPERS = "tests.helpers"
RUNNER = "run_in_blender.py"  # a script started by Blender, imported by nothing


def _python_files(root=TESTS):
    return sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts and "data" not in
                  p.relative_to(root).parts[:1])


def _imported_names(tree):
    """Every module name an import statement of ``tree`` names (``from a import b`` gives ``a`` and ``a.b``)."""
    for node in sorted(ast.walk(tree), key=lambda n: getattr(n, "lineno", 0)):
        if isinstance(node, ast.Import):
            yield node.lineno, [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = "." * node.level + (node.module or "")
            yield node.lineno, [base] + [f"{base}.{alias.name}".lstrip(".") if node.module else
                                         "." * node.level + alias.name for alias in node.names]


def _loaded_paths(tree):
    """String constants given to ``importlib.util.spec_from_file_location`` (files loaded by path)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) \
                == "spec_from_file_location":
            for arg in ast.walk(node):
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    yield node.lineno, arg.value


def _local_stems(root=TESTS):
    """Names that would import a module of tests/ by a bare name (pytest puts test folders on sys.path)."""
    return {p.stem for p in _python_files(root)} | {"helpers"}


def _why_bad(name, stems):
    parts = name.split(".")
    if name.startswith("."):
        return f"relative import {name}"
    if any(part.startswith("test_") for part in parts):
        return f"imports the test module {name}"
    if parts[0] == "tests" and len(parts) > 1 and parts[1] != "helpers":
        return f"imports {name}, not a helper (helpers live in {HELPERS})"
    if parts[0] in stems:
        return f"imports {name} by a bare name (use {HELPERS}.x)"
    return None


def _violations(path, root=TESTS):
    """One line per bad import statement (its first bad name) and per file of tests/ loaded by path."""
    stems, bad = _local_stems(root), []
    rel = path.relative_to(root.parent).as_posix()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for line, names in _imported_names(tree):
        why = next((w for w in (_why_bad(n, stems) for n in names) if w), None)
        if why:
            bad.append(f"{rel}:{line} {why}")
    for line, text in _loaded_paths(tree):
        if "test_" in text or "tests" in pathlib.PurePath(text).parts:
            bad.append(f"{rel}:{line} loads {text} by path")
    return bad


def _misplaced(root=TESTS):
    """Python files under tests/ that are neither test modules, conftest.py, helpers nor the runner."""
    out = []
    for path in _python_files(root):
        rel = path.relative_to(root)
        if path.name.startswith("test_") or path.name == "conftest.py" or rel.parts[0] == "helpers" \
                or rel.as_posix() == RUNNER:
            continue
        out.append(rel.as_posix())
    return out


def test_no_test_module_imports_another_test_module_or_a_loose_module():
    bad = [v for path in _python_files() for v in _violations(path)]
    assert not bad, "imports outside tests/helpers: " + "; ".join(bad)


def test_every_python_file_under_tests_has_its_place():
    assert not _misplaced(), f"neither a test, a conftest.py nor in tests/helpers/: {_misplaced()}"


def test_helpers_are_a_package():
    assert (TESTS / "helpers" / "__init__.py").is_file()


def test_the_layout_check_finds_each_kind_of_bad_import(tmp_path):
    root = tmp_path / "tests"
    (root / "blender").mkdir(parents=True)
    (root / "helpers").mkdir()
    (root / "helpers" / "__init__.py").write_text("")
    (root / "helpers" / "scene.py").write_text("X = 1\n")
    (root / "blender" / "stand_in.py").write_text("Y = 2\n")
    (root / "test_a.py").write_text("from tests.helpers.scene import X\nimport numpy\n")
    (root / "blender" / "test_b.py").write_text(
        "from test_a import X\n"
        "from stand_in import Y\n"
        "def f():\n    from tests.blender import test_a\n    import tests.core.test_c\n"
        "import importlib.util\nspec = importlib.util.spec_from_file_location('m', 'tests/blender/test_a.py')\n"
        "from tests import stand_in\n")
    assert _violations(root / "test_a.py", root) == []
    found = _violations(root / "blender" / "test_b.py", root)
    assert [v.split(" ", 1)[0].rsplit(":", 1)[1] for v in found] == ["1", "2", "4", "5", "8", "7"], found
    assert _misplaced(root) == ["blender/stand_in.py"]
