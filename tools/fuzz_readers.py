#!/usr/bin/env python
"""Fuzz the motion readers with mutated real files.

    .venv/bin/python tools/fuzz_readers.py --cases 2000 --seed 1
    .venv/bin/python tools/fuzz_readers.py --cases 300 --seed 7 --targets bvh,blend --batch 50 --keep /tmp/fails
    .venv/bin/python tools/fuzz_readers.py --cases 300 --targets fbx,glb --batch 75
    .venv/bin/python tools/fuzz_readers.py --cases 500 --targets npz
    .venv/bin/python tools/fuzz_readers.py --cases 3000 --targets gltf_uri,deflate_bomb --seed 39

Each case takes a real CMU file from ``tests/data`` (ASF, AMC, BVH, or a .blend written from an AMC take),
applies one mutation (``KINDS``: truncation, garbage bytes, dropped / repeated / swapped lines, wrong
value counts, NaN / inf / huge / malformed numbers, missing sections, latin-1 / UTF-16 / BOM encodings,
CR or CRLF line ends, empty / whitespace / binary files, the wrong format) and reads it:

* ``acclaim``: ``core.io.acclaim.load_acclaim`` (mutated ASF with its real AMC, or mutated AMC with its real
  ASF), in this process, with a per-case alarm;
* ``bvh``: ``readers.bvh.import_bvh`` (Blender's importer) and ``blend``: ``core.io.sources.read`` on a mutated
  .blend (or ``fbx`` / ``glb``: an FBX or GLB written by Blender's exporters, read by its importers in the
  reading child), and ``import_op``: the ``shapesig.import_acclaim`` operator on a mutated ASF/AMC - each in worker
  processes (``--batch`` cases each) so that a crash or a hang of Blender is detected and reported with the
  case that caused it (the worker is restarted after it);
* ``gltf_uri``: a glTF written by Blender with one buffer or image uri made hostile (``GLTF_URI_KINDS``: absolute,
  ``../``, %-encoded, a scheme, a device, a FIFO, a link out, a folder, over the budget, ...) and
  ``deflate_bomb``: FBX and .npz files that unpack to far more than they hold (``BOMB_KINDS``), both read through
  ``core.io.sources.read`` in this process (the reading child reads what passes the checks). A uri that leads
  outside must be refused (following it is a failure: a valid copy of the data lies there), a valid one must
  read; a bomb must be refused without this process growing by more than 256 MB.

A case passes when it ends in a valid Clip (finite rotations that are rotation matrices, finite root
translation) or in one of our errors (``ShapeSigError``: ``ParseError`` / ``CurveError``) whose message is
one line; for the operator, when it finishes with finite F-curves or cancels with one ``ERROR`` report and
leaves ``bpy.data`` as it was. Mutations that keep the file valid (``PRESERVING``: CRLF, BOM, tabs, a latin-1
comment, ...) must give the same rotations as the original **read by the same reader with the same options**
(``differential_case``: like with like, e.g. the raw ``import_bvh`` clip of the original against the raw
``import_bvh`` clip of the mutant, never a trimmed or bone-mapped clip against a raw one). Anything else (another exception, a multi-line
message, NaN, a different result, a hang, a crash) is a failure: listed at the end, exit code 1; ``--keep DIR``
copies the failing cases' files into DIR.

The mutators (``mutate``) and the checks (``check_clip``, ``read_acclaim_case``) are also used by the
bounded fuzz tests in ``tests/core/io/test_fuzz_readers.py`` and ``tests/blender/operators/test_bad_input_in_blender.py``.
"""

import argparse
import collections
import json
import os
import pathlib
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
import traceback

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

# (asf, amc) pairs and BVH files used as seeds
ACCLAIM_PAIRS = (
    ("acclaim/09-run.asf", "acclaim/09_02.amc"),
    ("acclaim/07-walk.asf", "acclaim/07_01.amc"),
    ("acclaim/16.asf", "acclaim/16_15.amc"),
)
BVH_FILES = ("bvh/09_03.bvh", "bvh/09_02.bvh", "acclaim/16_15.bvh")

# mutation kinds; PRESERVING ones keep the file valid (same rotations expected)
KINDS = (
    "truncate", "truncate_line", "garbage_bytes", "insert_garbage", "nul_bytes", "drop_lines",
    "repeat_lines", "swap_lines", "value_count", "nonfinite", "huge", "bad_number", "drop_section",
    "latin1_name", "utf16", "utf16_be", "bom", "crlf", "cr", "tabs", "latin1_comment", "empty",
    "whitespace", "binary", "wrong_format",
)
PRESERVING = {"crlf", "cr", "tabs", "bom", "latin1_comment", "utf16", "utf16_be"}
# .blend, FBX and GLB files are binary: their own kinds ("huge_count": a length or count field made huge)
BLEND_KINDS = ("truncate", "garbage_bytes", "insert_garbage", "zero_block", "bit_flips", "drop_block",
               "repeat_block", "bad_magic", "empty", "binary", "wrong_format")
BINARY_KINDS = {"blend": BLEND_KINDS, "fbx": BLEND_KINDS + ("huge_count",), "glb": BLEND_KINDS + ("huge_count",)}
_MAGIC = {"npz": (b"PK\x05\x06", b"\x93NUMPY"), "blend": (b"BLENDER?", b"NOTBLEND"), "fbx": (b"Kaydara FBX Binary  \x01", b"; FBX 7.4.0 project f"),
          "glb": (b"glTF\x01\x00\x00\x00", b"gltf")}
INTERCHANGE_TARGETS = ("fbx", "glb")  # read through Blender's importers in the reading child
# SMPL/AMASS .npz (read in process, pure numpy): the container's bytes, and its arrays (keys, shapes, values)
NPZ_KINDS = ("truncate", "garbage_bytes", "bit_flips", "bad_magic", "empty", "binary", "wrong_format",
             "npy_huge_shape", "missing_key", "odd_width", "nonfinite", "huge", "object_array", "zero_frames",
             "negative_rate", "huge_rate", "string_rate", "wrong_dims")

_NUM = re.compile(rb"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")
NONFINITE = (b"nan", b"NaN", b"inf", b"-inf", b"Infinity", b"1e999", b"-1e999", b"nan(0x1)")
HUGE = (b"1e308", b"-1e308", b"1.7976931348623157e308", b"1e300", b"-1e300", b"1e38", b"3.5e38",
        b"123456789012345678901234567890", b"1e-320", b"5e-324", b"0", b"-0", b"99999999999")
BAD_NUMBERS = (b"1.2.3", b"abc", b"--1", b"0x10", b"1e", b"+", b"1,5", b"\xff\xfe", b"(1)", b"1_000", b"e5")


