"""Which files the readers open, and how much of them: the one owner of the checks made before a clip file is read.
Only regular files are opened (``check_file``: a link to one is fine; a FIFO, socket, device, dangling or looping
link is refused before any ``open``). Clip files have caps, checked before reading: the size
(``$SHAPESIG_MAX_FILE_MB``; ``$SHAPESIG_MAX_BLEND_MB`` for .blend files), a text line's length (``MAX_LINE_BYTES``)
and a clip's frames (``$SHAPESIG_MAX_FRAMES``); ``$SHAPESIG_MAX_FILE_MB`` is also the memory budget of one file
(``check_budget``: what a compressed file unpacks to, a clip's rotations), checked from headers before any
allocation. A refused file raises ``UnreadableFileError`` (one line naming the
file); libraries skip such files and report them once (``skipped_line``). The caps and why: docs/robustness.md.
"""

import errno
import os
import stat
from typing import Optional

import numpy as np

from ..errors import ParseError, ShapeSigError, UnreadableFileError

__all__ = ["MAX_FILE_MB_ENV", "MAX_BLEND_MB_ENV", "MAX_FRAMES_ENV", "DEFAULT_MAX_FILE_MB", "DEFAULT_MAX_BLEND_MB", "DEFAULT_MAX_FRAMES", "MAX_LINE_BYTES",
           "max_file_bytes", "max_frames", "file_problem", "check_file", "open_regular", "read_bytes",
           "check_frames", "skipped_line", "memory_budget", "check_budget", "regular_within_cap"]

MAX_FILE_MB_ENV = "SHAPESIG_MAX_FILE_MB"
MAX_BLEND_MB_ENV = "SHAPESIG_MAX_BLEND_MB"
MAX_FRAMES_ENV = "SHAPESIG_MAX_FRAMES"
# text clip files (BVH, AMC, ASF): reading one takes about 13x (BVH) to 20x (AMC) its size at the peak
DEFAULT_MAX_FILE_MB = 128
# .blend files are read by Blender in a child process (readers.blend), in about their own size
DEFAULT_MAX_BLEND_MB = 1024
DEFAULT_MAX_FRAMES = 1_000_000
# the longest line of a text clip file (BVH, AMC, ASF): a BVH frame of 1,000 joints x 6 channels of 16 characters
# is 96 kB; a longer line is no motion file
MAX_LINE_BYTES = 1 << 20
_BLOCK = 1 << 20


def _env_number(name, default, convert):
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = convert(text)
    except ValueError:
        value = 0
    if not value > 0:
        raise ShapeSigError(f"${name} must be a positive number, got {text!r}")
    return value


def max_file_bytes(path="") -> int:
    """The size cap of a clip file in bytes: ``$SHAPESIG_MAX_BLEND_MB`` megabytes (default 1024) for a .blend,
    else ``$SHAPESIG_MAX_FILE_MB`` (default 128)."""
    if os.fspath(path).lower().endswith(".blend"):
        return int(_env_number(MAX_BLEND_MB_ENV, DEFAULT_MAX_BLEND_MB, float) * 2 ** 20)
    return int(_env_number(MAX_FILE_MB_ENV, DEFAULT_MAX_FILE_MB, float) * 2 ** 20)


def memory_budget() -> int:
    """The memory one clip file may take in bytes (``$SHAPESIG_MAX_FILE_MB``, default 128 MB): its decompressed
    arrays (an FBX's, an .npz's) and its clip's rotations (frames x joints x 72 bytes)."""
    return int(_env_number(MAX_FILE_MB_ENV, DEFAULT_MAX_FILE_MB, float) * 2 ** 20)


def check_budget(nbytes, path, what="its data"):
    """UnreadableFileError (the file is skipped by a library) when ``nbytes`` of ``what`` exceed
    ``memory_budget``; checked before the allocation."""
    limit = memory_budget()
    if nbytes > limit:
        raise UnreadableFileError(f"{what} would take {_mb(nbytes)} MB of memory, over the {_mb(limit)} MB budget "
                                  f"of a clip file (${MAX_FILE_MB_ENV} raises it)", path)


def max_frames() -> int:
    """The frame cap of a clip: ``$SHAPESIG_MAX_FRAMES`` (default 1,000,000)."""
    return int(_env_number(MAX_FRAMES_ENV, DEFAULT_MAX_FRAMES, int))


def _kind_of(mode) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def _stat(path):
    """(stat result, None) or (None, the one-line reason the file cannot be opened)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None, ("is a symbolic link to a missing file" if os.path.islink(path) else "file not found")
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return None, "is a symbolic link that loops"
        return None, f"cannot be read ({exc.strerror or exc})"
    if not stat.S_ISREG(st.st_mode):
        return None, f"is {_kind_of(st.st_mode)}, not a regular file"
    return st, None


def _checked(path, cap):
    """(stat result, None) of a regular file within the size cap (``cap``), or (None, the one-line reason)."""
    st, problem = _stat(path)
    if problem is None and cap:
        problem = _size_problem(st.st_size, path)
    return (None, problem) if problem else (st, None)


def file_problem(path, cap=True) -> Optional[str]:
    """Why ``path`` would not be opened (one line, without the path), or None: not a regular file (following
    links), cannot be stat'ed, or (``cap``) larger than the size cap."""
    return _checked(os.fspath(path), cap)[1]


