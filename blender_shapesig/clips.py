"""Load clips from files (a CLIP argument of the command line, folder libraries, operators).

``load_clips(spec, asf=None, fps=None, space="armature") -> list[Clip]``:

Space: by default every clip comes in the package's comparison space, each bone's rotation relative to its
rest pose expressed in Blender's armature axes (``action_io.to_armature_space``; ``meta["rotation_space"] ==
"armature"``), so an .amc loaded here, the same take imported with ``shapesig.import_acclaim`` and read from
the file, and its BVH conversion are comparable. ``space="native"`` keeps what the source gives: ASF axes for
.amc, pose-bone rotations for .bvh and .blend. An action in a .blend with no armature that has its bones is
read in pose space (``meta["rotation_space"] == "pose"``).

* ``FILE.amc``: ``core.acclaim.load_acclaim`` (skeleton: ``asf``, else the only .asf beside the .amc), 120 fps;
  in Blender axes (Z up, meters) unless ``space="native"``.
* ``FILE.bvh``: Blender's own BVH importer (``bpy.ops.import_anim.bvh``, rotate_mode 'NATIVE', default axis
  conversion: BVH Y up / -Z forward -> Blender Z up, scale 1) into a temporary scene that is removed with
  the imported armature and action afterwards; read with ``action_io.read_action`` (pose-bone rotations in
  each bone's rest frame; rest frames include the Y-up -> Z-up conversion, so local rotations are those of the
  file conjugated by each bone's rest orientation). fps = 1 / the file's ``Frame Time``. Every frame is kept
  (the Daz-friendly CMU files' first rest-pose frame too: crop it with ``Clip.crop``).
* ``FILE.blend``: every action in the file that animates pose bones; ``FILE.blend#ACTION``: that one. The
  actions (and the file's armature objects, for bone rotation modes and order) are appended with
  ``bpy.data.libraries.load``, read, and every data-block the append created is removed again — in a child
  process (``_blend_child``), so that a damaged file that crashes Blender's reader is a ParseError here
  (``SHAPESIG_BLEND_IN_PROCESS=1``: in this process).

``fps`` overrides the clips' frame rate. Errors are ``ParseError`` with a one-line message.
"""

import contextlib
import io
import os

import bpy

from . import action_io, compat
from .core.acclaim import decode_text, load_acclaim
from .core.errors import ParseError, ShapeSigError

__all__ = ["load_clips", "split_spec", "import_bvh", "check_bvh"]

EXTENSIONS = (".bvh", ".amc", ".blend")


def split_spec(spec):
    """(path, action name or None) for ``FILE.blend#ACTION`` / plain paths."""
    spec = os.fspath(spec)
    if "#" in spec:
        path, _, action = spec.rpartition("#")
        if path.lower().endswith(".blend"):
            return path, action
    return spec, None


SPACES = ("armature", "native")


def load_clips(spec, asf=None, fps=None, space="armature"):
    if space not in SPACES:
        raise ShapeSigError(f"space must be one of {', '.join(SPACES)}, got {space!r}")
    path, action_name = split_spec(spec)
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise ParseError(f"unknown clip type {ext or '(no extension)'!r}; expected .bvh, .amc, .blend or "
                         f"FILE.blend#ACTION", path)
    if not os.path.isfile(path):
        raise ParseError("no such file", path)
    if ext == ".amc":
        clips = [load_acclaim(path, asf, axes="blender" if space == "armature" else "asf")]
    elif ext == ".bvh":
        clips = [import_bvh(path, space=space)]
    else:
        clips = _load_blend(path, action_name, space=space)
    if fps is not None:
        for c in clips:
            c.fps = float(fps)
    return clips


# ------------------------------------------------------------------------------------------- BVH


