"""Text and numbers of motion files, shared by the format parsers (ASF, AMC, BVH), file names as data
(``shown_name`` for a terminal or a message, ``plot_name`` for matplotlib) and numbers for JSON (``json_float``)."""

import math
import os

from ..errors import ParseError
from .files import read_bytes

__all__ = ["decode_text", "read_text", "finite_float", "json_float", "shown_name", "plot_name"]


def json_float(x):
    """A float for JSON: NaN and infinities become None (JSON has no NaN); None stays None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def shown_name(name) -> str:
    """A file name for a terminal, a message or a report: control characters escaped (a newline shows as
    ``\\n``, an escape sequence as ``\\x1b``), bytes that are not UTF-8 (decoded with ``surrogateescape``) as
    ``\\xNN``; the rest as is."""
    text = os.fsdecode(name) if isinstance(name, bytes) else str(name)
    text = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    if text.isprintable():  # the common case, without a look at each character
        return text
    return "".join(ch if ch.isprintable() or ch == " " else ch.encode("unicode_escape").decode("ascii")
                   for ch in text)


def plot_name(name) -> str:
    """A name as matplotlib draws it literally: ``shown_name`` with ``$`` escaped (no mathtext)."""
    return shown_name(name).replace("$", r"\$")


def decode_text(data: bytes) -> str:
    """Text of a motion file: UTF-8, or UTF-16 / UTF-32 with a byte-order mark (a UTF-8 BOM is dropped);
    bytes that are not UTF-8 (e.g. latin-1 names in comments) become U+FFFD."""
    for bom, codec in ((b"\xff\xfe\x00\x00", "utf-32-le"), (b"\x00\x00\xfe\xff", "utf-32-be"),
                       (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"), (b"\xef\xbb\xbf", "utf-8")):
        if data.startswith(bom):
            return data[len(bom):].decode(codec, errors="replace")
    return data.decode("utf-8", errors="replace")


def read_text(path_or_text, kind):
    """(text, path or None) of a ``kind`` file ("ASF", "AMC"): bytes and text with a newline (or blank) are
    the file's content; a pathlib.Path or any other str is a path, read within the caps of ``core.io.files``
    (UnreadableFileError for a FIFO, a device, a broken link, a file or a line too long)."""
    if isinstance(path_or_text, (bytes, bytearray)):
        path_or_text = decode_text(bytes(path_or_text))
    if isinstance(path_or_text, str) and ("\n" in path_or_text or path_or_text.strip() == ""):
        return path_or_text, None
    path = os.fspath(path_or_text)
    if not os.path.lexists(path):
        raise ParseError(f"no such {kind} file", path)
    return decode_text(read_bytes(path, kind)), path


def finite_float(token, where, line, what="", limit=math.inf):
    """``token`` as a finite float of magnitude below ``limit``; else ParseError naming ``what`` and the line."""
    prefix = f"{what}: " if what else ""
    try:
        value = float(token)
    except ValueError:
        raise ParseError(f"{prefix}{token!r} is not a number", where, line) from None
    if not math.isfinite(value):
        raise ParseError(f"{prefix}{token!r} is not a finite number", where, line)
    if abs(value) >= limit:
        raise ParseError(f"{prefix}{token!r} is too large for Blender (32-bit floats)", where, line)
    return value
