""".blend files without bpy: the structure checks Blender's reader lacks.

Blender trusts a .blend file's block sizes, struct indices and DNA: a damaged one makes it allocate
absurdly or read outside a block, which aborts the whole process. ``check_blend`` walks the block headers
(through zstd / gzip compression when those modules exist) and the DNA1 block's struct definitions
(``_sdna_problem``) and raises a one-line ParseError first. The Blender half (reading the actions, in a child
process) is ``blender_shapesig.readers.blend_file``.
"""

import os
import struct

from ..errors import ParseError
from .files import open_regular

__all__ = ["check_blend"]


class _Skipper:
    """Sequential reads and forward skips over a (possibly zstd- or gzip-compressed) file."""

    def __init__(self, path):
        self.fh = open_regular(path)  # a regular file within the size cap (core.io.files), never a FIFO
        magic = self.fh.read(4)
        self.fh.seek(0)
        self.stream, self.size = self.fh, os.path.getsize(path)
        if magic == b"\x28\xb5\x2f\xfd":
            try:
                import zstandard
            except ImportError:
                self.stream = None  # cannot look inside: let Blender read it
                return
            self.stream = zstandard.ZstdDecompressor().stream_reader(self.fh)
            self.size = None
        elif magic[:2] == b"\x1f\x8b":
            import gzip

            self.stream = gzip.GzipFile(fileobj=self.fh)
            self.size = None

    def read(self, n):
        return self.stream.read(n)

    def skip(self, n):
        """Skip n bytes; False when the file ends first."""
        if self.size is not None:
            pos = self.fh.tell() + n
            if pos > self.size:
                return False
            self.fh.seek(pos)
            return True
        while n > 0:
            chunk = self.stream.read(min(n, 1 << 20))
            if not chunk:
                return False
            n -= len(chunk)
        return True

    def close(self):
        self.fh.close()


def check_blend(path):
    """Walk the block headers of a .blend file (through zstd/gzip compression when the modules exist) and
    raise ParseError when it is not a .blend file, a block header is damaged, a block runs past the end of
    the file or the end marker is missing. Blender's reader trusts the block sizes: a corrupt one makes it
    abort the whole process (failed allocation), which this check prevents."""
    try:
        reader = _Skipper(path)
    except OSError as exc:
        raise ParseError(f"cannot read .blend file: {exc.strerror or exc}", path) from None
    try:
        if reader.stream is None:
            return
        try:
            head = reader.read(17)
        except Exception:  # noqa: BLE001 - zlib/zstd errors
            raise ParseError("not a .blend file (damaged compressed data)", path) from None
        if not head.startswith(b"BLENDER"):
            raise ParseError("not a .blend file (no BLENDER header)", path)
        if head[7:9].isdigit() and head[9:10] == b"-":  # 4.3+: BLENDER17-01v0500, 64-bit block sizes
            if head[7:9] != b"17" or head[10:12] != b"01" or head[12:13] not in (b"v", b"V"):
                return  # a newer layout: Blender decides
            endian = "<" if head[12:13] == b"v" else ">"
            fmt, code_at, len_at, sdna_at = endian + "4siQqq", 0, 3, 1
            pending = head[17:]
        elif head[7:8] in (b"_", b"-") and head[8:9] in (b"v", b"V"):
            pending = head[12:]
            endian = "<" if head[8:9] == b"v" else ">"
            fmt = endian + ("4siIii" if head[7:8] == b"_" else "4siQii")
            code_at, len_at, sdna_at = 0, 1, 3
        else:
            raise ParseError("not a .blend file (unknown header)", path)
        hsize = struct.calcsize(fmt)
        blocks = 0
        typed = []  # (struct index, size, count, block number) of blocks holding structs
        struct_sizes = None
        while True:
            try:
                raw = pending + reader.read(hsize - len(pending))
            except Exception:  # noqa: BLE001
                raise ParseError("damaged compressed data", path) from None
            pending = b""
            if len(raw) < hsize:
                raise ParseError(f"truncated .blend file (ends inside block {blocks + 1}, no end marker)", path)
            fields = struct.unpack(fmt, raw)
            code, length = fields[code_at], fields[len_at]
            if code == b"ENDB":
                _check_struct_blocks(typed, struct_sizes, path)
                return
            if fields[sdna_at] != 0 and code != b"DNA1":
                typed.append((fields[sdna_at], length, fields[4], blocks + 1))
            if not code[:1].isalpha() or any(c != 0 and not 32 <= c < 127 for c in code):
                raise ParseError(f"corrupt .blend file (damaged header of block {blocks + 1})", path)
            if length < 0:
                raise ParseError(f"corrupt .blend file (block {blocks + 1} has a negative size)", path)
            try:
                if code == b"DNA1" and length < (64 << 20):
                    sdna = reader.read(length)
                    ok = len(sdna) == length
                    if ok:
                        problem, struct_sizes = _sdna_problem(sdna, endian)
                        if problem:
                            raise ParseError(f"corrupt .blend file (damaged DNA block: {problem})", path)
                else:
                    ok = reader.skip(length)
            except ParseError:
                raise
            except Exception:  # noqa: BLE001
                raise ParseError("damaged compressed data", path) from None
            if not ok:
                raise ParseError(f"corrupt or truncated .blend file (block {blocks + 1} "
                                 f"{code.rstrip(bytes(1)).decode('ascii', 'replace')} of {length} bytes runs "
                                 f"past the end of the file)", path)
            blocks += 1
    finally:
        reader.close()


