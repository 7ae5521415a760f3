"""What every command shares: the one-line error, stdout kept for the report, progress bars, turning CLIP
arguments into ``core.io.sources.ClipSpec`` s, and the option groups (clip reading, metric)."""

import argparse
import contextlib
import math
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


def finite(x):
    """A float for JSON: NaN / inf become None (JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


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
        sys.stderr.write(f"{PROG}: warning: {skipped_line(skipped)}\n")
    return [str(e) for e in skipped]


def display_name(clip):
    return clip.name


def cache_dir(args, search):
    """The signature cache folder of ``rank`` and ``dedupe``: --cache DIR, else $SHAPESIG_CACHE_DIR, else the
    per-user cache (``core.index.default_cache_dir``); None (memory only) with --no-cache. The cache makes its own
    subfolder there; when it cannot, it goes on in memory only with one warning (``SignatureCache.warning``)."""
    if args.no_cache:
        if args.cache:
            raise CommandError("--cache and --no-cache contradict each other")
        return None
    return args.cache or search.default_cache_dir()


SCHEDULER_HELP = ("run on Dask (optional package): a cluster's scheduler address (tcp://host:8786) or a local Dask "
                  "scheduler: threads, processes, sync (default: a thread pool, no Dask)")


def check_scheduler(name):
    """``--scheduler``'s value, refused in one line when it is neither a local Dask scheduler nor an address (the
    optional packages are checked by ``dedupe.parallel.require_dask`` before any clip is read)."""
    from ..dedupe.parallel import LOCAL_SCHEDULERS

    if name and name not in LOCAL_SCHEDULERS and "://" not in name and ":" not in name:
        raise CommandError(f"--scheduler {name!r}: give {', '.join(LOCAL_SCHEDULERS)} or an address "
                           f"(tcp://host:8786)")
    return name


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
    return (
        ("local (the local search: windows of pose and motion by log-signatures, then a DTW re-rank of a "
         "shortlist; between two clips its first stage), " if local else "")
        + "l2 (d_P*), elastic (d_S*), group (rho^n), concat (sigma_*^n), linear (sigma_L^n) or sim (sim^n, eq. 9.1); "
        f"a level may be appended (sim3) (default: {default})"
    )


def add_metric(p, depth_help=f"DP search depth D for elastic (default {DEFAULT_DEPTH})", default="sim",
               local=True):
    """--metric (``default``; None: the command resolves it and its help names ``DEFAULT_METRIC``), --level,
    --depth."""
    from ..core.metrics import DEFAULT_METRIC

    p.add_argument("--metric", default=default, help=metric_help(default or f"{DEFAULT_METRIC}, or sim with "
                                                                           f"--windows", local))
    p.add_argument("--level", type=int, help=f"signature truncation level (default {DEFAULT_LEVEL})")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH, help=depth_help)
