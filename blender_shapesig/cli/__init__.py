"""Command line: ``python -m blender_shapesig COMMAND ...``, one module per command (``add_parser(sub)``,
``run(args)``) and the shared parts in ``common``. Every command takes ``--json`` and ``--debug``; errors exit with
code 2 and one line on stderr; bpy is imported only for .blend files, with fd 1 pointed at stderr.
See docs/cli.md.
"""

import json
import sys
import traceback

from . import blend, dedupe, distance, evaluate, index, matrix, rank, transition
from .common import (EXIT_ERROR, PROG, CommandError, _Parser, load_many, load_one, shown, stdout_to_stderr,
                     write_text)

COMMANDS = (distance, rank, blend, matrix, evaluate, dedupe, index, transition)

__all__ = ["main", "build_parser", "CommandError", "PROG", "EXIT_ERROR", "load_one", "load_many"]


def _name(command):
    return command.__name__.rsplit(".", 1)[-1]


def build_parser(command=None):
    """The parser of every command, or of ``command`` alone when it names one (what a call runs: building the
    others' options and help texts took 14-20 ms of every call's start)."""
    parser = _Parser(
        prog=PROG,
        description="Shape analysis of motion-capture clips: SRVT elastic distance, geodesic blends, signatures.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    only = [one for one in COMMANDS if _name(one) == command]
    for one in only or COMMANDS:
        one.add_parser(sub)
    return parser


def _emit(args, out, text):
    if getattr(args, "json", False):
        write_text(sys.stdout, json.dumps(out) + "\n")  # ASCII: names that are not UTF-8 as \udcNN escapes
    elif text:
        write_text(sys.stdout, text + "\n")


def _error(message, debug):
    if debug:
        traceback.print_exc(file=sys.stderr)
    line = shown(" ".join(str(message).split()) or "error")
    if not line.startswith(PROG):
        line = f"{PROG}: error: {line}"
    write_text(sys.stderr, line + "\n")
    return EXIT_ERROR


# the command line's options for the neutral advice of core's messages (the panel words them for animators)
_FLAG_HINTS = (("give its skeleton file", " (--asf)"), ("choose its skeleton file", " (--asf)"),
               ("give a bone map", " (--bone-map FILE.json)"), ("map the bones", " (--bone-map FILE.json)"),
               ("allow partial matches", " (--allow-partial)"), ("allow long blends", " (--allow-long)"))


def _with_flags(line):
    """A core error line with the option that acts on each piece of advice it gives."""
    for advice, flag in _FLAG_HINTS:
        if advice in line and flag not in line:
            line = line.replace(advice, advice + flag, 1)
    return line


def _stop_children():
    """Kill the reading children (a signal, an interrupt) and close the shared one (its temp folder removed)."""
    from ..readers import child, guard

    guard.kill_all()
    try:
        child.close()
    except Exception:  # noqa: BLE001 - on the way out: what is left is killed already
        pass


def main(argv=None):
    """Run the command line; returns the exit code (0, or 2 on errors)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    parser = build_parser(argv[0] if argv else None)
    try:
        args = parser.parse_args(argv)
    except CommandError as exc:
        return _error(exc, debug)
    except SystemExit as exc:  # --help
        return int(exc.code or 0) if isinstance(exc.code, int) else 0
    if not getattr(args, "command", None):
        names = ", ".join(map(_name, COMMANDS))
        return _error(f"no command given: choose one of {names} (see --help)", False)
    from ..readers import guard

    try:  # SIGTERM / SIGHUP / SIGINT end the reading children and remove their temp folders
        with guard.on_signals(), stdout_to_stderr():
            out, text = args.func(args)
    except (KeyboardInterrupt, guard.Terminated) as exc:
        _stop_children()
        sys.stderr.write(f"{PROG}: interrupted\n")
        return 128 + getattr(exc, "signum", 2)
    except Exception as exc:  # every failure: one line (and the traceback with --debug)
        from ..core.errors import error_line

        return _error(exc if isinstance(exc, CommandError) else _with_flags(error_line(exc)), debug)
    _emit(args, out, text)
    return 0
