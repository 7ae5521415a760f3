"""FBX and glTF files without bpy: the checks made before Blender's importers read them (in a child process,
``blender_shapesig.readers.interchange``), and what the file says that the importers do not. ``check_interchange``
refuses in one line what the importers cannot read (an ASCII FBX, a VRM animation, a wrong magic, a truncated
GLB, a glTF whose JSON or buffers are broken) and returns the facts the reader needs: for glTF the animation names
and the **key rate** (glTF has no frame rate: keys are seconds, so the rate is the key spacing of the densest
channel, from each sampler input's ``min``/``max``/``count`` or, without them, its times).
See docs/formats.md.
"""

import base64
import json
import os
import struct

import numpy as np

from ..errors import ParseError
from . import files

__all__ = ["INTERCHANGE_EXTENSIONS", "FBX_MAGIC", "GLB_MAGIC", "check_interchange", "gltf_json", "key_rate",
           "ASCII_FBX_MESSAGE", "check_resources", "resource_path"]

INTERCHANGE_EXTENSIONS = (".fbx", ".glb", ".gltf", ".vrma")
FBX_MAGIC = b"Kaydara FBX Binary  \x00"
GLB_MAGIC = b"glTF"
_JSON_CHUNK, _BIN_CHUNK = 0x4E4F534A, 0x004E4942
FBX_MIN_VERSION = 7100  # Blender's importer reads FBX 7.1 and later
ASCII_FBX_MESSAGE = ("an ASCII FBX file: Blender's FBX importer reads binary FBX only; re-save it as binary FBX "
                     "(in the program that wrote it, or with Autodesk's FBX Converter)")
_FLOAT = 5126  # glTF componentType of float32


