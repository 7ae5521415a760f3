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


# ------------------------------------------------------------------ the measures' words: no thesis symbol, one source

from blender_shapesig.core.measure_words import ENGINES, MEASURES, OPTIONS, PANEL_NAME, THESIS_SYMBOLS  # noqa: E402

SYMBOL = re.compile("|".join(THESIS_SYMBOLS))
# a Python exception's name or a traceback in a text a person reads (tests/blender/test_panel_words.py too)
EXCEPTION_NAME = re.compile(r"\w*Error\b|\w*Exception\b|Traceback|NoneType|\bErrno\b")
ALL_WORDS = {f"{table}[{key!r}]": words for table, group in (("ENGINES", ENGINES), ("MEASURES", MEASURES),
                                                              ("OPTIONS", OPTIONS)) for key, words in group.items()}
DOCS = PACKAGE.parent / "docs"
# the modules whose strings a person reads as labels, status lines and reports (tooltips aside: operator docstrings
# and ``description=`` may name a thesis symbol)
UI_MODULES = ("panels", "operators", "search/results.py", "search/library.py")


def test_the_patterns_find_thesis_symbols_and_exception_names():
    for text in ("sorted by d_S*", "sim^3 = 1.0817", "sim\u00b3", "metric sim3", "\u03c1 = 0.8",
                 "not in the comparison space"):
        assert SYMBOL.search(text), text
    for text in ("Similarity = 1.0817, Timing-aligned difference = 8.2126", "similar motion", "simple"):
        assert not SYMBOL.search(text), text
    for text in ("KeyError: 'take'", "ShapeSigError", "Traceback (most recent call last)", "'NoneType' object"):
        assert EXCEPTION_NAME.search(text), text
    assert not EXCEPTION_NAME.search("internal error ('take'); the console has the details")


def test_labels_columns_and_status_words_hold_no_thesis_symbol():
    assert not SYMBOL.search(PANEL_NAME) and not EXCEPTION_NAME.search(PANEL_NAME)
    for where, words in ALL_WORDS.items():
        for field in ("label", "column", "status"):
            text = getattr(words, field)
            assert text and not SYMBOL.search(text), f"{where}.{field}: {text!r}"
    # the symbols live in the tooltips: each measure's tooltip names its symbol
    for where in ("MEASURES['sim']", "MEASURES['elastic']", "ENGINES['sim']", "ENGINES['moments']"):
        words = ALL_WORDS[where]
        assert words.symbol and words.symbol in words.tooltip, where


def test_the_docs_name_each_measure_by_its_words_and_its_symbol():
    """docs/search.md (the user's guide of the panel) uses the panel's words, each measure with its symbol."""
    text = (DOCS / "search.md").read_text(encoding="utf-8").replace("\\*", "*")
    assert f"**{PANEL_NAME}**" in text and "Signature Search" not in text
    for key in ("sim", "elastic", "local"):
        assert MEASURES[key].column in text, key
    for key in ("local", "sim", "moments"):
        assert ENGINES[key].label.split(" (")[0] in text, key
    for key in ("sim", "elastic"):
        assert MEASURES[key].symbol in text, key
    for key in ("level", "rerank", "depth"):
        assert f"**{OPTIONS[key].label}**" in text, key


def _ui_strings(tree, skip_tooltips=True):
    """[(line, text)] of the string constants of ``tree`` (the constant parts of f-strings included) a person may
    read, docstrings and (``skip_tooltips``) ``description=`` values aside."""
    skip = _docstrings(tree) | _argv_items(tree)
    if skip_tooltips:
        for node in ast.walk(tree):
            if isinstance(node, ast.keyword) and node.arg == "description":
                skip.update(id(n) for n in ast.walk(node.value))
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip]


def _ui_module_paths():
    out = []
    for name in UI_MODULES:
        path = PACKAGE / name
        out += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return out


def test_no_label_or_report_of_the_panel_and_operators_holds_a_thesis_symbol():
    paths = _ui_module_paths()
    assert len(paths) >= 10
    found = [f"{p.relative_to(PACKAGE)}:{line}: {text!r}" for p in paths
             for line, text in _ui_strings(ast.parse(p.read_text(encoding="utf-8")))
             if SYMBOL.search(text) or EXCEPTION_NAME.search(text)]
    assert not found, "\n".join(found)


def _names():
    """Every label and column header of the measure words (and the panel's name)."""
    return {PANEL_NAME} | {w.label for w in ALL_WORDS.values()} | {w.column for w in ALL_WORDS.values()}


def test_one_source_of_the_measure_words():
    """The engines', measures' and options' names are written once, in core/measure_words.py: no other module of a
    Blender session (nor the demo's report) spells one as a string of its own, alone or, for names of two words or
    more, inside a longer text; they read ``ENGINES`` / ``MEASURES`` / ``OPTIONS`` instead. So the panel, the
    reports, the tooltips and the demo cannot disagree."""
    names = _names()
    long_names = {n for n in names if " " in n or "-" in n}
    modules = [p for p in PACKAGE.rglob("*.py") if p.relative_to(PACKAGE).parts[0] not in COMMAND_LINE_ONLY
               and p.name != "measure_words.py"] + [PACKAGE.parent / "tools" / "demo.py"]
    found = []
    for p in modules:
        for line, text in _ui_strings(ast.parse(p.read_text(encoding="utf-8")), skip_tooltips=False):
            if text.strip() in names or any(n in text for n in long_names):
                found.append(f"{p.relative_to(PACKAGE.parent)}:{line}: {text!r}")
    assert not found, "\n".join(found)


def test_the_one_source_check_finds_a_copy():
    tree = ast.parse('def f():\n    """Timing-aligned in a docstring"""\n    return label(text="Timing-aligned")')
    texts = [t for _line, t in _ui_strings(tree, skip_tooltips=False)]
    assert texts == ["Timing-aligned"] and "Timing-aligned" in _names()