# ------------------------------------------------------------------------------------------ mutation


def _lines(data):
    return data.split(b"\n")


def _join(lines):
    return b"\n".join(lines)


def _numbers(data):
    return [m.span() for m in _NUM.finditer(data)]


def _pick_number(data, rng):
    """A numeric token's span: half the time one in the first tenth of the file (headers, hierarchy)."""
    spans = _numbers(data)
    if not spans:
        return None
    if rng.random() < 0.5:
        head = [s for s in spans if s[0] < len(data) // 10] or spans
        return rng.choice(head)
    return rng.choice(spans)


def _replace_number(data, rng, choices):
    span = _pick_number(data, rng)
    if span is None:
        return data + b"\n" + rng.choice(choices)
    return data[:span[0]] + rng.choice(choices) + data[span[1]:]


def _text_of(data):
    return data.decode("utf-8", errors="replace")


def _blocks(lines, fmt):
    """[(first, last)] line ranges of 'sections' to drop: ASF ':' sections and bones, AMC frames and the
    header, BVH joints (to their closing brace) and the MOTION header."""
    out = []
    stripped = [ln.strip() for ln in lines]
    if fmt == "asf":
        starts = [i for i, s in enumerate(stripped) if s.startswith(b":")] + [len(lines)]
        out += [(a, b - 1) for a, b in zip(starts, starts[1:])]
        begins = [i for i, s in enumerate(stripped) if s == b"begin"]
        for i in begins:
            for j in range(i + 1, len(lines)):
                if stripped[j] == b"end":
                    out.append((i, j))
                    break
    elif fmt == "amc":
        frames = [i for i, s in enumerate(stripped) if s.isdigit()]
        out += [(a, b - 1) for a, b in zip(frames, frames[1:] + [len(lines)])]
        if frames:
            out.append((0, frames[0] - 1))
            # one bone's lines in every frame: a "missing channel"
            names = {s.split()[0] for s in stripped[frames[0] + 1:(frames[1] if len(frames) > 1 else len(lines))]
                     if s.split()}
            if names:
                out.append(("bone", sorted(names)[0]))
    elif fmt == "bvh":
        depth_of = []
        depth = 0
        for s in stripped:
            if s == b"{":
                depth += 1
            depth_of.append(depth)
            if s == b"}":
                depth -= 1
        for i, s in enumerate(stripped):
            if s.upper().startswith(b"JOINT") or s.upper().startswith(b"END SITE"):
                d = depth_of[i + 1] if i + 1 < len(lines) else 0
                for j in range(i + 1, len(lines)):
                    if stripped[j] == b"}" and depth_of[j] == d:
                        out.append((i, j))
                        break
            if s.upper() in (b"MOTION", b"HIERARCHY") or s.lower().startswith(b"frame"):
                out.append((i, i))
    return [b for b in out if b[0] != "bone" or fmt == "amc"]


def mutate(data: bytes, kind: str, rng: random.Random, fmt: str) -> bytes:
    """One mutation of ``data`` (a file of format ``fmt``: 'asf', 'amc', 'bvh', or the binary 'blend', 'fbx', 'glb')."""
    if fmt in BINARY_KINDS:
        return _mutate_binary(data, kind, rng, fmt)
    n = len(data)
    if kind == "truncate":
        return data[:rng.randrange(0, max(n, 1))]
    if kind == "truncate_line":
        lines = _lines(data)
        return _join(lines[:rng.randrange(0, len(lines))])
    if kind == "garbage_bytes":
        buf = bytearray(data)
        for _ in range(rng.randint(1, 16)):
            if buf:
                buf[rng.randrange(len(buf))] = rng.randrange(256)
        return bytes(buf)
    if kind == "insert_garbage":
        pos = rng.randrange(0, n + 1)
        return data[:pos] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 64))) + data[pos:]
    if kind == "nul_bytes":
        buf = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            buf.insert(rng.randrange(len(buf) + 1), 0)
        return bytes(buf)
    if kind in ("drop_lines", "repeat_lines", "swap_lines"):
        lines = _lines(data)
        if len(lines) < 2:
            return data
        if kind == "swap_lines":
            a, b = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[a], lines[b] = lines[b], lines[a]
            return _join(lines)
        count = rng.choice((1, 1, 2, 3, 5, 20))
        if rng.random() < 0.5:  # a contiguous run
            a = rng.randrange(len(lines))
            idx = list(range(a, min(a + count, len(lines))))
        else:
            idx = sorted(rng.sample(range(len(lines)), min(count, len(lines))))
        if kind == "drop_lines":
            drop = set(idx)
            return _join([ln for i, ln in enumerate(lines) if i not in drop])
        out = []
        rep = set(idx)
        for i, ln in enumerate(lines):
            out.append(ln)
            if i in rep:
                out.append(ln)
        return _join(out)
    if kind == "value_count":
        lines = _lines(data)
        cand = [i for i, ln in enumerate(lines) if len(_NUM.findall(ln)) >= 1 and len(ln.split()) >= 2]
        if not cand:
            return data + b" 0"
        i = rng.choice(cand)
        tokens = lines[i].split()
        if rng.random() < 0.5 and len(tokens) > 1:
            del tokens[rng.randrange(1, len(tokens))]
        else:
            tokens.insert(rng.randrange(1, len(tokens) + 1), rng.choice((b"0", b"1.5", b"-2")))
        lines[i] = b" ".join(tokens)
        return _join(lines)
    if kind == "nonfinite":
        return _replace_number(data, rng, NONFINITE)
    if kind == "huge":
        return _replace_number(data, rng, HUGE)
    if kind == "bad_number":
        return _replace_number(data, rng, BAD_NUMBERS)
    if kind == "drop_section":
        lines = _lines(data)
        blocks = _blocks(lines, fmt)
        if not blocks:
            return _join(lines[1:])
        block = rng.choice(blocks)
        if block[0] == "bone":
            name = block[1]
            return _join([ln for ln in lines if not (ln.split() and ln.split()[0] == name)])
        a, b = block
        return _join(lines[:a] + lines[b + 1:])
    if kind == "latin1_name":
        # a non-ASCII name, written in latin-1 (not UTF-8): a bone / joint name
        lines = _lines(data)
        key = {"asf": b"name", "bvh": b"JOINT", "amc": None}[fmt]
        cand = [i for i, ln in enumerate(lines) if key is not None and ln.split()[:1] == [key]]
        if not cand:
            cand = [i for i, ln in enumerate(lines) if ln.split() and not _NUM.fullmatch(ln.split()[0])]
        if not cand:
            return data
        i = rng.choice(cand)
        lines[i] = lines[i].rstrip() + "éß".encode("latin-1")
        return _join(lines)
    if kind == "utf16":
        return _text_of(data).encode("utf-16")  # little-endian with BOM
    if kind == "utf16_be":
        return b"\xfe\xff" + _text_of(data).encode("utf-16-be")
    if kind == "bom":
        return b"\xef\xbb\xbf" + data
    if kind == "crlf":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
    if kind == "cr":
        return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r")
    if kind == "tabs":
        lines = _lines(data)
        return _join([b"\t".join(ln.split(b" ")) + (b" \t" if ln.strip() else b"") for ln in lines])
    if kind == "latin1_comment":
        if fmt == "bvh":  # BVH has no comments: trailing spaces instead
            return data.replace(b"\n", b"  \n", 1)
        lines = _lines(data)
        i = rng.randrange(1, len(lines)) if fmt == "amc" else 0
        # ASF: before the first section; AMC: a comment line anywhere
        if fmt == "amc":
            lines.insert(i, "# commentaire: données à 120 Hz".encode("latin-1"))
        else:
            lines.insert(0, "# squelette (données CMU)".encode("latin-1"))
        return _join(lines)
    if kind == "empty":
        return b""
    if kind == "whitespace":
        return rng.choice((b"\n", b"   \n\t\n", b"\r\n\r\n", b" "))
    if kind == "binary":
        size = rng.choice((1, 16, 512, 4096))
        return bytes(rng.randrange(256) for _ in range(size))
    if kind == "wrong_format":
        other = {"asf": "acclaim/09_02.amc", "amc": "acclaim/09-run.asf", "bvh": "acclaim/09-run.asf"}[fmt]
        return (DATA / other).read_bytes()[:rng.choice((200, 5000, 10 ** 9))]
    raise ValueError(f"unknown mutation {kind!r}")