def check_interchange(path) -> dict:
    """The facts of an FBX / glTF file (``{"format": "fbx" | "gltf", "version": ..., "animations": [names] (glTF),
    "rate": key rate in frames per second (glTF, None without animations)}``); ParseError (one line, naming the file)
    for a file Blender's importers cannot read. A regular file within the size cap only (``core.io.files``)."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    with files.open_regular(path) as fh:
        head = fh.read(64)
        size = os.fstat(fh.fileno()).st_size
        if ext == ".fbx":
            return _check_fbx(path, head, fh)
        if head[:4] == GLB_MAGIC:
            doc, binary = _glb(path, head, fh, size)
        elif ext == ".glb":
            raise ParseError("not a GLB file (it does not start with 'glTF')", path)
        else:
            fh.seek(0)
            doc, binary = _parse_json(fh.read(), path), None
    return _gltf_facts(path, doc, binary)


def _check_fbx(path, head, fh) -> dict:
    if head.startswith(FBX_MAGIC):
        if len(head) < 27:
            raise ParseError("truncated FBX file (the header is cut off)", path)
        version = struct.unpack("<I", head[23:27])[0]
        if version < FBX_MIN_VERSION:
            raise ParseError(f"FBX version {version / 1000:g} is too old: Blender's importer reads FBX 7.1 and later; "
                             f"re-save it as a newer binary FBX", path)
        fh.seek(0)
        _walk_fbx(fh.read(), version, path)
        return {"format": "fbx", "version": version}
    fh.seek(0)
    text = fh.read(4096)
    try:
        text.decode("utf-8")
        is_text = True
    except UnicodeDecodeError as exc:
        is_text = exc.start > len(text) - 4  # only a character cut at the end of the block
    if is_text and (b"FBX" in text or b"Kaydara" in text or text.lstrip()[:1] == b";"):
        raise ParseError(ASCII_FBX_MESSAGE, path)
    raise ParseError("not an FBX file (it does not start with the binary FBX header)", path)


# FBX property types: fixed sizes, and the arrays' element sizes (an array: length, encoding, compressed length)
_FBX_FIXED = {ord("Y"): 2, ord("C"): 1, ord("I"): 4, ord("F"): 4, ord("D"): 8, ord("L"): 8}
_FBX_ARRAYS = {ord("f"): 4, ord("i"): 4, ord("d"): 8, ord("l"): 8, ord("b"): 1}
_ZLIB_MAX_RATIO = 1032  # deflate expands at most ~1032:1
# the budget counts each unpacked array byte 8 times: Blender's importer (Python arrays and lists, then its own
# copies) took 646 MB at its peak for 12.8 MB of arrays (a 4,000-frame take of 30 bones); docs/robustness.md
_FBX_UNPACKED_COST = 8


def _walk_fbx(data, version, path):
    """Check every node record of a binary FBX before Blender's parser trusts it: each record ends within its parent,
    its property count fits its property bytes, each property fits, each array's stated length fits its (compressed)
    bytes. Blender allocates a stated count before reading it: one damaged count is gigabytes (a hang, not an
    error). ParseError naming the first bad record."""
    wide = version >= 7500
    head = struct.Struct("<QQQB" if wide else "<IIIB")
    size, sentinel = len(data), head.size  # a nested list ends with an all-zero record header

    def bad(what, at):
        raise ParseError(f"damaged FBX file: {what} at byte {at:,}", path)

    stack, pos, unpacked = [size], 27, 0
    while stack:
        end = stack[-1]
        if pos + head.size > end:
            if len(stack) == 1 and pos <= end:
                return  # the file's footer follows the top-level records
            bad("a record runs past its parent", pos)
        rec_end, nprops, props_len, name_len = head.unpack_from(data, pos)
        if rec_end == 0:  # an all-zero header ends the list it is in, at its record's end
            pos += sentinel
            if stack.pop() != pos and stack:
                bad("a nested list does not end where its record does", pos)
            if not stack:
                return
            continue
        body = pos + head.size + name_len
        if not body <= rec_end <= end or body + props_len > rec_end or nprops > props_len:
            bad("a record's lengths do not fit", pos)
        at, stop = body, body + props_len
        for _ in range(nprops):
            kind = data[at] if at < stop else None
            at += 1
            if kind in _FBX_FIXED:
                at += _FBX_FIXED[kind]
            elif kind in _FBX_ARRAYS and at + 12 <= stop:
                length, encoding, packed = struct.unpack_from("<III", data, at)
                raw = length * _FBX_ARRAYS[kind]
                if (encoding == 0 and raw != packed) or (encoding == 1 and raw > packed * _ZLIB_MAX_RATIO + 64) \
                        or encoding > 1:
                    bad(f"an array of {length:,} values does not fit its {packed:,} bytes", at)
                unpacked += raw  # the importer unpacks every array: the budget bounds them whatever the ratio
                files.check_budget(unpacked * _FBX_UNPACKED_COST, path, "its arrays")
                at += 12 + packed
            elif kind in (ord("S"), ord("R")) and at + 4 <= stop:
                at += 4 + struct.unpack_from("<I", data, at)[0]
            else:
                bad("an unknown or cut property", at - 1)
            if at > stop:
                bad("a property runs past its record", at)
        if at < rec_end:  # nested records follow the properties
            stack.append(rec_end)
        pos = at if at < rec_end else rec_end


def _glb(path, head, fh, size):
    """(JSON document, BIN chunk bytes or None) of a GLB file, its header and chunk lengths checked."""
    if len(head) < 20:
        raise ParseError("truncated GLB file (the header is cut off)", path)
    version, length, chunk_len, chunk_type = struct.unpack("<IIII", head[4:20])
    if version != 2:
        raise ParseError(f"glTF version {version} is not supported (glTF 2.0 only)", path)
    if length > size:
        raise ParseError(f"truncated GLB file: the header says {length:,} bytes, the file has {size:,}", path)
    if chunk_type != _JSON_CHUNK or 20 + chunk_len > length:
        raise ParseError("damaged GLB file: its first chunk is not a JSON chunk within the file", path)
    fh.seek(20)
    doc = _parse_json(fh.read(chunk_len), path)
    binary = None
    at = 20 + chunk_len + (-chunk_len % 4)
    if at + 8 <= length:
        fh.seek(at)
        bin_len, bin_type = struct.unpack("<II", fh.read(8))
        if bin_type == _BIN_CHUNK:
            if at + 8 + bin_len > length:
                raise ParseError("damaged GLB file: its binary chunk reaches past the end of the file", path)
            binary = fh.read(bin_len)
    return doc, binary


def _parse_json(data, path):
    try:
        doc = json.loads(data.decode("utf-8-sig"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise ParseError(f"damaged glTF file: its JSON cannot be read ({str(exc).splitlines()[0][:80]})", path) from None
    if not isinstance(doc, dict):
        raise ParseError("damaged glTF file: its JSON is not an object", path)
    return doc


def gltf_json(path) -> dict:
    """The JSON document of a .gltf / .glb file (checked as ``check_interchange`` does)."""
    path = os.fspath(path)
    with files.open_regular(path) as fh:
        head = fh.read(64)
        if head[:4] == GLB_MAGIC:
            return _glb(path, head, fh, os.fstat(fh.fileno()).st_size)[0]
        fh.seek(0)
        return _parse_json(fh.read(), path)


def resource_path(uri, path):
    """The file a glTF's ``uri`` names as Blender's importer resolves it (``\\`` as ``/``, %-decoded, normalised,
    beside the glTF), or the one-line reason it is refused: a scheme (``file:``, ``http:``), an absolute path, a
    way out of the glTF's folder (``..``, a link pointing elsewhere) or a NUL byte."""
    from urllib.parse import unquote, urlsplit

    try:
        scheme = urlsplit(uri).scheme
    except ValueError:
        scheme = "?"
    if scheme:
        return None, "is not a file beside the glTF (it has a scheme)"
    name = os.path.normpath(unquote(uri.replace("\\", "/")))
    if "\x00" in name or os.path.isabs(name) or name == ".." or name.startswith(".." + os.sep) or \
            os.path.splitdrive(name)[0]:
        return None, "is not a file in the glTF's folder"
    folder = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    full = os.path.join(os.path.dirname(os.path.abspath(path)), name)
    if os.path.commonpath([folder, os.path.realpath(full)]) != folder:
        return None, "leads out of the glTF's folder"
    return full, None


