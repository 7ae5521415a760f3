"""What every command shares: the one-line error, stdout kept for the report, progress bars, turning CLIP
arguments into ``core.io.sources.ClipSpec`` s, and the option groups (clip reading, metric)."""

import argparse
import contextlib
import os
import sys

from ..core.metrics import DEFAULT_DEPTH, DEFAULT_LEVEL

PROG = "blender_shapesig"
EXIT_ERROR = 2
def _clip_help():
    from ..core.io.registry import NAMED_CLIPS, extensions_text

    return (f"a {extensions_text()} file (every armature animation in it) or FILE#ACTION (one animation of a "
            f"{', '.join(NAMED_CLIPS)} file)")


CLIP_HELP = _clip_help()


class CommandError(Exception):
    """Bad command-line usage or input: reported as one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse, but usage errors become a CommandError (one line) instead of usage + exit."""

    def error(self, message):
        where = self.prog[len(PROG):].strip()
        raise CommandError(f"{PROG}: error: {where + ': ' if where else ''}{message}")


# ---------------------------------------------------------------------------------------------
# Output plumbing


@contextlib.contextmanager
def stdout_to_stderr():
    """Send everything written to stdout (Python and C level) to stderr until the block ends."""
    try:
        sys.stdout.flush()
    except Exception:
        pass
    saved_fd = None
    try:
        saved_fd = os.dup(1)
        os.dup2(2, 1)
    except OSError:
        saved_fd = None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        try:
            sys.stderr.flush()
        except Exception:
            pass
        if saved_fd is not None:
            try:
                # C-level buffers (Blender's printf) must be flushed before fd 1 is restored.
                import ctypes

                ctypes.CDLL(None).fflush(None)
            except Exception:
                pass
            os.dup2(saved_fd, 1)
            os.close(saved_fd)


def say(kind, text):
    """One line on stderr: ``blender_shapesig: KIND: TEXT`` with the text's names as data (``shown``: a newline in a
    file name shows as ``\\n``, never as a line of its own)."""
    write_text(sys.stderr, f"{PROG}: {kind}: {shown(text)}\n")


def write_text(stream, text):
    """``text`` on ``stream`` whatever its encoding (what it cannot encode, e.g. a name that is not UTF-8, is
    written as a ``\\x`` escape instead of failing)."""
    encoding = getattr(stream, "encoding", None) or "utf-8"
    stream.write(text.encode(encoding, "backslashreplace").decode(encoding, "strict"))
    stream.flush()


def progress_bar(args, desc, total=None):
    """A ``progress(done, total)`` drawing a bar on stderr (``core.progress.Bar``; silent with --no-progress or
    without ``args``); a context manager."""
    from ..core.progress import Bar

    return Bar(desc, enabled=args is not None and not getattr(args, "no_progress", False), total=total)


# ---------------------------------------------------------------------------------------------
# Reading clips


# core.io.sources is the one front door: the command line only turns a CLIP argument and its options into a
# ClipSpec, so the signature-cache keys of its libraries are ClipSpec.key, those of the panel's folder libraries.


def crop_of(args):
    """``(start, end, fps, trim)`` of the command line (what ClipSpec takes besides the path and skeleton)."""
    if args is None:
        return None
    fps = getattr(args, "fps", None)
    if fps is not None:
        from ..core.clip.prepare import check_fps

        fps = check_fps(fps, "--fps")  # the command line names its flag (core's messages name none)
    return (getattr(args, "start", None), getattr(args, "end", None), fps, getattr(args, "trim", None) or "auto")


def clip_spec(text, asf=None, crop=None, bone_map="auto"):
    """The ClipSpec of one CLIP argument with ``--asf``, ``(start, end[, fps, trim])`` and ``--bone-map``."""
    from ..core.io.sources import ClipSpec

    start, end, *rest = crop or (None, None)
    fps, trim = rest if rest else (None, "auto")
    return ClipSpec.parse(text, asf=asf or None, start=start, end=end, fps=fps, trim=trim, bone_map=bone_map)