def _bvh_text(path):
    """(text, plain): the file's text (UTF-8; UTF-16/32 or UTF-8 with a byte-order mark; else latin-1) and
    whether it is plain UTF-8 without a BOM, the only encoding Blender's importer reads."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise ParseError(f"cannot read BVH file: {exc.strerror or exc}", path) from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff", b"\xef\xbb\xbf", b"\x00\x00\xfe\xff")):
        return decode_text(data), False
    try:
        return data.decode("utf-8"), True
    except UnicodeDecodeError:
        return data.decode("latin-1"), False


_FLOAT32_MAX = 3.4028234e38


def _bvh_number(token, path, line):
    """A BVH number that Blender can key: finite and within float32 range (else ParseError)."""
    try:
        x = float(token)
    except ValueError:
        raise ParseError(f"{token!r} is not a number", path, line) from None
    if x != x or x in (float("inf"), float("-inf")):
        raise ParseError(f"{token!r} is not a finite number", path, line)
    if abs(x) >= _FLOAT32_MAX:
        raise ParseError(f"{token!r} is too large for Blender (32-bit floats)", path, line)
    return x


def check_bvh(path):
    """Validate a BVH file's structure and numbers before Blender's importer sees it (its failures are
    tracebacks); returns the frame time. Raises ParseError naming the line."""
    lines = _bvh_text(path)[0].splitlines()
    if not any(ln.strip() for ln in lines):
        raise ParseError("empty BVH file", path)
    channels, depth, joints = 0, 0, 0
    motion_line = None
    seen_header = False
    for no, raw in enumerate(lines, 1):
        tokens = raw.split()
        if not tokens:
            continue
        key = tokens[0].upper()
        if not seen_header:
            if key != "HIERARCHY":
                raise ParseError("expected HIERARCHY (is this a BVH file?)", path, no)
            seen_header = True
            continue
        if key in ("ROOT", "JOINT"):
            joints += 1
        elif key == "{":
            depth += 1
        elif key == "}":
            depth -= 1
            if depth < 0:
                raise ParseError("unbalanced '}'", path, no)
        elif key == "CHANNELS":
            try:
                n = int(tokens[1])
            except (IndexError, ValueError):
                raise ParseError("bad CHANNELS line", path, no) from None
            if len(tokens) != n + 2:
                raise ParseError(f"CHANNELS says {n} but lists {len(tokens) - 2}", path, no)
            channels += n
        elif key == "OFFSET":
            if len(tokens) != 4:
                raise ParseError("OFFSET needs 3 numbers", path, no)
            for v in tokens[1:]:
                _bvh_number(v, path, no)
        elif key == "MOTION":
            motion_line = no
            break
    if motion_line is None or joints == 0:
        raise ParseError("no MOTION section (truncated BVH?)" if joints else "no joints (is this a BVH file?)", path)
    if depth != 0:
        raise ParseError("unbalanced braces in HIERARCHY", path, motion_line)
    head = [(i, ln) for i, ln in enumerate(lines[motion_line:], motion_line + 1) if ln.strip()][:2]
    if len(head) < 2:
        raise ParseError("MOTION section without Frames / Frame Time", path, motion_line)
    (n1, frames_line), (n2, time_line) = head
    frames_line, time_line = " ".join(frames_line.split()), " ".join(time_line.split())
    try:
        if not frames_line.lower().startswith("frames"):
            raise ValueError
        frames = int(frames_line.split(":", 1)[1])
    except (IndexError, ValueError):
        raise ParseError("expected 'Frames: N'", path, n1) from None
    try:
        if not time_line.lower().startswith("frame time"):
            raise ValueError
        frame_time = float(time_line.split(":", 1)[1])
    except (IndexError, ValueError):
        raise ParseError("expected 'Frame Time: seconds'", path, n2) from None
    if not frame_time > 0 or frame_time != frame_time or frame_time == float("inf"):
        raise ParseError("'Frame Time' must be a positive number", path, n2)
    if frames < 1:
        raise ParseError("no frames", path, n1)
    data = [(i, ln) for i, ln in enumerate(lines[n2:], n2 + 1) if ln.strip()]
    if len(data) < frames:
        raise ParseError(f"{len(data)} frames of motion data for 'Frames: {frames}' (truncated file?)", path)
    for i, ln in data[:frames]:
        values = ln.split()
        if len(values) != channels:
            raise ParseError(f"{len(values)} values for {channels} channels", path, i)
        for v in values:
            _bvh_number(v, path, i)
    return frame_time


@contextlib.contextmanager
def _quiet_fds():
    """Send the process's stdout and stderr (file descriptors 1 and 2: Blender's C-level messages and the
    importer's prints) to a temporary file for the duration."""
    import sys
    import tempfile

    saved = []
    with tempfile.TemporaryFile() as sink:
        try:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            for fd in (1, 2):
                saved.append((fd, os.dup(fd)))
                os.dup2(sink.fileno(), fd)
        except OSError:
            pass
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                yield
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)


def _ensure_bvh_importer():
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
        return
    except (AttributeError, KeyError):
        pass
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    try:
        bpy.ops.import_anim.bvh.get_rna_type()
    except (AttributeError, KeyError):
        raise ShapeSigError("Blender's BVH importer (io_anim_bvh) is not available") from None


def _id_collections():
    """Names of the bpy.data collections of removable data-blocks (not the UI: screens, window managers,
    workspaces)."""
    out = []
    for prop in bpy.data.bl_rna.properties:
        name = prop.identifier
        if prop.type != "COLLECTION" or name in ("window_managers", "screens", "workspaces"):
            continue
        if hasattr(getattr(bpy.data, name, None), "remove"):
            out.append(name)
    return out


def _id_snapshot():
    return {(coll, id_.as_pointer()) for coll in _id_collections() for id_ in getattr(bpy.data, coll)}