def _huge_count(data, rng, fmt):
    """A count made huge: in a GLB an accessor's ``count`` or the header's length, in an FBX a random aligned
    32-bit field (array lengths, property counts, end offsets are such fields)."""
    import struct

    if fmt == "glb" and data[:4] == b"glTF" and len(data) >= 20:
        n = struct.unpack("<I", data[12:16])[0]
        try:
            doc = json.loads(data[20:20 + n])
        except ValueError:
            doc = None
        if isinstance(doc, dict) and doc.get("accessors") and rng.random() < 0.7:
            rng.choice(doc["accessors"])["count"] = rng.choice((2 ** 31 - 1, 2 ** 32 + 5, 10 ** 12))
            body = json.dumps(doc).encode()
            body += b" " * (-len(body) % 4)
            rest = data[20 + n:]
            return b"glTF" + struct.pack("<II", 2, 20 + len(body) + len(rest)) + \
                struct.pack("<II", len(body), 0x4E4F534A) + body + rest
        return data[:8] + struct.pack("<I", 0xFFFFFFF0) + data[12:]
    buf = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(27, max(28, len(buf) - 4)) & ~3
        buf[i:i + 4] = struct.pack("<I", rng.choice((0x7FFFFFFF, 0xFFFFFFFF, 0x10000000)))
    return bytes(buf)


def _mutate_binary(data, kind, rng, fmt="blend"):
    n = len(data)
    buf = bytearray(data)
    if kind == "huge_count":
        return _huge_count(data, rng, fmt)
    if kind == "truncate":
        return data[:rng.randrange(0, n)]
    if kind == "garbage_bytes":
        for _ in range(rng.randint(1, 64)):
            buf[rng.randrange(12, n)] = rng.randrange(256)  # keep the header: reach the block parser
        return bytes(buf)
    if kind == "insert_garbage":
        pos = rng.randrange(12, n)
        return data[:pos] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 256))) + data[pos:]
    if kind == "zero_block":
        a = rng.randrange(12, n)
        size = rng.choice((8, 64, 1024, 16384))
        buf[a:a + size] = bytes(len(buf[a:a + size]))
        return bytes(buf)
    if kind == "bit_flips":
        for _ in range(rng.randint(1, 32)):
            i = rng.randrange(12, n)
            buf[i] ^= 1 << rng.randrange(8)
        return bytes(buf)
    if kind == "drop_block":
        a = rng.randrange(12, n)
        return data[:a] + data[a + rng.choice((4, 100, 4096, 65536)):]
    if kind == "repeat_block":
        a = rng.randrange(12, n)
        b = min(n, a + rng.choice((4, 100, 4096)))
        return data[:b] + data[a:b] + data[b:]
    if kind == "bad_magic":
        magic = rng.choice(_MAGIC[fmt])
        return magic + data[len(magic):]
    if kind == "empty":
        return b""
    if kind == "binary":
        return bytes(rng.randrange(256) for _ in range(rng.choice((12, 512, 65536))))
    if kind == "wrong_format":
        return (DATA / "acclaim/09_02.amc").read_bytes()
    raise ValueError(f"unknown .blend mutation {kind!r}")


# --------------------------------------------------------------------------------------------- checks


def check_clip(clip):
    """None when ``clip`` is a valid Clip (finite rotation matrices, finite root translation), else why not."""
    from blender_shapesig.core.clip.clip import Clip

    if not isinstance(clip, Clip):
        return f"returned {type(clip).__name__}, not a Clip"
    R = clip.rotations
    if R.ndim != 4 or R.shape[0] < 1 or R.shape[2:] != (3, 3):
        return f"rotations of shape {R.shape}"
    if not np.all(np.isfinite(R)):
        return "non-finite rotations"
    err = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max()
    if err > 1e-5:
        return f"rotations not orthogonal (error {err:.3g})"
    if np.linalg.det(R).min() < 0.99:
        return "rotation with determinant < 1"
    if clip.root_translation is not None and not np.all(np.isfinite(clip.root_translation)):
        return "non-finite root translation"
    return None


def check_error(exc):
    """None when ``exc`` is one of our errors with a one-line message, else why not."""
    from blender_shapesig.core.errors import ShapeSigError

    if not isinstance(exc, ShapeSigError):
        return f"{type(exc).__name__}: {str(exc)[:200]}"
    msg = str(exc)
    if not msg.strip():
        return f"{type(exc).__name__} with an empty message"
    if "\n" in msg or "\r" in msg:
        return f"{type(exc).__name__} with a multi-line message: {msg[:200]!r}"
    if len(msg) > 400:
        return f"{type(exc).__name__} with a {len(msg)}-character message"
    return None


class CaseTimeout(Exception):
    pass


def _alarm(seconds):
    def handler(signum, frame):
        raise CaseTimeout(f"no result after {seconds} s")

    if hasattr(signal, "SIGALRM"):
        signal.signal(signal.SIGALRM, handler)
        signal.alarm(int(seconds))