def _size_problem(size, path) -> Optional[str]:
    limit = max_file_bytes(path)
    if size <= limit:
        return None
    blend = os.fspath(path).lower().endswith(".blend")
    return (f"is {_mb(size)} MB, over the {_mb(limit)} MB limit for "
            f"{'.blend' if blend else 'clip'} files (${MAX_BLEND_MB_ENV if blend else MAX_FILE_MB_ENV} raises it)")


def _mb(nbytes) -> str:
    mb = nbytes / 2 ** 20
    return f"{mb:,.0f}" if mb >= 10 else f"{mb:.2g}"


def regular_within_cap(path) -> bool:
    """True when ``path`` is a regular file (following links) within the size cap, by one stat; False for
    anything else (``check_file`` then says why)."""
    try:
        return _checked(os.fspath(path), True)[1] is None
    except ValueError:  # a path with a NUL byte
        return False


def check_file(path, cap=True) -> os.stat_result:
    """The stat of a regular file within the size cap (``cap``); UnreadableFileError naming it otherwise."""
    path = os.fspath(path)
    st, problem = _checked(path, cap)
    if problem is not None:
        raise UnreadableFileError(problem, path)
    return st


def open_regular(path, cap=True):
    """A binary file object of a regular file (``check_file`` first: a FIFO is never opened; opened without
    blocking and checked again, so a file swapped for a FIFO meanwhile is refused too)."""
    path = os.fspath(path)
    check_file(path, cap)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise UnreadableFileError(f"cannot be read ({exc.strerror or exc})", path) from None
    try:
        st = os.fstat(fd)
        problem = (None if stat.S_ISREG(st.st_mode) else f"is {_kind_of(st.st_mode)}, not a regular file") or \
            (_size_problem(st.st_size, path) if cap else None)
        if problem:
            raise UnreadableFileError(problem, path)
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_bytes(path, kind, max_line=MAX_LINE_BYTES) -> bytes:
    """The bytes of a text clip file (``kind``: "BVH", "AMC", "ASF"): a regular file within the size cap whose
    lines (ended by LF or CR) are at most ``max_line`` bytes; read in blocks, so a file that breaks a cap is
    refused after at most one block past the cap (UnreadableFileError naming the file)."""
    path = os.fspath(path)
    limit = max_file_bytes(path)
    blocks, total, run = [], 0, 0
    try:
        with open_regular(path) as fh:
            while True:
                block = fh.read(_BLOCK)
                if not block:
                    break
                total += len(block)
                if total > limit:  # the file grew since its stat
                    raise UnreadableFileError(_size_problem(total, path), path)
                run = _longest_run(block, run, max_line, path, kind)
                blocks.append(block)
    except OSError as exc:
        raise UnreadableFileError(f"cannot read {kind} file: {exc.strerror or exc}", path) from None
    return b"".join(blocks)


def _longest_run(block, run, max_line, path, kind) -> int:
    """The length of the line still open at the end of ``block`` (``run``: the length of the one open at its
    start); UnreadableFileError when a line is longer than ``max_line`` bytes."""
    a = np.frombuffer(block, dtype=np.uint8)
    ends = np.flatnonzero((a == 10) | (a == 13))
    if ends.size == 0:
        longest = run = run + len(block)
    else:
        longest = max(run + int(ends[0]), int(np.diff(ends).max(initial=0)) - 1)
        run = len(block) - int(ends[-1]) - 1
        longest = max(longest, run)
    if longest > max_line:
        raise UnreadableFileError(f"has a line longer than {max_line:,} bytes (is this a {kind} file?)", path)
    return run


def check_frames(frames, path, line=None, what="clip", more=False):
    """ParseError when a ``what`` of ``frames`` frames (``more``: at least that many) is over the frame cap
    (``$SHAPESIG_MAX_FRAMES``)."""
    limit = max_frames()
    if frames > limit:
        count = f"more than {limit:,} frames" if more else f"{frames:,} frames"
        raise ParseError(f"{count}, over the {limit:,}-frame limit for a {what} (${MAX_FRAMES_ENV} raises it)",
                         path, line)


def skipped_line(skipped, shown=5) -> str:
    """One line for the files a library skipped (``skipped``: UnreadableFileErrors or paths): 'skipped 4 files
    that are not regular files or cannot be read: x.bvh, z.bvh, d.bvh, l.bvh'."""
    names = [os.path.basename(getattr(s, "path", None) or str(s)) for s in skipped]
    more = ", ..." if len(names) > shown else ""
    noun = "file that is not a regular file or cannot be read" if len(names) == 1 else \
        "files that are not regular files or cannot be read"
    return f"skipped {len(names)} {noun}: {', '.join(names[:shown])}{more}"