def _remove_new_ids(before):
    """Remove every data-block created since the snapshot ``before``."""
    new = [id_ for coll in _id_collections() for id_ in getattr(bpy.data, coll, ())
           if (coll, id_.as_pointer()) not in before]
    scenes = [i for i in new if isinstance(i, bpy.types.Scene)]
    others = [i for i in new if not isinstance(i, bpy.types.Scene)]
    if others:
        bpy.data.batch_remove(others)
    for sc in scenes:
        with contextlib.suppress(RuntimeError, ReferenceError):
            bpy.data.scenes.remove(sc)


def import_bvh(path, name=None, space="armature"):
    """One BVH file as a Clip through Blender's importer, leaving the file as it was."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ParseError("no such file", path)
    frame_time = check_bvh(path)
    _ensure_bvh_importer()
    text, plain = _bvh_text(path)
    if not plain:
        # Blender's importer reads UTF-8 only: give it a UTF-8 copy of a BOM / UTF-16 / latin-1 file
        import tempfile

        with tempfile.TemporaryDirectory(prefix="shapesig_bvh_") as tmp:
            copy = os.path.join(tmp, os.path.basename(path))
            with open(copy, "w", encoding="utf-8", newline="") as fh:
                fh.write(text)
            clip = _import_checked_bvh(copy, frame_time, name, shown=path, space=space)
        clip.source = path
        return clip
    return _import_checked_bvh(path, frame_time, name, space=space)


def _import_checked_bvh(path, frame_time, name=None, shown=None, space="armature"):
    shown = shown or path
    before = _id_snapshot()
    window = getattr(bpy.context, "window", None)
    old_scene = window.scene if window is not None else None
    old_selected, old_active = None, None
    if window is None:
        # no window: import into the current scene, remembering selection and active object
        old_selected = [o for o in bpy.context.scene.objects if o.select_get()]
        old_active = bpy.context.view_layer.objects.active
    try:
        if window is not None:
            window.scene = bpy.data.scenes.new("shapesig_bvh_import")
        try:
            with _quiet_fds():  # the importer prints progress; Blender prints failures to stderr
                result = bpy.ops.import_anim.bvh(filepath=path, rotate_mode="NATIVE", frame_start=1,
                                                 use_fps_scale=False, update_scene_fps=False,
                                                 update_scene_duration=False, global_scale=1.0)
        except RuntimeError as exc:
            lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip() and not ln.startswith("Location")]
            raise ParseError(f"Blender's BVH importer failed: {lines[-1] if lines else exc}", shown) from None
        if "FINISHED" not in result:
            raise ParseError("Blender's BVH importer did not finish", shown)
        armatures = [o for o in bpy.data.objects
                     if ("objects", o.as_pointer()) not in before and o.type == "ARMATURE"]
        if len(armatures) != 1 or armatures[0].animation_data is None or armatures[0].animation_data.action is None:
            raise ParseError("the BVH importer made no animated armature", shown)
        arm = armatures[0]
        fps = 1.0 / frame_time
        if abs(fps - round(fps)) < 1e-3:
            fps = float(round(fps))  # "Frame Time: 0.00833333" means 120 fps
        clip = action_io.read_action(arm.animation_data.action, armature=arm, fps=fps,
                                     name=name or os.path.splitext(os.path.basename(path))[0],
                                     space="armature" if space == "armature" else "pose")
        clip.source = path
        clip.meta["format"] = "bvh"
        return clip
    finally:
        if window is not None:
            window.scene = old_scene
        _remove_new_ids(before)
        if old_selected is not None:
            for o in old_selected:
                with contextlib.suppress(ReferenceError, RuntimeError):
                    o.select_set(True)
            with contextlib.suppress(ReferenceError, RuntimeError):
                bpy.context.view_layer.objects.active = old_active


# ----------------------------------------------------------------------------------------- .blend


def _best_armature(action, armatures):
    """The armature that uses the action, else the one sharing the most bones with it (or None)."""
    for arm in armatures:
        if arm.animation_data is not None and arm.animation_data.action == action:
            return arm
    bones = set(action_io._bone_channels(compat.all_action_fcurves(action)))
    best, score = None, 0
    for arm in armatures:
        n = len(bones & {b.name for b in arm.data.bones})
        if n > score:
            best, score = arm, n
    if best is not None and score == len(bones):
        return best
    return None


class _Skipper:
    """Sequential reads and forward skips over a (possibly zstd- or gzip-compressed) file."""

    def __init__(self, path):
        self.fh = open(path, "rb")
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
    import struct

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
    import struct

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


# "1": read .blend clip files in this process (faster by the start-up of a child; a damaged file can then crash
# this process). Default: a child process reads them (see _blend_child).
BLEND_IN_PROCESS_ENV = "SHAPESIG_BLEND_IN_PROCESS"
BLEND_CHILD_TIMEOUT = 600.0


def _load_blend(path, action_name, space="armature"):
    check_blend(path)
    if os.environ.get(BLEND_IN_PROCESS_ENV) == "1":
        return _load_blend_here(path, action_name, space)
    return _load_blend_isolated(path, action_name, space)


def _child_command(args_json):
    """The command that runs _blend_child: the Blender binary in background mode inside Blender, else this
    Python (which has the bpy module)."""
    import sys

    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_blend_child.py")
    binary = getattr(bpy.app, "binary_path", "") or ""
    if binary and os.path.basename(binary).lower().startswith("blender"):
        return [binary, "--background", "--factory-startup", "--python-exit-code", "3", "--python", script,
                "--", args_json]
    return [sys.executable, script, args_json]


def _load_blend_isolated(path, action_name, space):
    """_load_blend_here in a child process: a .blend that crashes Blender gives a ParseError, not a crash."""
    import json
    import subprocess
    import sys
    import tempfile

    from . import _blend_child
    from .core.clip import Clip

    package_root = os.path.dirname(os.path.abspath(__file__))
    with tempfile.TemporaryDirectory(prefix="shapesig_blend_") as tmp:
        out = os.path.join(tmp, "clips.npz")
        args = json.dumps({"path": os.path.abspath(path), "action": action_name, "space": space, "out": out,
                           "package_dir": os.path.dirname(package_root),
                           "package": os.path.basename(package_root), "sys_path": [p for p in sys.path if p]})
        try:
            proc = subprocess.run(_child_command(args), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, timeout=BLEND_CHILD_TIMEOUT)
        except subprocess.TimeoutExpired:
            raise ParseError(f"reading the .blend file took more than {BLEND_CHILD_TIMEOUT:.0f} s", path) from None
        except OSError as exc:
            raise ParseError(f"cannot start a process to read the .blend file: {exc}", path) from None
        if not os.path.isfile(out):
            if proc.returncode < 0 or proc.returncode > 128:
                raise ParseError("corrupt .blend file: Blender crashed reading it (damaged data)", path)
            last = [ln for ln in proc.stderr.decode("utf-8", "replace").splitlines() if ln.strip()]
            raise ParseError(f"could not read the .blend file ({last[-1] if last else f'exit {proc.returncode}'})",
                             path)
        clips, error = _blend_child.read_result(out, Clip)
    if error is not None:
        raise ParseError(error)
    return clips


def _load_blend_here(path, action_name, space="armature"):
    try:
        with bpy.data.libraries.load(path, link=False) as (data_from, _to):
            available = list(data_from.actions)
            objects = list(data_from.objects)
    except (OSError, RuntimeError) as exc:
        raise ParseError(f"cannot read .blend file: {str(exc).splitlines()[0] if str(exc) else exc}", path) from None
    except UnicodeDecodeError:
        raise ParseError("corrupt .blend file (a name is not valid UTF-8 text)", path) from None
    if action_name is not None and action_name not in available:
        shown = ", ".join(available[:8]) + (" ..." if len(available) > 8 else "")
        raise ParseError(f"no action {action_name!r} in the file (it has: {shown or 'none'})", path)
    wanted = [action_name] if action_name is not None else available
    if not wanted:
        raise ParseError("the file has no actions", path)
    before = _id_snapshot()
    try:
        with bpy.data.libraries.load(path, link=False) as (data_from, data_to):
            data_to.actions = list(wanted)
            data_to.objects = objects
        loaded_objects = [o for o in data_to.objects if o is not None]
        armatures = [o for o in loaded_objects if o.type == "ARMATURE"]
        clips = []
        for want, action in zip(wanted, data_to.actions):
            if action is None:
                continue
            if not action_io._bone_channels(compat.all_action_fcurves(action)):
                if action_name is not None:
                    raise ParseError(f"action {action_name!r} animates no pose bones", path)
                continue
            arm = _best_armature(action, armatures)
            clip = action_io.read_action(action, armature=arm, name=want,
                                         bones=None if arm is None else _animated_bones(action, arm),
                                         space="armature" if (space == "armature" and arm is not None) else "pose")
            clip.source = f"{path}#{want}"
            clip.meta["format"] = "blend"
            clips.append(clip)
        if not clips:
            raise ParseError("no action in the file animates pose bones", path)
        return clips
    except ShapeSigError as exc:
        if isinstance(exc, ParseError):
            raise
        raise ParseError(str(exc), path) from None
    except UnicodeDecodeError:
        raise ParseError("corrupt .blend file (a name is not valid UTF-8 text)", path) from None
    finally:
        _remove_new_ids(before)


def _animated_bones(action, arm):
    """The armature's bones (armature order) that the action animates."""
    keyed = set(action_io._bone_channels(compat.all_action_fcurves(action)))
    return [b.name for b in arm.data.bones if b.name in keyed]
