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
# a Python exception's name or a traceback in a text a person reads (tests/blender/panels/test_panel_words.py too)
EXCEPTION_NAME = re.compile(r"\w*Error\b|\w*Exception\b|Traceback|NoneType|\bErrno\b")
ALL_WORDS = {f"{table}[{key!r}]": words for table, group in (("ENGINES", ENGINES), ("MEASURES", MEASURES),
                                                              ("OPTIONS", OPTIONS)) for key, words in group.items()}
DOCS = PACKAGE.parent / "docs"
# the modules whose strings a person reads as labels, status lines and reports (tooltips aside: operator docstrings
# and ``description=`` may name a thesis symbol)
# (every module of the Blender layer: the packages below are core, the command line's and the file readers')
NOT_UI = ("core", "cli", "dedupe", "evaluation", "readers")


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
        for field in ("label", "column", "status", "description"):
            text = getattr(words, field)
            assert text and not SYMBOL.search(text), f"{where}.{field}: {text!r}"
    # the symbols live in the tooltips: each measure's tooltip names its symbol
    for where in ("MEASURES['sim']", "MEASURES['elastic']", "ENGINES['sim']", "ENGINES['moments']"):
        words = ALL_WORDS[where]
        assert words.symbol and words.symbol in words.tooltip, where
    for where, words in ALL_WORDS.items():
        assert words.symbol in words.tooltip, where


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
    return sorted(p for p in PACKAGE.rglob("*.py") if p.relative_to(PACKAGE).parts[0] not in NOT_UI)


def test_no_label_or_report_of_the_panel_and_operators_holds_a_thesis_symbol():
    paths = _ui_module_paths()
    assert len(paths) >= 30
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


# ------------------------------------------------------------------ every place that names a measure reads the owner

import argparse  # noqa: E402
import html.parser  # noqa: E402
import importlib.util  # noqa: E402

from blender_shapesig.core.measure_words import SYMBOLS, metric_phrase  # noqa: E402
from blender_shapesig.core.metric_names import ALL_METRICS, LOCAL, METRICS  # noqa: E402

ROOT = PACKAGE.parent
SYMBOL_ONLY = re.compile("|".join(SYMBOLS))  # the thesis' symbols without the metric ids the command line takes
# "id = words" in --metric's help
NAMED = re.compile(r"(?:^|; )(\w+) = ([^,;]+)")


def _commands():
    from blender_shapesig.cli import build_parser

    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def _option(parser, dest):
    return next(a for a in parser._actions if a.dest == dest)


def test_the_owner_holds_every_engine_and_measure():
    """One ``Words`` per engine of Find Similar and per measure the command line takes, each under its id."""
    assert set(ENGINES) == {LOCAL, "sim", "moments"} and set(ALL_METRICS) <= set(MEASURES)
    for table in (ENGINES, MEASURES, OPTIONS):
        for key, words in table.items():
            assert words.key == key and words.description and "\n" not in words.description, key
    assert {metric_phrase(m) for m in ALL_METRICS} == {ENGINES[LOCAL].short} | {MEASURES[m].label for m in METRICS}


def test_metric_help_names_each_measure_in_the_owners_words():
    """``--metric``'s help of distance, rank and matrix: every metric id with the owner's label and symbol, and
    nothing else (a measure spelled by hand, or one missing, fails)."""
    commands = _commands()
    for name, local in (("distance", True), ("rank", True), ("matrix", False)):
        text = " ".join(_option(commands[name], "metric").help.split())
        got = dict(NAMED.findall(text))
        want = {base: f"{MEASURES[base].label}" for base in METRICS}
        if local:
            want[LOCAL] = ENGINES[LOCAL].short
        assert got == want, name
        for base in METRICS:
            assert f"{base} = {MEASURES[base].label}, {MEASURES[base].symbol};" in text, (name, base)


def _claims_as_often(text):
    return "as often" in " ".join(text.split())


def test_rank_help_describes_the_engines_in_the_owners_words_and_the_docs_numbers():
    """``rank --help`` names the three engines by the owner's label and one-line description; its claim on the
    same take in another format agrees with docs/evaluation.md's numbers (the default's and sim^3's) and with
    docs/cli.md."""
    rank = _commands()["rank"]
    text = " ".join(rank.description.split())
    for key in ("local", "sim"):
        assert f"{ENGINES[key].short}: {ENGINES[key].description}" in text, key
    assert f"{ENGINES['moments'].label}: {ENGINES['moments'].description}" in text
    assert f"{ENGINES['moments'].label}: {ENGINES['moments'].description}" in _option(rank, "windows").help
    assert MEASURES["elastic"].status in _option(rank, "rerank").help
    evaluation = " ".join((DOCS / "evaluation.md").read_text(encoding="utf-8").split())
    m = re.search(r"the same take in another file format first for (\d+) of (\d+) clips \(sim\^3: (\d+)/(\d+)",
                  evaluation)
    assert m, "docs/evaluation.md no longer gives the same-take numbers of the default and sim^3"
    default, signatures = (int(m.group(1)), int(m.group(2))), (int(m.group(3)), int(m.group(4)))
    cli_md = (DOCS / "cli.md").read_text(encoding="utf-8")
    assert _claims_as_often(text) == (default == signatures) == _claims_as_often(cli_md)
    assert "better" not in text


