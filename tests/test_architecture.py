"""The shape of the package (issue 13): modules of a readable size, functions that fit on a screen or two, and
the layering rule that core never reaches into the Blender layer (checked statically here; tests/core/test_no_bpy.py
imports every core module with bpy blocked)."""

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "blender_shapesig"
MAX_MODULE_LINES = 550      # non-blank lines
MAX_FUNCTION_LINES = 120    # lines from 'def' to the last line of the body
BLENDER_LAYER = ("bpy", "mathutils", "bpy_extras", "addon_utils")


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _rel(path):
    return path.relative_to(PACKAGE.parent).as_posix()


@pytest.mark.parametrize("path", _modules(), ids=_rel)
def test_module_size(path):
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
    assert len(lines) <= MAX_MODULE_LINES, f"{_rel(path)}: {len(lines)} non-blank lines"


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
    """No import of bpy & co. in core, nor of the package's Blender-layer modules (core names those only by
    reader-registry strings, imported when such a file is read)."""
    bad = []
    for path in sorted((PACKAGE / "core").rglob("*.py")):
        depth = len(path.parent.relative_to(PACKAGE).parts)  # core/x.py: 1, core/index/x.py: 2
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
    assert not bad, "; ".join(bad)