def _alarm_off():
    if hasattr(signal, "SIGALRM"):
        signal.alarm(0)


def run_case(fn, expected=None, timeout=30):
    """Run ``fn()`` (a reader returning a Clip); returns (outcome, detail): outcome 'ok', 'error' (ours, one
    line) or 'FAIL'. ``expected``: rotations the result must match (preserving mutations)."""
    _alarm(timeout)
    try:
        clip = fn()
    except CaseTimeout as exc:
        return "FAIL", f"hang: {exc}"
    except BaseException as exc:  # noqa: BLE001 - everything is classified
        _alarm_off()
        if isinstance(exc, KeyboardInterrupt):
            raise
        why = check_error(exc)
        if why is None:
            if expected is not None:
                return "FAIL", f"a file-preserving mutation was rejected: {exc}"
            return "error", str(exc)
        return "FAIL", why + " | " + traceback.format_exc(limit=-3).strip().splitlines()[-3].strip()
    finally:
        _alarm_off()
    why = check_clip(clip)
    if why is not None:
        return "FAIL", why
    if expected is not None:
        if clip.rotations.shape != expected.shape or not np.allclose(clip.rotations, expected, atol=1e-9):
            return "FAIL", "a file-preserving mutation changed the result"
    return "ok", f"{clip.frames} frames, {len(clip.bones)} bones"


# ------------------------------------------------------------------------------------ Acclaim (in process)


_ORIGINALS = {}


def differential_case(read, original, mutant, kind, timeout=30, memo=None):
    """Read ``mutant`` with ``read`` (a reader: path -> Clip) and classify it (``run_case``); for a PRESERVING
    ``kind`` the result must equal ``read(original)``: the same reader and options on both files, so a reader
    whose result depends on the file's layout rather than its content (line ends, tabs, encoding) is caught.
    ``memo``: a dict keeping the originals' rotations between cases (keyed by reader and path)."""
    expected = None
    if kind in PRESERVING:
        key = (read, os.fspath(original))
        if memo is None or key not in memo:
            got = read(original)
            if check_clip(got) is not None:
                raise ValueError(f"the original {original} does not read as a valid clip: {check_clip(got)}")
            expected = got.rotations
            if memo is not None:
                memo[key] = expected
        else:
            expected = memo[key]
    return run_case(lambda: read(mutant), expected, timeout)


def read_bvh_raw(path):
    """The ``bvh`` target's reader: Blender's importer through ``readers.bvh.import_bvh`` (no trimming, no bone
    map): the original and its mutants are both read with it."""
    from blender_shapesig.readers.bvh import import_bvh

    return import_bvh(path)


def original_acclaim(asf, amc):
    key = (asf, amc)
    if key not in _ORIGINALS:
        from blender_shapesig.core.io.acclaim import load_acclaim

        _ORIGINALS[key] = load_acclaim(DATA / amc, DATA / asf).rotations
    return _ORIGINALS[key]


def read_acclaim_case(asf_bytes, amc_bytes, folder, expected=None, timeout=30):
    """Write the two files into ``folder`` and load them with ``load_acclaim``; (outcome, detail)."""
    from blender_shapesig.core.io.acclaim import load_acclaim

    asf = os.path.join(folder, "skel.asf")
    amc = os.path.join(folder, "take.amc")
    with open(asf, "wb") as f:
        f.write(asf_bytes)
    with open(amc, "wb") as f:
        f.write(amc_bytes)
    return run_case(lambda: load_acclaim(amc, asf), expected, timeout)


def acclaim_case(rng, kind, folder):
    asf_rel, amc_rel = rng.choice(ACCLAIM_PAIRS)
    asf_bytes, amc_bytes = (DATA / asf_rel).read_bytes(), (DATA / amc_rel).read_bytes()
    which = rng.choice(("asf", "amc"))
    if which == "asf":
        asf_bytes = mutate(asf_bytes, kind, rng, "asf")
    else:
        amc_bytes = mutate(amc_bytes, kind, rng, "amc")
    expected = original_acclaim(asf_rel, amc_rel) if kind in PRESERVING else None
    outcome, detail = read_acclaim_case(asf_bytes, amc_bytes, folder, expected)
    return outcome, detail, f"{which}:{amc_rel if which == 'amc' else asf_rel}"


def _amass_arrays(rng, frames=40):
    """The arrays of an AMASS SMPL-H file: 52 joints' axis angles, the root path, rate, shape and gender."""
    nrng = np.random.default_rng(rng.randrange(2 ** 32))
    return {"poses": nrng.normal(0.0, 0.3, (frames, 156)), "trans": np.cumsum(nrng.normal(0, 0.01, (frames, 3)), 0),
            "mocap_framerate": np.array(120.0), "betas": nrng.normal(0, 1, 16), "gender": np.array("male")}


def _npz_bytes(arrays):
    import io

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _npy_huge_shape(data, rng):
    """The first array's .npy header in the zip made to declare a huge shape (the reader must not allocate it)."""
    i = data.find(b"'shape': (")
    if i < 0:
        return data
    j = data.find(b")", i)
    huge = rng.choice((b"'shape': (4000000000, 156", b"'shape': (99999999999999", b"'shape': (-1, 156"))
    new = huge + b" " * max(0, j - i - len(huge))
    return data[:i] + new[:j - i] + data[j:] if len(new) >= j - i else data[:i] + new + data[j:]


def npz_case(rng, kind, folder, i):
    """One mutated AMASS-like .npz, read through the front door (``sources.read``): (outcome, detail, source)."""
    from blender_shapesig.core.io.sources import read as read_clips

    arrays = _amass_arrays(rng)
    if kind == "missing_key":
        del arrays[rng.choice(("poses", "mocap_framerate"))]
    elif kind == "odd_width":
        arrays["poses"] = arrays["poses"][:, :rng.choice((0, 1, 5, 70, 100))]
    elif kind == "nonfinite":
        arrays["poses"][rng.randrange(40), rng.randrange(156)] = rng.choice((np.nan, np.inf, -np.inf))
    elif kind == "huge":
        arrays[rng.choice(("poses", "trans"))][rng.randrange(40)] = rng.choice((1e308, -1e300, 1e38))
    elif kind == "object_array":
        arrays["poses"] = np.array([None, [1, 2]], dtype=object)
    elif kind == "zero_frames":
        arrays["poses"], arrays["trans"] = arrays["poses"][:0], arrays["trans"][:0]
    elif kind in ("negative_rate", "huge_rate", "string_rate"):
        arrays["mocap_framerate"] = {"negative_rate": np.array(-30.0), "huge_rate": np.array(1e30),
                                     "string_rate": np.array("fast")}[kind]
    elif kind == "wrong_dims":
        arrays["poses"] = arrays["poses"].reshape(40, 52, 3)
    try:
        data = _npz_bytes(arrays)
    except ValueError:  # an object array numpy will not write without pickling: write it pickled
        import io

        buf = io.BytesIO()
        np.savez(buf, **{k: v for k, v in arrays.items()})
        data = buf.getvalue()
    if kind == "npy_huge_shape":
        data = _npy_huge_shape(data, rng)
    elif kind in BLEND_KINDS:
        data = _mutate_binary(data, kind, rng, "npz")
    path = os.path.join(folder, f"{i}.npz")
    pathlib.Path(path).write_bytes(data)

    def read():
        got = read_clips(path)
        for c in got[1:]:
            why = check_clip(c)
            if why:
                raise AssertionError(why)
        return got[0]
    outcome, detail = run_case(read, None, 30)
    return outcome, detail, "amass"