class _Headers(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.headers, self._in = [], False

    def handle_starttag(self, tag, attrs):
        self._in = tag == "th"

    def handle_data(self, data):
        if self._in:
            self.headers.append(data)
            self._in = False


def test_dedupe_report_headers_are_the_owners_columns():
    """The HTML report's pair tables (clusters and near misses) head each measure's column with the owner's."""
    from blender_shapesig.dedupe import report

    got = _Headers()
    got.feed(report._table([], str))
    assert got.headers == ["a", "b"] + [MEASURES[k].column for k in ("sim", "elastic", "relative", "take")] + [
        "near-duplicate"]


def _demo():
    spec = importlib.util.spec_from_file_location("shapesig_demo_words", ROOT / "tools" / "demo.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_demo_report_headers_are_the_owners_columns_and_none_is_empty():
    """The demo's ranking table: the sort measure's column, and the timing-aligned difference's only when a row
    has one (the issue's table had an empty d_S* column)."""
    demo = _demo()
    assert demo.result_columns("local", False) == [MEASURES["local"].column]
    assert demo.result_columns("sim", False) == [MEASURES["sim"].column]
    assert demo.result_columns("elastic", True) == [MEASURES["sim"].column, MEASURES["elastic"].column]


def test_evaluation_report_names_each_metric_in_the_owners_words():
    from blender_shapesig.evaluation.report import format_report

    row = {"accuracy": 1.0, "correct": 2, "seconds": 0.5, "map": 1.0,
           "confusion": {"classes": ["walk"], "table": [[2]]}}
    names = ("local", "sim3", "elastic", "sim3+elastic5")
    text = format_report({"clips": 2, "classes": ["walk"], "metrics": {n: row for n in names}})
    assert f"| local | {ENGINES['local'].short} |" in text and f"| sim3 | {MEASURES['sim'].label} |" in text
    assert f"| elastic | {MEASURES['elastic'].label} |" in text
    assert f"| sim3+elastic5 | {MEASURES['sim'].label}, the best 5 re-ranked by the {MEASURES['elastic'].status} |" \
        in text


def _shown_strings(path):
    """[(line, text)] of the strings of a command-line module a person reads in its output (docstrings and the
    ``help=``/``description=`` of its options, its tooltips, aside)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _docstrings(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg in ("help", "description"):
            skip.update(id(n) for n in ast.walk(node.value))
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip]


def test_no_report_or_output_of_the_command_line_holds_a_thesis_symbol():
    """The command line's text output and messages, the dedupe report (its gates' rule and failed tests), the
    evaluation report and the demo report use the owner's words; a thesis symbol only in ``--help`` (where the
    owner's symbols follow their words) and the docs."""
    paths = sorted((PACKAGE / "cli").glob("*.py")) + sorted((PACKAGE / "dedupe").glob("*.py")) + sorted(
        (PACKAGE / "evaluation").glob("*.py")) + [PACKAGE / "core" / "search" / "dedupe.py", ROOT / "tools" / "demo.py"]
    found = [f"{p.relative_to(ROOT)}:{line}: {text!r}" for p in paths for line, text in _shown_strings(p)
             if SYMBOL_ONLY.search(text)]
    assert not found, "\n".join(found)


def test_help_holds_only_the_owners_symbols():
    """Every ``--help`` text: with the owner's symbols taken out, no thesis symbol is left (an equation number, a
    citation of the docs, may stay)."""
    symbols = sorted({w.symbol for w in ALL_WORDS.values() if w.symbol}, key=len, reverse=True)
    no_equation = re.compile("|".join(s for s in SYMBOLS if not s.startswith("eq")))
    commands = _commands()
    texts = [(name, p.description or "") for name, p in commands.items()]
    texts += [(f"{name} {a.dest}", a.help or "") for name, p in commands.items() for a in p._actions]
    assert len(texts) > 100
    found = []
    for where, text in texts:
        for s in symbols:
            text = text.replace(s, "")
        if no_equation.search(text):
            found.append(f"{where}: {text!r}")
    assert not found, "\n".join(found)