def _check_struct_blocks(typed, struct_sizes, path):
    """Every block of structs must name an existing struct definition and hold ``count * size`` bytes:
    Blender trusts both (a damaged one makes it read outside the block)."""
    if struct_sizes is None:
        return
    for index, length, count, number in typed:
        if not 0 <= index < len(struct_sizes):
            raise ParseError(f"corrupt .blend file (block {number} names struct definition {index} of "
                             f"{len(struct_sizes)})", path)
        if count < 0 or count * struct_sizes[index] > length:
            raise ParseError(f"corrupt .blend file (block {number}: {count} structs of "
                             f"{struct_sizes[index]} bytes in {length} bytes)", path)


def _sdna_problem(data, endian):
    """(why the DNA1 block - the file's struct definitions: SDNA, NAME, TYPE, TLEN, STRC - is damaged or None,
    the size of each struct definition). Blender uses these indices without bounds checks, so a damaged one
    crashes it."""
    pos = 0

    def take(n):
        nonlocal pos
        if n < 0 or pos + n > len(data):
            raise ValueError("truncated")
        out = data[pos:pos + n]
        pos += n
        return out

    def align():
        nonlocal pos
        pos = (pos + 3) & ~3

    def strings(tag):
        if take(4) != tag:
            raise ValueError(f"no {tag.decode()} section")
        (count,) = struct.unpack(endian + "i", take(4))
        if not 0 <= count <= len(data):
            raise ValueError(f"bad {tag.decode()} count")
        out = []
        for _ in range(count):
            end = data.find(b"\0", pos)
            if end < 0:
                raise ValueError("unterminated name")
            word = take(end - pos + 1)[:-1]
            if any(c < 32 or c > 126 for c in word):
                raise ValueError(f"non-text {tag.decode()} entry")
            out.append(word)
        align()
        return out

    try:
        if take(4) != b"SDNA":
            return "no SDNA header", None
        names = strings(b"NAME")
        types = strings(b"TYPE")
        if take(4) != b"TLEN":
            return "no TLEN section", None
        lengths = struct.unpack(endian + "H" * len(types), take(2 * len(types)))
        align()
        if take(4) != b"STRC":
            return "no STRC section", None
        (count,) = struct.unpack(endian + "i", take(4))
        if not 0 <= count <= len(types):
            return "bad struct count", None
        sizes = []
        seen = set()
        for _ in range(count):
            stype, nfields = struct.unpack(endian + "hh", take(4))
            if not 0 <= stype < len(types) or stype in seen or nfields < 0:
                return "bad struct entry", None
            seen.add(stype)
            sizes.append(lengths[stype])
            fields = struct.unpack(endian + "h" * (2 * nfields), take(4 * nfields))
            if any(not 0 <= t < len(types) for t in fields[0::2]) or \
                    any(not 0 <= n < len(names) for n in fields[1::2]):
                return f"struct {types[stype].decode()} has an out-of-range field", None
    except (ValueError, struct.error) as exc:
        return str(exc), None
    return None, sizes