# -------------------------------------------------------------- hostile libraries: glTF uris, deflate bombs

# a buffer (or image) uri of a separate glTF: (kind, uri template, must it be refused?). {outside}: a folder beside
# the glTF's holding a valid copy of its .bin (so a reader that follows the uri would succeed: reading it is the
# failure), {sentinel}: a file outside; FIFOs, links and big files are made in the glTF's folder
GLTF_URI_KINDS = (
    ("own", "base.bin", False), ("own_encoded", "base%2Ebin", False), ("data_uri", "{data}", False),
    ("absolute", "{outside}/base.bin", True), ("dotdot", "../outside/base.bin", True),
    ("encoded_dotdot", "..%2Foutside%2Fbase.bin", True), ("double_encoded", "..%252Foutside%252Fbase.bin", True),
    ("backslash", "..\\outside\\base.bin", True), ("nested_dotdot", "a/b/../../../outside/base.bin", True),
    ("file_scheme", "file://{outside}/base.bin", True), ("http", "http://127.0.0.1:9/base.bin", True),
    ("device", "/dev/zero", True), ("encoded_device", "%2Fdev%2Fzero", True), ("sentinel", "{sentinel}", True),
    ("fifo", "pipe.bin", True), ("link_out", "link_out.bin", True), ("link_device", "link_zero.bin", True),
    ("folder", ".", True), ("missing", "nowhere.bin", True), ("nul", "base.bin%00.png", True),
    ("over_budget", "big.bin", True), ("long", "x" * 5000, True), ("not_text", 12, True),
)
GLTF_URI_WHERE = ("buffer", "image")
# names of files that do not exist inside the folder: a missing image is the importer's to report (it reads nothing)
_MISSING_IMAGE_OK = ("missing", "long", "double_encoded")
BOMB_KINDS = ("fbx_one", "fbx_many", "fbx_wide", "fbx_under", "npz_poses", "npz_extra", "npz_members")
_BOMBS = {}  # (values, level) -> zlib bytes of that many zero doubles


def _zeros_deflated(values):
    if values not in _BOMBS:
        import zlib

        comp, left, chunk, parts = zlib.compressobj(9), values * 8, bytes(1 << 22), []
        while left:
            n = min(left, len(chunk))
            parts.append(comp.compress(chunk[:n]))
            left -= n
        parts.append(comp.flush())
        _BOMBS[values] = b"".join(parts)
    return _BOMBS[values]


def fbx_bomb_bytes(arrays, version=7400):
    """A binary FBX of one top-level record per array (``arrays``: value counts of zlib-compressed zero doubles)
    whose lengths are all right: only a memory budget refuses it."""
    import struct

    wide = version >= 7500
    fmt, sentinel = ("<QQQB", 25) if wide else ("<IIIB", 13)
    out, pos = [], 27
    for k, values in enumerate(arrays):
        packed = _zeros_deflated(values)
        prop = b"d" + struct.pack("<III", values, 1, len(packed)) + packed
        name = f"Curve{k}".encode()
        end = pos + struct.calcsize(fmt) + len(name) + len(prop)
        out.append(struct.pack(fmt, end, 1, len(prop), len(name)) + name + prop)
        pos = end
    head = b"Kaydara FBX Binary  \x00\x1a\x00" + struct.pack("<I", version)
    return head + b"".join(out) + bytes(sentinel) + bytes(160)


def _npz_bomb(kind, rng):
    """An .npz whose arrays unpack to far more than the file (``np.savez_compressed`` of zeros; made once per
    kind and size)."""
    frames = rng.choice((200_000, 1_000_000, 4_000_000))
    members = rng.choice((300, 2000))
    key = (kind, frames if kind != "npz_members" else members)
    if key not in _BOMBS:
        _BOMBS[key] = _npz_bomb_bytes(kind, frames, members)
    return _BOMBS[key]


def _npz_bomb_bytes(kind, frames, members):
    import io

    arrays = {"mocap_framerate": np.array(120.0), "trans": np.zeros((10, 3))}
    if kind == "npz_poses":
        arrays["poses"] = np.zeros((frames, 72), np.float32)
    elif kind == "npz_extra":  # a small body, a huge array beside it
        arrays["poses"] = np.zeros((10, 72))
        arrays["dmpls"] = np.zeros((frames, 64))
    else:  # many members
        arrays["poses"] = np.zeros((10, 72))
        for m in range(members):
            arrays[f"m{m}"] = np.zeros(1)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def bomb_case(rng, kind, folder, i):
    """One deflate bomb (FBX or .npz) read through the front door: our one-line error, the file refused from its
    headers (no allocation: this process's peak stays put), or a clip within the budget."""
    import resource

    from blender_shapesig.core.io.sources import read as read_clips

    if kind.startswith("fbx"):
        version = rng.choice((7400, 7500))
        if kind == "fbx_one":
            arrays = [rng.choice((40_000_000, 120_000_000, 300_000_000))]
        elif kind == "fbx_many":  # many arrays, each small, together over the budget
            arrays = [rng.choice((1_000_000, 3_000_000))] * rng.choice((20, 60))
        elif kind == "fbx_wide":
            arrays = [rng.choice((2_000_000, 8_000_000))] * 4
        else:  # under the budget: then Blender's importer reads it (and finds no armature)
            arrays = [rng.choice((1_000, 50_000))]
        data, ext = fbx_bomb_bytes(arrays, version), "fbx"
    else:
        data, ext = _npz_bomb(kind, rng), "npz"
    path = os.path.join(folder, f"{i}.{ext}")
    pathlib.Path(path).write_bytes(data)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    outcome, detail = run_case(lambda: read_clips(path)[0], None, 120)
    grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    if outcome != "FAIL" and grown > 256:
        outcome, detail = "FAIL", f"this process grew by {grown:.0f} MB reading a {len(data) / 2 ** 20:.1f} MB file"
    return outcome, detail, f"{len(data) / 2 ** 20:.2f} MB"


