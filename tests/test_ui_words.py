"""No message the add-on can show in Blender names a command-line flag (issue 31: "pass --bone-map FILE.json" inside
Blender). Static: every string of every module a Blender session imports (core, the Blender layer, the readers; not
``cli/`` and ``dedupe/``, the command line's own packages) is read from the source, docstrings and comments aside;
none may hold a flag such as ``--fps`` or start one from a formatted value (``f"--{name}"``). The argument lists of
the Blender child processes (``[binary, "--background", ...]``) are a program's command line, not a message."""

import ast
import pathlib
import re

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "blender_shapesig"
COMMAND_LINE_ONLY = ("cli", "dedupe")
FLAG = re.compile(r"(?<![\w-])--[A-Za-z]")


def _docstrings(tree):
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _argv_items(tree):
    """Strings that are items of a list literal holding a flag-like item: a child process's argument list."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.List) and any(isinstance(e, ast.Constant) and isinstance(e.value, str)
                                              and e.value.startswith("--") for e in node.elts):
            out.update(id(e) for e in node.elts)
    return out


def flags_in(source):
    """[(line, text)] of the strings in ``source`` that name a flag (see the module docstring)."""
    tree = ast.parse(source)
    skip = _docstrings(tree) | _argv_items(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            parts = node.values
            for a, b in zip(parts, parts[1:]):
                if isinstance(a, ast.Constant) and isinstance(b, ast.FormattedValue) and str(a.value).endswith("--"):
                    found.append((node.lineno, a.value))
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            if FLAG.search(node.value):
                found.append((node.lineno, node.value))
    return found


def test_the_check_finds_flags():
    assert flags_in('raise ShapeSigError("pass --bone-map FILE.json")')
    assert flags_in('raise ShapeSigError(f"use --{name}")')
    assert flags_in('self.report({"ERROR"}, f"{x}: try --allow-partial")')
    assert not flags_in('def f():\n    """the --fps option"""\n    return "a -- b, a-b, x--y"')
    assert not flags_in('cmd = [binary, "--background", "--python", script]')


def test_no_message_names_a_command_line_flag():
    modules = [p for p in PACKAGE.rglob("*.py") if p.relative_to(PACKAGE).parts[0] not in COMMAND_LINE_ONLY]
    assert len(modules) > 50
    found = [f"{p.relative_to(PACKAGE)}:{line}: {text!r}" for p in modules
             for line, text in flags_in(p.read_text(encoding="utf-8"))]
    assert not found, "\n".join(found)