def bone_map_of(args):
    return getattr(args, "bone_map", "auto") if args is not None else "auto"


def load_one(spec, asf=None, crop=None, bone_map="auto"):
    """The one clip a CLIP argument names, cropped, through ``--bone-map``."""
    from ..core.io.sources import read_one

    return read_one(clip_spec(spec, asf, crop, bone_map))


def load_many(specs, asf=None, args=None, skipped=None):
    """Every clip the CLIP arguments name (a .blend may hold several), cropped by ``args``. With a ``skipped``
    list, a file that is not a regular file or is over a cap (``core.io.files``) is skipped into it, else refused."""
    from ..core.errors import UnreadableFileError
    from ..core.io.sources import read

    out = []
    with progress_bar(args, "loading") as bar:
        for i, spec in enumerate(specs):
            try:
                out.extend(read(clip_spec(spec, asf, crop_of(args), bone_map_of(args))))
            except UnreadableFileError as exc:
                if skipped is None:
                    raise
                skipped.append(exc)
            bar(i + 1, len(specs))
    return out


def report_skipped(skipped):
    """One stderr line for the files a command skipped (not regular files, unreadable, over a cap); the JSON's
    ``"skipped"`` list: one line per file."""
    from ..core.io.files import skipped_line

    if skipped:
        say("warning", skipped_line(skipped))
    return [str(e) for e in skipped]


def display_name(clip):
    return clip.name


FILE_KEYS_RECORD = "file keys"  # the cache folder's record of file hashes (SignatureCache.read_fingerprints)


@contextlib.contextmanager
def remembered_file_keys(cache):
    """The files' hashes kept in the cache folder from one command to the next (``sources.load_file_keys``): a
    file unchanged since (size, mtime, inode, change time) is not read again to be keyed; the record is updated
    when this command hashed files."""
    from ..core.io import sources

    sources.load_file_keys(cache.read_fingerprints(FILE_KEYS_RECORD))
    yield
    record = sources.file_keys_record()
    if record is not None:
        cache.write_fingerprints(FILE_KEYS_RECORD, record)


def open_cache(args, search):
    """The signature cache of ``rank``, ``index`` and ``dedupe``: in --cache DIR, else $SHAPESIG_CACHE_DIR, else the
    per-user cache (``core.search.default_cache_dir``); in memory only with --no-cache. The cache makes its own
    subfolder there; when it cannot, it goes on in memory only with one warning (``SignatureCache.warning``), except
    in a folder the user names with --cache: that is an error (docs/cli.md)."""
    if getattr(args, "no_cache", False):
        if args.cache:
            raise CommandError("--cache and --no-cache contradict each other")
        return search.SignatureCache(None)
    cache = search.SignatureCache(args.cache or search.default_cache_dir())
    if args.cache and cache.warning:
        raise CommandError(f"--cache {shown(args.cache)}: {cache.warning.split(' (', 1)[-1].rsplit(');', 1)[0]}")
    return cache


def cache_dir(args, search):
    """The folder ``open_cache`` opens (None with --no-cache), for a command that opens it itself (``dedupe``);
    a --cache DIR that cannot be used is refused here the same way."""
    if getattr(args, "no_cache", False) or args.cache:
        return open_cache(args, search).root
    return search.default_cache_dir()


# ---------------------------------------------------------------------------------------------
# Output files: never a source, never replacing a file without --overwrite, complete or absent


def check_outputs(paths, args, sources=()):
    """Refuse (CommandError, before any work) an output that is one of the ``sources`` or that exists already
    without ``--overwrite``."""
    for out in paths:
        for src in sources:
            try:
                same = os.path.samefile(out, src)
            except (OSError, ValueError):
                same = False
            if same:
                raise CommandError(f"{shown(out)} is one of the source files: give another output")
        if os.path.lexists(out) and not getattr(args, "overwrite", False):
            raise CommandError(f"{shown(out)} exists: give --overwrite to replace it")