def gltf_uri_case(rng, kind, base, folder, i):
    """The separate glTF ``base`` (``base.gltf`` + ``base.bin``) with one buffer or image uri made hostile
    (``GLTF_URI_KINDS``), read through the front door in a folder of its own. A uri that leads outside the
    glTF's folder or to anything but a regular file within the budget must be refused; the others read."""
    import base64
    import shutil

    from blender_shapesig.core.io.sources import read as read_clips

    _, template, must_refuse = next(k for k in GLTF_URI_KINDS if k[0] == kind)
    where = rng.choice(GLTF_URI_WHERE) if kind not in ("own", "own_encoded", "data_uri") else "buffer"
    case = os.path.join(folder, f"case{i}")
    lib, outside = os.path.join(case, "lib"), os.path.join(case, "outside")
    os.makedirs(lib)
    os.makedirs(outside)
    shutil.copy(os.path.join(base, "base.bin"), os.path.join(lib, "base.bin"))
    shutil.copy(os.path.join(base, "base.bin"), os.path.join(outside, "base.bin"))
    sentinel = os.path.join(outside, "secret.txt")
    pathlib.Path(sentinel).write_text("not yours")
    os.mkfifo(os.path.join(lib, "pipe.bin"))
    os.symlink(os.path.join(outside, "base.bin"), os.path.join(lib, "link_out.bin"))
    os.symlink("/dev/zero", os.path.join(lib, "link_zero.bin"))
    with open(os.path.join(lib, "big.bin"), "wb") as f:
        f.truncate(1 << 31)  # sparse: 2 GB, over the budget
    data = "data:application/octet-stream;base64," + base64.b64encode(
        pathlib.Path(base, "base.bin").read_bytes()).decode()
    uri = template.format(outside=outside, sentinel=sentinel, data=data) if isinstance(template, str) else template
    doc = json.loads(pathlib.Path(base, "base.gltf").read_text())
    if where == "buffer":
        doc["buffers"][0]["uri"] = uri
    else:
        doc.setdefault("images", []).append({"uri": uri, "name": "skin"})
    path = os.path.join(lib, "take.gltf")
    pathlib.Path(path).write_text(json.dumps(doc))
    outcome, detail = run_case(lambda: read_clips(path)[0], None, 120)
    if outcome == "ok" and must_refuse and not (where == "image" and kind in _MISSING_IMAGE_OK):
        outcome, detail = "FAIL", f"a {where} uri of kind {kind} was followed"
    elif outcome == "error" and not must_refuse:
        outcome, detail = "FAIL", f"a valid {where} uri was refused: {detail}"
    return outcome, detail, f"{where}:{kind}"


def _make_separate_gltf(folder):
    """``folder/base.gltf`` + ``base.bin``: the 09_02 BVH's first 60 frames written by Blender's exporter."""
    code = (
        "import bpy\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "bpy.ops.import_anim.bvh(filepath=%r, update_scene_fps=True)\n"
        "sc = bpy.context.scene; sc.frame_start, sc.frame_end = 1, 60\n"
        "bpy.ops.export_scene.gltf(filepath=%r, export_format='GLTF_SEPARATE', export_frame_range=True)\n"
    ) % (str(DATA / "bvh/09_02.bvh"), os.path.join(folder, "base.gltf"))
    subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=str(ROOT))


# ----------------------------------------------------------------------------- Blender workers (subprocess)


def _worker(target, cases_path, results_path):
    """Run the cases of one batch inside this (bpy) process, appending one JSON line per case."""
    import bpy

    import blender_shapesig
    from blender_shapesig.core.io.sources import read as read_clips

    if target == "import_op":
        blender_shapesig.register()
    with open(cases_path) as f:
        cases = [json.loads(ln) for ln in f if ln.strip()]
    out = open(results_path, "a", buffering=1)
    originals = {}
    for case in cases:
        if target == "bvh":
            outcome, detail = differential_case(read_bvh_raw, case["original"], case["path"], case["kind"],
                                                case["timeout"], originals)
        elif target == "blend" or target in INTERCHANGE_TARGETS:
            def read():
                got = read_clips(case["path"])
                for c in got[1:]:
                    why = check_clip(c)
                    if why:
                        raise AssertionError(why)
                return got[0]
            outcome, detail = run_case(read, None, case["timeout"])  # BLEND_KINDS preserve nothing
        else:
            outcome, detail = _operator_case(bpy, case)
        out.write(json.dumps({"id": case["id"], "outcome": outcome, "detail": detail}) + "\n")
    out.close()


def data_snapshot(bpy):
    """Names of every action, object, armature, mesh, scene and collection in bpy.data."""
    return {coll: {i.name for i in getattr(bpy.data, coll)}
            for coll in ("actions", "objects", "armatures", "meshes", "scenes", "collections")}


def _operator_case(bpy, case):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    before = data_snapshot(bpy)
    reports = []
    try:
        result = bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=case["path"], asf_path=case["asf"])
    except RuntimeError as exc:
        # an operator that reports ERROR raises RuntimeError from bpy.ops; the message is the report
        reports = [ln for ln in str(exc).splitlines() if ln.strip()]
        result = {"CANCELLED"}
    except BaseException as exc:  # noqa: BLE001
        return "FAIL", f"operator raised {type(exc).__name__}: {str(exc)[:200]}"
    after = data_snapshot(bpy)
    if "FINISHED" in result:
        new_actions = after["actions"] - before["actions"]
        if not new_actions:
            return "FAIL", "finished without an action"
        for name in new_actions:
            act = bpy.data.actions[name]
            from blender_shapesig import compat

            for fc in compat.all_action_fcurves(act):
                co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
                fc.keyframe_points.foreach_get("co", co)
                if not np.all(np.isfinite(co)):
                    return "FAIL", f"action {name} has non-finite keys in {fc.data_path}"
        return "ok", f"{len(new_actions)} action(s)"
    if after != before:
        changed = {k: sorted(after[k] ^ before[k]) for k in after if after[k] != before[k]}
        return "FAIL", f"cancelled but bpy.data changed: {changed}"
    text = " ".join(reports)
    if len(reports) > 2:
        return "FAIL", f"multi-line report: {text[:200]}"
    return "error", text[:300]


