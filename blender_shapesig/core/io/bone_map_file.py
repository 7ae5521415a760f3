"""The bone-map file format: a small JSON object ``{"bone": "joint", ...}`` (keys starting with ``#`` are comments,
e.g. ``"#rig"``) of at most ``MAX_MAP_BYTES``, read (``read_bytes``, ``decode``) and written (``dumps``, ``write``)
here; what a valid map is (canonical joints, each once) is ``core.rigs.maps.check_map``, which
``core.rigs.load_map`` / ``parse_map`` / ``map_json`` / ``save_map`` apply on top. See docs/rigs.md.
"""

import json
import os

from ..errors import ParseError
from .files import open_regular

__all__ = ["MAX_MAP_BYTES", "read_bytes", "decode", "dumps", "write"]

# A saved bone map is a small JSON object (a few KB for any rig); larger files are refused unread.
MAX_MAP_BYTES = 1 << 20


def dumps(body: dict) -> str:
    """A map's JSON text as saved: one entry a line, in the order given, a final newline."""
    return json.dumps(body, indent=1, sort_keys=False) + "\n"


def write(path, text: str) -> str:
    """Write a map's text (``dumps``) to ``path``; returns the path."""
    path = os.fspath(path)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path


def decode(text, where: str = "bone map"):
    """A saved map's JSON text (str or UTF-8 bytes) as its JSON value, the ``#`` comment keys of an object dropped.
    Every defect is one ``ParseError`` naming ``where``: not UTF-8, over ``MAX_MAP_BYTES``, not JSON, nested too
    deeply for the parser."""
    if len(text) > MAX_MAP_BYTES:
        raise ParseError(f"the bone map is larger than {MAX_MAP_BYTES // 2 ** 20} MB; a bone map is a small "
                         f"JSON object", where)
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ParseError(f"the bone map is not UTF-8 text (byte {exc.start})", where) from None
    try:
        data = json.loads(text)
    except RecursionError:
        raise ParseError("the bone map is nested too deeply to be a bone map", where) from None
    except json.JSONDecodeError as exc:
        raise ParseError(f"the bone map is not valid JSON ({exc.msg}, line {exc.lineno})", where) from None
    except ValueError as exc:  # e.g. a number too long to convert
        raise ParseError(f"the bone map is not valid JSON ({str(exc).splitlines()[0][:120]})", where) from None
    if isinstance(data, dict):
        data = {k: v for k, v in data.items() if not str(k).startswith("#")}
    return data


def read_bytes(path) -> bytes:
    """A saved map file's bytes (at most ``MAX_MAP_BYTES + 1``); files over ``MAX_MAP_BYTES`` and files that are not
    regular files (a FIFO, a device, a dangling link: ``open_regular``, which never blocks) are refused unread, one
    ``ParseError`` naming the file."""
    path = os.fspath(path)
    try:
        if os.path.getsize(path) > MAX_MAP_BYTES:
            raise ParseError(f"the bone map is larger than {MAX_MAP_BYTES // 2 ** 20} MB; a bone map is a small "
                             f"JSON object", path)
        with open_regular(path, cap=False) as fh:
            return fh.read(MAX_MAP_BYTES + 1)
    except OSError as exc:
        raise ParseError(f"cannot read the bone map ({exc.strerror or exc})", path) from None