def temp_beside(path, suffix=".tmp"):
    """A temporary name in ``path``'s folder (a rename onto ``path`` is then atomic)."""
    folder, base = os.path.split(os.path.abspath(path))
    return os.path.join(folder, f".{base}.shapesig-{os.getpid()}{suffix}")


def write_output(path, data, args=None):
    """Write ``data`` (bytes) to ``path`` through a temporary file renamed when complete (a full disk leaves no
    truncated file); ``args``: refused when ``path`` exists without ``--overwrite`` (``check_outputs``)."""
    if args is not None:
        check_outputs([path], args)
    tmp = temp_beside(path)
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


def shown(name) -> str:
    """A file name for a message (``core.io.text.shown_name``: a newline shows as ``\\n``)."""
    from ..core.io.text import shown_name

    return shown_name(name)


class Staged:
    """``with Staged(folder, args) as stage:`` a command writes its outputs into ``stage.path`` (a temporary folder
    inside ``folder``); when the block ends without error they are moved into ``folder`` (a file that exists there
    is refused without ``--overwrite``, before any is moved), else removed: a failed run (a full disk) leaves no
    half of its outputs. ``stage.moved(value)``: ``value`` with the staging folder in its paths replaced."""

    def __init__(self, folder, args):
        self.folder, self.args, self.path = os.path.abspath(folder), args, None
        self._made = not os.path.isdir(self.folder)

    def __enter__(self):
        import tempfile

        os.makedirs(self.folder, exist_ok=True)
        self.path = tempfile.mkdtemp(prefix=".shapesig-", suffix=".tmp", dir=self.folder)
        return self

    def __exit__(self, kind, _exc, _tb):
        import shutil

        try:
            if kind is None:
                self._move()
        finally:
            shutil.rmtree(self.path, ignore_errors=True)
            if kind is not None and self._made:
                with contextlib.suppress(OSError):
                    os.rmdir(self.folder)  # made for this run and empty
        return False

    def _move(self):
        pairs = []
        for root, _dirs, names in os.walk(self.path):
            for name in names:
                src = os.path.join(root, name)
                pairs.append((src, os.path.join(self.folder, os.path.relpath(src, self.path))))
        check_outputs([dst for _src, dst in pairs], self.args)
        for src, dst in pairs:
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            os.replace(src, dst)

    def moved(self, value):
        if isinstance(value, str):
            return value.replace(self.path, self.folder)
        if isinstance(value, dict):
            return {k: self.moved(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return type(value)(self.moved(v) for v in value)
        return value


def plot_text(name) -> str:
    """A name as matplotlib draws it literally (``core.io.text.plot_name``)."""
    from ..core.io.text import plot_name

    return plot_name(name)


def add_overwrite(p):
    p.add_argument("--overwrite", action="store_true", help="replace outputs that exist (default: refuse them)")


SCHEDULER_HELP = ("run on Dask (optional package): a cluster's scheduler address (tcp://host:8786) or a local Dask "
                  "scheduler: threads, processes, sync (default: a thread pool, no Dask)")


def check_scheduler(name):
    """``--scheduler``'s value, checked before any clip is read (one line, exit 2, within 10 s): a local Dask
    scheduler (threads, processes, sync) or a ``tcp://host:port`` address where a Dask scheduler answers; the
    optional packages it needs (``dedupe.parallel.require_dask``)."""
    if not name:
        return name
    from ..dedupe.parallel import LOCAL_SCHEDULERS, require_dask

    inproc = name.startswith("inproc://")  # a scheduler of this very process (Dask's LocalCluster in a program)
    if name not in LOCAL_SCHEDULERS and not inproc:
        import re

        m = re.fullmatch(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})", name)
        if m is None or not 0 < int(m.group(2)) < 65536:
            raise CommandError(f"--scheduler {shown(name)!r}: give {', '.join(LOCAL_SCHEDULERS)} or a Dask "
                               f"scheduler's address tcp://host:port (e.g. tcp://127.0.0.1:8786)")
    try:
        require_dask(name)
    except Exception as exc:  # noqa: BLE001 - a missing package: one line
        raise CommandError(str(exc)) from None
    if name not in LOCAL_SCHEDULERS and not inproc:
        _probe_scheduler(name, m.group(1).strip("[]"), int(m.group(2)))
    return name


_PROBE_SECONDS = 4.0


def _probe_scheduler(name, host, port):
    """A Dask scheduler speaks first on a new connection (a frame whose 8-byte length is small): anything else (no
    answer, an HTTP server, a closed port) is refused before ``distributed`` reads its answer as a frame."""
    import socket
    import struct

    try:
        sock = socket.create_connection((host, port), timeout=_PROBE_SECONDS)
    except OSError as exc:
        raise CommandError(f"--scheduler {name}: cannot reach it ({exc.strerror or exc})") from None
    head = b""
    with sock:
        try:
            while len(head) < 8:
                got = sock.recv(8 - len(head))
                if not got:
                    break
                head += got
        except OSError:
            pass  # no answer in time
    if len(head) < 8 or not 0 < struct.unpack("<Q", head)[0] < (1 << 26):
        raise CommandError(f"--scheduler {name}: what answers there is not a Dask scheduler")


def add_common(p, asf=True, crop=True):
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else there")
    p.add_argument("--debug", action="store_true", help="show the full traceback on errors")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    if asf:
        p.add_argument("--asf", help="skeleton (.asf) for .amc clips (default: the only .asf beside each .amc)")
    if asf:  # every clip-reading command
        p.add_argument("--bone-map", default="auto", metavar="auto|none|FILE.json",
                       help="match bones of different rigs through the canonical joints: auto (built-in name "
                            "tables, default), none (exact bone names), or a saved map {\"bone\": \"joint\"}")
        p.add_argument("--allow-partial", action="store_true",
                       help="compare / blend even when under half of the moving joints are shared")
    if crop:
        p.add_argument("--start", type=int, metavar="FRAME",
                       help="crop every clip to start at this frame (inclusive; wins over --trim at the start)")
        p.add_argument("--end", type=int, metavar="FRAME", help="crop every clip to end at this frame (inclusive)")
    p.add_argument("--trim", choices=("auto", "none"), default="auto",
                   help="auto (default): drop detected rest-pose / ramp frames at both ends of every clip; "
                        "none: keep every frame")
    p.add_argument("--fps", type=float, metavar="F",
                   help="frame rate of every clip (default: the file's: BVH Frame Time, AMC 120, an action's or "
                        "its scene's)")


def metric_help(default, local=True):
    """--metric's help: every metric id in its words (``core.measure_words``), and its thesis symbol as a tooltip
    names it."""
    from ..core.measure_words import ENGINES, MEASURES
    from ..core.metric_names import LOCAL, METRICS

    engine = ENGINES[LOCAL]
    items = [f"{LOCAL} = {engine.short}, the local search (between two clips: its first stage)"] if local else []
    items += [f"{base} = {MEASURES[base].label}, {MEASURES[base].symbol}" for base in METRICS]
    return "; ".join(items) + f"; a signature measure takes a level (sim3) (default: {default})"


def add_metric(p, depth_help=f"DP search depth D for elastic (default {DEFAULT_DEPTH})", default="sim",
               local=True):
    """--metric (``default``; None: the command resolves it and its help names ``DEFAULT_METRIC``), --level,
    --depth."""
    from ..core.metrics import DEFAULT_METRIC

    p.add_argument("--metric", default=default, help=metric_help(default or f"{DEFAULT_METRIC}, or sim with "
                                                                           f"--windows", local))
    p.add_argument("--level", type=int, help=f"signature truncation level (default {DEFAULT_LEVEL})")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH, help=depth_help)