def run_batches(target, cases, tmp, batch, timeout, log):
    """Run ``cases`` (dicts with 'id') in worker processes of ``batch`` cases; a worker that dies or hangs
    marks its current case 'FAIL' (crash / hang) and a new worker takes the rest."""
    results = {}
    pending = list(cases)
    while pending:
        chunk = pending[:batch]
        cases_path = os.path.join(tmp, f"{target}_cases.jsonl")
        results_path = os.path.join(tmp, f"{target}_results.jsonl")
        with open(cases_path, "w") as f:
            for c in chunk:
                f.write(json.dumps(c) + "\n")
        open(results_path, "w").close()
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", target, cases_path, results_path]
        try:
            proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  timeout=timeout * len(chunk) + 60, cwd=str(ROOT))
            status = proc.returncode
            err = proc.stderr.decode("utf-8", "replace").strip().splitlines()[-1:] if proc.returncode else []
        except subprocess.TimeoutExpired:
            status, err = "timeout", []
        with open(results_path) as f:
            done = [json.loads(ln) for ln in f if ln.strip()]
        for r in done:
            results[r["id"]] = (r["outcome"], r["detail"])
        rest = chunk[len(done):]
        if rest:  # the worker stopped early: the next case crashed or hung it
            culprit = rest[0]
            what = "hang (worker killed after the batch timeout)" if status == "timeout" else \
                f"worker died (exit {status}{', SIGSEGV' if status == -11 else ''}) {' '.join(err)[:200]}".rstrip()
            results[culprit["id"]] = ("FAIL", what)
            log(f"  {target} case {culprit['id']} ({culprit['kind']}): {what}")
            pending = rest[1:] + pending[batch:]
        else:
            pending = pending[batch:]
    return results


def _make_blend(path):
    """A .blend holding the 09_02 take imported by the add-on (an armature with one action), uncompressed."""
    code = (
        "import bpy, sys; sys.path.insert(0, %r)\n"
        "import blender_shapesig; blender_shapesig.register()\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "bpy.ops.shapesig.import_acclaim(filepath=%r, asf_path=%r)\n"
        "bpy.ops.wm.save_as_mainfile(filepath=%r, compress=False)\n"
    ) % (str(ROOT), str(DATA / "acclaim/09_02.amc"), str(DATA / "acclaim/09-run.asf"), path)
    subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=str(ROOT))


def _make_interchange(path, fmt):
    """An FBX or GLB written by Blender's exporter: the 09_02 BVH run on its armature (60 frames), with a small
    skinned cube (the FBX exporter then writes the bind pose)."""
    code = (
        "import bpy\n"
        "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
        "bpy.ops.import_anim.bvh(filepath=%r, update_scene_fps=True)\n"
        "arm = bpy.context.object; sc = bpy.context.scene; sc.frame_start, sc.frame_end = 1, 60\n"
        "bpy.ops.mesh.primitive_cube_add(size=1); cube = bpy.context.object; cube.parent = arm\n"
        "cube.modifiers.new('rig', 'ARMATURE').object = arm\n"
        "cube.vertex_groups.new(name=arm.data.bones[0].name).add(list(range(8)), 1.0, 'REPLACE')\n"
        "if %r == 'fbx':\n"
        "    bpy.ops.export_scene.fbx(filepath=%r, add_leaf_bones=False, bake_anim_use_all_actions=False)\n"
        "else:\n"
        "    bpy.ops.export_scene.gltf(filepath=%r, export_format='GLB')\n"
    ) % (str(DATA / "bvh/09_02.bvh"), fmt, path, path)
    subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=str(ROOT))


# ----------------------------------------------------------------------------------------------- main