def check_resources(doc, path):
    """Every file a glTF makes its importer open (``buffers[]`` and ``images[]`` uris), checked before Blender
    sees them: inside the file (a GLB chunk, a ``data:`` uri) or a regular file in the glTF's own folder, all of
    them within the memory budget (``files.check_budget``); a missing image is the importer's to report (it reads
    nothing), a missing buffer is refused here. ParseError naming the uri otherwise."""
    total = 0
    for key in ("buffers", "images"):
        for i, item in enumerate(_list(doc, key, path)):
            uri = item.get("uri") if isinstance(item, dict) else None
            if uri is None:
                continue
            if not isinstance(uri, str):
                raise ParseError(f"damaged glTF file: the uri of {key[:-1]} {i} is not text", path)
            if uri.startswith("data:"):
                continue
            shown = uri if len(uri) <= 60 else uri[:57] + "..."
            full, problem = resource_path(uri, path)
            if problem is None and (key == "buffers" or os.path.lexists(full)):
                problem = files.file_problem(full)
            if problem is not None:
                raise ParseError(f"its {key[:-1]} {shown!r} {problem}", path)
            if full is not None and os.path.lexists(full):
                total += os.stat(full).st_size
    files.check_budget(total, path, "the files it refers to")


def _list(doc, key, path):
    value = doc.get(key, [])
    if not isinstance(value, list):
        raise ParseError(f"damaged glTF file: {key!r} is not a list", path)
    return value


def _gltf_facts(path, doc, binary) -> dict:
    used = doc.get("extensionsUsed") or []
    if isinstance(used, list) and "VRMC_vrm_animation" in used:
        raise ParseError("a VRM animation (.vrma) moves plain nodes, not an armature's bones; Blender's glTF importer "
                         "makes no armature of it, so it cannot be read (import it with the VRM add-on and save a "
                         ".blend)", path)
    asset = doc.get("asset")
    version = str(asset.get("version", "")) if isinstance(asset, dict) else ""
    if not version.startswith("2"):
        raise ParseError(f"glTF version {version or '(none)'} is not supported (glTF 2.0 only)", path)
    check_resources(doc, path)
    animations = _list(doc, "animations", path)
    names = []
    for i, anim in enumerate(animations):
        if not isinstance(anim, dict):
            raise ParseError(f"damaged glTF file: animation {i} is not an object", path)
        names.append(str(anim.get("name") or ""))
    rate = key_rate(doc, binary, path) if animations else None  # (a count past its buffer is named first)
    files.check_budget(_animation_bytes(doc) * _FBX_UNPACKED_COST, path, "its animation keys")
    return {"format": "gltf", "version": version, "animations": names, "rate": rate}


_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_COUNT = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def _animation_bytes(doc) -> int:
    """The bytes of every animation sampler's input and output accessors (what the importer turns into keys),
    from the accessors' counts and types; counted like an FBX's arrays against the memory budget."""
    accessors = doc.get("accessors") if isinstance(doc.get("accessors"), list) else []
    used = set()
    for anim in doc.get("animations") or []:
        samplers = anim.get("samplers") if isinstance(anim, dict) else None
        for sampler in samplers if isinstance(samplers, list) else []:
            if isinstance(sampler, dict):
                used.update(i for i in (sampler.get("input"), sampler.get("output")) if isinstance(i, int))
    total = 0
    for i in used:
        acc = accessors[i] if 0 <= i < len(accessors) and isinstance(accessors[i], dict) else {}
        count = acc.get("count")
        if isinstance(count, int) and count > 0:
            total += count * _COMPONENT_BYTES.get(acc.get("componentType"), 4) * _TYPE_COUNT.get(acc.get("type"), 1)
    return total


def key_rate(doc, binary, path) -> float:
    """The key rate of a glTF document: 1 / the key spacing of its densest channel (the smallest mean spacing of a
    sampler input with two keys or more), rounded to an integer when within 1 % of one; 30 when every channel has
    a single key (a still pose has no rate). ParseError when the inputs are damaged or the rate is not 1 to 1000."""
    accessors = _list(doc, "accessors", path)
    spacing, longest = [], 0.0
    for anim in _list(doc, "animations", path):
        for sampler in anim.get("samplers", []) if isinstance(anim.get("samplers", []), list) else []:
            acc = _item(accessors, sampler.get("input") if isinstance(sampler, dict) else None, "accessor", path)
            count = acc.get("count")
            if not isinstance(count, int) or count < 1:
                raise ParseError("damaged glTF file: an animation input has no key count", path)
            lo, hi = _min_max(doc, acc, binary, path)
            longest = max(longest, hi)
            if count >= 2 and hi > lo:
                spacing.append((hi - lo) / (count - 1))
    if not spacing:
        return 30.0
    rate = 1.0 / min(spacing)
    rate = float(round(rate)) if abs(rate - round(rate)) <= 0.01 * rate else round(rate, 6)
    if not 1.0 <= rate <= 1000.0:
        raise ParseError(f"animation keys {1000.0 / rate:.3g} ms apart are not a frame rate (1 to 1000 per second)", path)
    files.check_frames(int(longest * rate) + 1, path)
    return rate


def _item(items, index, what, path):
    if not isinstance(index, int) or not 0 <= index < len(items) or not isinstance(items[index], dict):
        raise ParseError(f"damaged glTF file: a missing {what} ({index!r})", path)
    return items[index]


def _min_max(doc, acc, binary, path):
    """(first, last) key time of a sampler input: its ``min``/``max``, else read from its buffer."""
    lo, hi = acc.get("min"), acc.get("max")
    if isinstance(lo, list) and isinstance(hi, list) and len(lo) == len(hi) == 1:
        try:
            lo, hi = float(lo[0]), float(hi[0])
        except (TypeError, ValueError):
            raise ParseError("damaged glTF file: an animation input's min/max are not numbers", path) from None
    else:
        times = _times(doc, acc, binary, path)
        lo, hi = float(times.min()), float(times.max())
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0 or hi < lo:
        raise ParseError("damaged glTF file: animation key times are not increasing seconds", path)
    return lo, hi


def _times(doc, acc, binary, path) -> np.ndarray:
    """The float32 key times of an accessor, every offset and length checked against its buffer."""
    if acc.get("componentType") != _FLOAT or acc.get("type") != "SCALAR" or "bufferView" not in acc:
        raise ParseError("damaged glTF file: an animation input is not a list of float times", path)
    view = _item(_list(doc, "bufferViews", path), acc["bufferView"], "buffer view", path)
    data = _buffer(doc, view.get("buffer"), binary, path)
    start = _offset(view.get("byteOffset", 0), path) + _offset(acc.get("byteOffset", 0), path)
    stride = view.get("byteStride") or 4
    count = acc["count"]
    if not isinstance(stride, int) or stride < 4 or start + stride * (count - 1) + 4 > min(
            len(data), _offset(view.get("byteOffset", 0), path) + _offset(view.get("byteLength", 0), path)):
        raise ParseError(f"damaged glTF file: an accessor of {count:,} keys reaches past its buffer", path)
    return np.ndarray((count,), dtype="<f4", buffer=data, offset=start, strides=(stride,)).astype(np.float64)


def _offset(value, path):
    if not isinstance(value, int) or value < 0:
        raise ParseError("damaged glTF file: a byte offset is not a non-negative integer", path)
    return value


def _buffer(doc, index, binary, path) -> bytes:
    buf = _item(_list(doc, "buffers", path), index, "buffer", path)
    uri = buf.get("uri")
    if uri is None:
        if binary is None:
            raise ParseError("damaged glTF file: a buffer refers to a binary chunk the file lacks", path)
        return binary
    if not isinstance(uri, str):
        raise ParseError("damaged glTF file: a buffer's uri is not text", path)
    if uri.startswith("data:"):
        try:
            return base64.b64decode(uri.partition(",")[2], validate=True)
        except ValueError:
            raise ParseError("damaged glTF file: a buffer's data uri is not base64", path) from None
    name, problem = resource_path(uri, path)
    if problem is None:
        problem = files.file_problem(name)
    if problem is not None:
        raise ParseError(f"its buffer {uri!r} {problem}", path)
    with files.open_regular(name) as fh:
        return fh.read()