def main(argv=None):
    p = argparse.ArgumentParser(description="Fuzz the ASF/AMC, BVH and .blend readers with mutated real files.")
    p.add_argument("--cases", type=int, default=500, help="number of cases (split over the targets)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--targets", default="acclaim,bvh,blend,import_op",
                   help="comma-separated: acclaim, npz, bvh, blend, import_op, fbx, glb, gltf_uri, deflate_bomb "
                        "(default: acclaim, bvh, blend, import_op)")
    p.add_argument("--batch", type=int, default=40, help="cases per Blender worker process")
    p.add_argument("--timeout", type=int, default=30, help="seconds per case before it counts as a hang")
    p.add_argument("--weights", default="acclaim=6,bvh=2,blend=1,import_op=1,fbx=1,glb=1,gltf_uri=1,deflate_bomb=1",
                   help="share of the cases per target")
    p.add_argument("--worker", nargs=3, metavar=("TARGET", "CASES", "RESULTS"), help=argparse.SUPPRESS)
    p.add_argument("--json", action="store_true", help="also print the summary as one JSON object")
    p.add_argument("--keep", metavar="DIR", help="copy the files of failing cases into DIR (to reproduce them)")
    args = p.parse_args(argv)
    if args.worker:
        _worker(*args.worker)
        return 0

    targets = [t.strip() for t in args.targets.split(",") if t.strip()]
    weights = dict(kv.split("=") for kv in args.weights.split(","))
    for t in targets:
        if t not in ("acclaim", "npz", "bvh", "blend", "import_op", "gltf_uri", "deflate_bomb") + INTERCHANGE_TARGETS:
            p.error(f"unknown target {t!r}")
    import importlib.util

    have_bpy = importlib.util.find_spec("bpy") is not None  # the workers import it, not this process
    if not have_bpy:
        dropped = [t for t in targets if t not in ("acclaim", "npz", "deflate_bomb")]
        if dropped:
            print(f"bpy is not importable: skipping {', '.join(dropped)}", file=sys.stderr)
        targets = [t for t in targets if t in ("acclaim", "npz", "deflate_bomb")]
    total_w = sum(float(weights.get(t, 1)) for t in targets)
    counts = {t: int(round(args.cases * float(weights.get(t, 1)) / total_w)) for t in targets}
    rng = random.Random(args.seed)
    t0 = time.time()
    rows = []  # (target, kind, outcome, detail, source)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    def keep(path, name):
        if args.keep:
            import shutil

            os.makedirs(args.keep, exist_ok=True)
            shutil.copyfile(path, os.path.join(args.keep, name))

    with tempfile.TemporaryDirectory(prefix="shapesig_fuzz_") as tmp:
        if counts.get("acclaim"):
            folder = os.path.join(tmp, "acclaim")
            os.makedirs(folder)
            for i in range(counts["acclaim"]):
                kind = KINDS[i % len(KINDS)] if i < len(KINDS) else rng.choice(KINDS)
                outcome, detail, src = acclaim_case(rng, kind, folder)
                rows.append(("acclaim", kind, outcome, detail, src))
                if outcome == "FAIL":
                    log(f"  acclaim {kind} {src}: {detail}")
                    keep(os.path.join(folder, "skel.asf"), f"acclaim-{i}-{kind}.asf")
                    keep(os.path.join(folder, "take.amc"), f"acclaim-{i}-{kind}.amc")
        if counts.get("npz"):
            folder = os.path.join(tmp, "npz")
            os.makedirs(folder)
            for i in range(counts["npz"]):
                kind = NPZ_KINDS[i % len(NPZ_KINDS)] if i < len(NPZ_KINDS) else rng.choice(NPZ_KINDS)
                outcome, detail, src = npz_case(rng, kind, folder, i)
                rows.append(("npz", kind, outcome, detail, src))
                if outcome == "FAIL":
                    log(f"  npz {kind}: {detail}")
                    keep(os.path.join(folder, f"{i}.npz"), f"npz-{i}-{kind}.npz")
        for target, kinds, make in (("deflate_bomb", BOMB_KINDS, None),
                                    ("gltf_uri", [k[0] for k in GLTF_URI_KINDS], _make_separate_gltf)):
            if not counts.get(target):
                continue
            folder = os.path.join(tmp, target)
            os.makedirs(folder)
            if make is not None:
                make(folder)
            for i in range(counts[target]):
                kind = kinds[i % len(kinds)] if i < len(kinds) else rng.choice(kinds)
                if target == "gltf_uri":
                    outcome, detail, src = gltf_uri_case(rng, kind, folder, os.path.join(folder, "cases"), i)
                    import shutil

                    shutil.rmtree(os.path.join(folder, "cases", f"case{i}"), ignore_errors=True)
                else:
                    outcome, detail, src = bomb_case(rng, kind, folder, i)
                    os.remove(os.path.join(folder, f"{i}.{'fbx' if kind.startswith('fbx') else 'npz'}"))
                rows.append((target, kind, outcome, detail, src))
                if outcome == "FAIL":
                    log(f"  {target} {kind} {src}: {detail}")
        for target in ("bvh", "blend", "import_op") + INTERCHANGE_TARGETS:
            n = counts.get(target, 0)
            if not n:
                continue
            folder = os.path.join(tmp, target)
            os.makedirs(folder)
            if target == "blend":
                base = os.path.join(tmp, "base.blend")
                _make_blend(base)
                if args.keep:
                    keep(base, "base.blend")
                sources = [(base, "blend")]
                kinds = BLEND_KINDS
            elif target in INTERCHANGE_TARGETS:
                base = os.path.join(tmp, f"base.{target}")
                _make_interchange(base, target)
                keep(base, f"base.{target}")
                sources = [(base, target)]
                kinds = BINARY_KINDS[target]
            elif target == "bvh":
                sources = [(str(DATA / b), "bvh") for b in BVH_FILES]
                kinds = KINDS
            else:
                sources = [(str(DATA / a), str(DATA / m)) for a, m in ACCLAIM_PAIRS[:2]]
                kinds = KINDS
            cases = []
            for i in range(n):
                kind = kinds[i % len(kinds)] if i < len(kinds) else rng.choice(kinds)
                src = rng.choice(sources)
                case = {"id": f"{target}-{i}", "kind": kind, "timeout": args.timeout}
                if target == "import_op":
                    asf, amc = src
                    which = rng.choice(("asf", "amc"))
                    fmt_path = asf if which == "asf" else amc
                    mutated = mutate(pathlib.Path(fmt_path).read_bytes(), kind, rng, which)
                    path = os.path.join(folder, f"{i}.{which}")
                    pathlib.Path(path).write_bytes(mutated)
                    case["asf"] = path if which == "asf" else asf
                    case["path"] = amc if which == "asf" else path
                    case["source"] = f"{which}:{os.path.basename(fmt_path)}"
                else:
                    fmt = target if target in BINARY_KINDS else "bvh"
                    mutated = mutate(pathlib.Path(src[0]).read_bytes(), kind, rng, fmt)
                    path = os.path.join(folder, f"{i}.{fmt}")
                    pathlib.Path(path).write_bytes(mutated)
                    case["path"] = path
                    case["original"] = src[0]  # read by the same reader in the worker (preserving kinds)
                    case["source"] = os.path.basename(src[0])
                cases.append(case)
            results = run_batches(target, cases, tmp, args.batch, args.timeout, log)
            for c in cases:
                outcome, detail = results[c["id"]]
                if outcome == "FAIL":
                    ext = os.path.splitext(c["path"])[1]
                    keep(c["path"], f"{c['id']}-{c['kind']}{ext}")
                    if target == "import_op":
                        keep(c["asf"], f"{c['id']}-{c['kind']}.asf")
                rows.append((target, c["kind"], outcome, detail, c["source"]))
                if outcome == "FAIL" and "worker died" not in detail and "hang" not in detail:
                    log(f"  {target} {c['kind']} {c['source']}: {detail}")

    seconds = time.time() - t0
    table = collections.defaultdict(collections.Counter)
    for target, kind, outcome, _, _ in rows:
        table[(target, kind)][outcome] += 1
    print(f"fuzz_readers: {len(rows)} cases, seed {args.seed}, {seconds:.1f} s")
    print(f"{'target':10s} {'mutation':15s} {'cases':>6s} {'ok':>5s} {'error':>6s} {'FAIL':>5s}")
    for (target, kind), c in sorted(table.items()):
        print(f"{target:10s} {kind:15s} {sum(c.values()):6d} {c['ok']:5d} {c['error']:6d} {c['FAIL']:5d}")
    by_target = collections.defaultdict(collections.Counter)
    for target, _, outcome, _, _ in rows:
        by_target[target][outcome] += 1
    for target, c in sorted(by_target.items()):
        print(f"{target:10s} {'(all)':15s} {sum(c.values()):6d} {c['ok']:5d} {c['error']:6d} {c['FAIL']:5d}")
    fails = [r for r in rows if r[2] == "FAIL"]
    messages = collections.Counter(re.sub(r"\d+", "N", r[3])[:90] for r in rows if r[2] == "error")
    print("most common error messages (digits as N):")
    for msg, k in messages.most_common(12):
        print(f"  {k:5d}  {msg}")
    if fails:
        print(f"{len(fails)} FAILURES:")
        for target, kind, _, detail, src in fails[:50]:
            print(f"  {target} {kind} {src}: {detail}")
    else:
        print("no failures: every case gave a valid clip or one of our one-line errors")
    if args.json:
        print(json.dumps({"cases": len(rows), "seed": args.seed, "seconds": round(seconds, 1),
                          "targets": {t: dict(c) for t, c in by_target.items()},
                          "failures": [list(r) for r in fails]}))
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
