"""Where clips come from: the one front door for reading clips by name (pure Python, never imports bpy).
``ClipSpec`` (a parsed CLIP argument: ``FILE.blend#ACTION``, skeleton, crop, frame rate, trim), discovery in
folders (``EXTENSIONS``, ``discover``), the **cache key recipe** (``ClipSpec.key``, on the content keys of
``file_keys``: ``file_key``, ``clip_key``), ``read(spec)`` through the reader registry (the ``.blend`` reader is
registered by the Blender layer) and ``LibraryItem``. See docs/architecture.md, "A file to a ranked row".
"""

import dataclasses
import os
from dataclasses import dataclass
from typing import Callable, Iterator, List, Optional, Sequence

from ..clip.clip import Clip
from ..errors import ParseError, ShapeSigError, UnreadableFileError
from ..clip.prepare import check_fps
from ..clip.trim import TRIM_MODES, trim_clip
from . import files
from .file_keys import clip_key, file_key, file_keys_record, load_file_keys
from .registry import EXTENSIONS, NAMED_CLIPS, extensions_text, reader_for, register_reader

__all__ = [
    "EXTENSIONS", "ClipSpec", "LibraryItem", "register_reader", "reader_for", "discover",
    "read", "read_one", "after_read", "clip_address", "bone_map_key", "file_key", "clip_key", "clip_item", "library", "Library", "trim_ends", "trim_key",
    "unique_labels", "file_identity", "load_file_keys", "file_keys_record",
]


# changes when the trim rule changes (cached signatures of trimmed clips are then recomputed)
_TRIM_VERSION = ":1"



# ----------------------------------------------------------------------------------------------- specs

@dataclass(frozen=True)
class ClipSpec:
    """One named source: ``path`` (a file), ``action`` (for ``FILE.blend#ACTION``, ``FILE.glb#ANIMATION``: the
    types of ``registry.NAMED_CLIPS``), ``asf`` (skeleton of an
    ``.amc``; None: the only .asf beside it), ``start``/``end`` (crop, inclusive frame numbers), ``fps``
    (override of the file's frame rate), ``trim`` ("auto": drop detected rest-pose / ramp frames at both ends,
    ``core.clip.trim``; "none": keep every frame; an explicit ``start`` keeps the head, an explicit ``end`` the tail).
    Every field that changes the clips read is part of ``key()``."""

    path: str
    action: Optional[str] = None
    asf: Optional[str] = None
    start: Optional[int] = None
    end: Optional[int] = None
    fps: Optional[float] = None
    trim: str = "auto"
    # "auto" | "none" | a saved map's path: the comparison space across rigs (core.rigs.apply_bone_map)
    bone_map: str = "auto"

    def __post_init__(self):
        if self.trim not in TRIM_MODES:
            raise ShapeSigError(f"trim must be one of {', '.join(TRIM_MODES)}, got {self.trim!r}")
        if self.fps is not None:
            object.__setattr__(self, "fps", check_fps(self.fps, "frame rate"))

    @classmethod
    def parse(cls, text, **options) -> "ClipSpec":
        """``FILE.blend#ACTION`` (any type of ``NAMED_CLIPS``) -> path and action; any other text is a path, and so
        is a text naming a clip file that exists (a file named ``walk.glb#copy.glb`` is that file, not the
        animation ``copy.glb`` of ``walk.glb``). ``options``: the other fields."""
        text = os.fspath(text)
        path, sep, action = text.rpartition("#")
        if sep and path.lower().endswith(NAMED_CLIPS) and not (text.lower().endswith(EXTENSIONS)
                                                                  and os.path.lexists(text)):
            return cls(path, action or None, **options)
        return cls(text, None, **options)

    @property
    def ext(self) -> str:
        return os.path.splitext(self.path)[1].lower()

    @property
    def name(self) -> str:
        """The display name: the action for ``FILE.blend#ACTION`` (or ``FILE.glb#ANIMATION``), else the file name
        without extension."""
        return self.action if self.action is not None else os.path.splitext(os.path.basename(self.path))[0]

    @property
    def text(self) -> str:
        """The spec as a user writes it (``FILE.blend#ACTION`` or the path)."""
        return self.path if self.action is None else f"{self.path}#{self.action}"

    def check(self) -> "ClipSpec":
        """ParseError when the file is missing, a folder or of an unknown type (the command line's messages);
        UnreadableFileError when it is not a regular file or over the size cap (``core.io.files``). One stat
        for a readable file; the messages' tests only for the others."""
        if self.ext in EXTENSIONS and files.regular_within_cap(self.path):
            return self
        if not os.path.lexists(self.path):
            raise ParseError("file not found", self.path)
        if os.path.isdir(self.path):
            raise ParseError(f"is a folder, expected a {extensions_text()} file", self.path)
        if self.ext not in EXTENSIONS:
            raise ParseError(f"unsupported file type {self.ext or '(none)'}; expected {extensions_text()} "
                             f"(FILE#ACTION picks one clip of a file that holds several)", self.path)
        files.check_file(self.path)  # UnreadableFileError: a FIFO, a device, a broken link, over the size cap
        return self

    def skeleton(self) -> Optional[str]:
        """The skeleton file of an ``.amc`` (``find_asf``), None for other formats."""
        if self.ext != ".amc":
            return None
        from .acclaim import find_asf  # (scipy is imported only when an .amc is read)

        return find_asf(self.path, self.asf)

    def key(self) -> str:
        """The cache key: the file's content (``file_key``), the skeleton's content, the action, the crop,
        the frame rate, the trim rule and the bone map. Equal keys mean equal clips."""
        skeleton = self.skeleton()
        extra = (f"asf={file_key(skeleton) if skeleton else ''}|action={self.action}|start={self.start}"
                 f"|end={self.end}|fps={self.fps}|{trim_key(self.trim)}")
        extra += f"|bone_map={bone_map_key(self.bone_map)}"
        if self.ext == ".blend":
            extra += "|axes=world"  # actions read in the world's axes (the armature object's matrix) since wave 4
        return file_key(self.path, extra)


def trim_key(trim) -> str:
    """The key part of a trim rule (with the rule's version: a new rule recomputes trimmed clips)."""
    return f"trim={trim}{_TRIM_VERSION if trim != 'none' else ''}"


def bone_map_key(bone_map) -> str:
    """The key part of a ``bone_map`` option: the tables' version for "auto", a saved map's content."""
    from ..rigs import TABLES_VERSION

    if bone_map in (None, "none"):
        return "none"
    if bone_map == "auto":
        return f"auto{TABLES_VERSION}"
    return f"{TABLES_VERSION}:" + file_key(bone_map) if os.path.isfile(bone_map) else f"missing:{bone_map}"


def clip_address(spec_text, name, source="") -> tuple:
    """``(text, action)``: how a user names one clip read from the source ``spec_text``. A clip of a whole file
    that holds several (``NAMED_CLIPS``) is ``FILE#ACTION``, its action taken from the reader's ``source``
    (``FILE#ACTION``) when it says so, else from its ``name``: the FBX / glTF readers name the clip of a file of
    one animation after the file, which is then named by itself (action None); any other spec is itself."""
    spec = ClipSpec.parse(spec_text)
    if spec.action is not None:
        return spec.text, spec.action
    if spec.ext not in NAMED_CLIPS:
        return spec.text, None
    for prefix in (spec.path, os.path.abspath(spec.path)):
        if source.startswith(prefix + "#"):
            action = source[len(prefix) + 1:]
            return f"{spec.path}#{action}", action
    if not name or (spec.ext != ".blend" and name == os.path.splitext(os.path.basename(spec.path))[0]):
        return spec.path, None
    return f"{spec.path}#{name}", name


def discover(paths, recursive=True, skipped=None) -> List[str]:
    """Clip specs for files and ``FILE.blend#ACTION`` given directly and clip files found in folders (each
    folder's files sorted by path), without repeats. Only regular files (links to them too) within the size cap
    are taken: the others (a FIFO, a device, a dangling or looping link, an unreadable or too large file) are
    never opened and go to ``skipped`` (UnreadableFileErrors) when given. ShapeSigError for a path that does not
    exist."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    out, seen = [], set()
    for p in paths:
        p = os.fspath(p)
        path = ClipSpec.parse(p).path
        if os.path.isdir(p):
            walker = os.walk(p) if recursive else [(p, [], os.listdir(p))]
            found = []
            for root, dirs, names in walker:
                if _cache_folder(root, names):
                    dirs[:] = []  # a signature cache (its entries are .npz files too) or any tagged cache
                    continue
                found += [os.path.join(root, n) for n in names if n.lower().endswith(EXTENSIONS)]
            specs = sorted(found)
        elif os.path.lexists(path):
            specs = [p]
        else:
            raise ShapeSigError(f"library path {path!r} does not exist")
        for s in specs:
            if s in seen:
                continue
            seen.add(s)
            problem = files.file_problem(ClipSpec.parse(s).path)
            if problem is None:
                out.append(s)
            elif skipped is not None:
                skipped.append(UnreadableFileError(problem, s))
    return out


def _cache_folder(folder, names) -> bool:
    """True for a cache folder a library scan skips: the signature cache's own (``blender_shapesig-cache``) and
    any folder marked by a ``CACHEDIR.TAG`` (the Cache Directory Tagging convention)."""
    return os.path.basename(os.path.normpath(folder)) == "blender_shapesig-cache" or "CACHEDIR.TAG" in names


# ---------------------------------------------------------------------------------------------- readers

def _read_bvh(spec: ClipSpec) -> List[Clip]:
    from .bvh import load_bvh

    # our bpy-free reader: the clip Blender's importer gives (readers.bvh.import_bvh), ~100x faster
    return [load_bvh(spec.path)]


def _read_amc(spec: ClipSpec) -> List[Clip]:
    from .acclaim import load_acclaim

    # Blender's armature axes: the space every reader gives (comparable with .bvh and .blend clips)
    return [load_acclaim(spec.path, spec.skeleton(), axes="blender")]


def _read_npz(spec: ClipSpec) -> List[Clip]:
    from .smpl import load_smpl

    return [load_smpl(spec.path)]


register_reader(".amc", _read_amc)
register_reader(".bvh", _read_bvh)
register_reader(".npz", _read_npz)


def read(spec, **options) -> List[Clip]:
    """Every clip a source names (a ``.blend`` may hold several actions), cropped and at the spec's frame rate.

    ``spec``: a ClipSpec or the text of one (``options`` then fill its other fields)."""
    spec = spec if isinstance(spec, ClipSpec) else ClipSpec.parse(spec, **options)
    spec.check()
    reader = reader_for(spec.ext)
    try:
        clips = list(reader(spec))
    except (ShapeSigError, KeyboardInterrupt, SystemExit):
        raise
    except MemoryError:  # a file no cap caught: this file only, one line
        raise ParseError("the file needs more memory than this machine gives", spec.path) from None
    except Exception as exc:  # noqa: BLE001 - any other failure of a reader is one line for this file
        text = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise ParseError(f"could not read the file ({text})", spec.path) from None
    if not clips:
        raise ParseError("no armature action found" if spec.action is None else f"no action {spec.action!r}",
                         spec.path)
    return after_read(clips, fps=spec.fps, trim=spec.trim, start=spec.start, end=spec.end, bone_map=spec.bone_map)


def after_read(clips, fps=None, trim="none", start=None, end=None, bone_map="none") -> List[Clip]:
    """The steps after a reader, in order, for files and the Blender layer's actions alike: the frame rate
    (``fps`` overrides), the trim rule ("auto": ``trim_ends``, keeping an explicit end), the crop (scene frames
    ``start``..``end``, inclusive, clamped to each clip: one crop applies to clips of any length, e.g. the command
    line's --start/--end; a clip it misses entirely is refused) and the bone map into the comparison space
    (``rigs.apply_bone_map``)."""
    if fps is not None:
        clips = [dataclasses.replace(c, fps=float(fps)) for c in clips]
    if trim == "auto" and (start is None or end is None):
        clips = [trim_ends(c, start, end) for c in clips]
    if start is not None or end is not None:
        clips = [c.crop(start, end, clamp=True) for c in clips]
    if bone_map not in (None, "none"):
        from ..rigs import apply_bone_map

        clips = [apply_bone_map(c, bone_map) for c in clips]
    return clips


def trim_ends(clip, start=None, end=None):
    """``trim.trim_clip`` keeping the end(s) cropped explicitly (an explicit ``start`` / ``end`` wins; the crop
    itself is the caller's). Used by ``read`` and by the Blender library's actions."""
    out = trim_clip(clip)
    start = clip.frame_start if start is not None else out.frame_start
    end = clip.frame_end if end is not None else out.frame_end
    if (start, end) != (out.frame_start, out.frame_end):
        trim = dict(out.meta["trim"], kept=(start, end))  # what the rule cut, the explicit end(s) kept
        out = dataclasses.replace(clip.crop(start, end), meta=dict(out.meta, trim=trim))
    return out


def read_one(spec, **options) -> Clip:
    """The one clip a source names; ShapeSigError when it holds several (pick one with ``FILE#ACTION``)."""
    spec = spec if isinstance(spec, ClipSpec) else ClipSpec.parse(spec, **options)
    clips = read(spec)
    if len(clips) != 1:
        names = ", ".join(c.name for c in clips[:5])
        raise ShapeSigError(f"{spec.text} holds {len(clips)} actions ({names}{', ...' if len(clips) > 5 else ''}); "
                            f"pick one with FILE#ACTION")
    return clips[0]


# ---------------------------------------------------------------------------------------------- library

@dataclass
class LibraryItem:
    """A library member that may not be loaded yet: ``key`` identifies its content (it changes whenever the
    data changes), ``load()`` returns its clip(s) (a Clip or a list: a .blend file holds several).
    ``path``/``action``: where it comes from (the file as given, the action name or None)."""

    name: str
    key: str
    load: Callable[[], object]
    source: str = ""
    path: Optional[str] = None
    action: Optional[str] = None

    def clips(self) -> List[Clip]:
        out = self.load()
        if isinstance(out, Clip):
            return [out]
        out = list(out)
        for c in out:
            if not isinstance(c, Clip):
                raise ShapeSigError(f"library item {self.name!r}: loader returned {type(c).__name__}, not a Clip")
        return out


def clip_item(clip: Clip) -> LibraryItem:
    """A library item for a clip already in memory, keyed by its data (or ``meta["cache_key"]``)."""
    return LibraryItem(clip.name, clip.meta.get("cache_key") or clip_key(clip), (lambda c=clip: c), clip.source)


def spec_item(spec: ClipSpec, load: Optional[Callable] = None) -> LibraryItem:
    """The library item of one source: keyed by ``spec.key()`` and read (by ``load(spec)``, default ``read``)
    only when the key is not cached."""
    loader = load or read
    return LibraryItem(spec.name, spec.key(), lambda: loader(spec), spec.text, spec.path, spec.action)


def library(paths, recursive=True, load=None, **options) -> List[LibraryItem]:
    """Library items for sources (files, ``FILE.blend#ACTION``, folders searched for clip files), each once
    (``Library``: a source that cannot be keyed raises; files the readers never open are left out). ``options``:
    ClipSpec fields for every source (``asf``, ``start``, ``end``, ``fps``, ``trim``); files read only when not cached."""
    return Library(paths, lambda text: ClipSpec.parse(text, **options), unique=True, recursive=recursive,
                   load=load).items()


class Library:
    """A library as a person names it: the items of ``sources`` (clip files, ``FILE#ACTION``, folders, ready
    ``ClipSpec``s), keyed one at a time by ``members()`` (a folder's file hashed at its turn, for a progress bar),
    with the sources it left out and why (the command line's ``rank`` and ``index``, ``dedupe`` and ``library``
    make theirs with it). ``spec(text)``: the ``ClipSpec`` of a path (default ``ClipSpec.parse``);
    ``load(spec)``: how an item reads its clips (default ``sources.read``). Files the readers never open (not
    regular files, over a cap: ``core.io.files``) and a folder's files that cannot be keyed (an ``.amc`` without its
    skeleton) are skipped into ``skipped``; a source named directly that does not exist raises, and with ``strict``
    (the default) so does one that cannot be keyed. ``unique``: a source met again (named twice, or named and in a
    folder given too) is left out. ``skipped``: ShapeSigErrors, ``skipped_lines()`` one line each naming its
    source."""

    def __init__(self, sources, spec: Optional[Callable] = None, *, strict=True, unique=False, recursive=True,
                 load=None):
        self.sources = [sources] if isinstance(sources, (str, os.PathLike, ClipSpec)) else list(sources)
        self.spec, self.strict, self.unique = spec or ClipSpec.parse, strict, unique
        self.recursive, self.load = recursive, load
        self.skipped: List[ShapeSigError] = []
        self._named = {}  # id of a skipped error -> the source text it is about
        self._found = None

    def found(self) -> list:
        """(source, text, named) per member, folders' files found (once; a folder that does not exist raises)."""
        if self._found is None:
            self._found, seen = [], set()
            for src in self.sources:
                folder = not isinstance(src, ClipSpec) and os.path.isdir(src)
                for one in discover([src], self.recursive, skipped=self.skipped) if folder else [src]:
                    text = one.text if isinstance(one, ClipSpec) else os.fspath(one)
                    if not (self.unique and text in seen):
                        seen.add(text)
                        self._found.append((one, text, not folder))
        return self._found

    def __len__(self) -> int:  # members found, keyed or not (a progress bar's total)
        return len(self.found())

    def members(self, holes=False) -> Iterator[Optional[LibraryItem]]:
        """Each member's item, keyed at its turn, in the order given (a folder's files sorted by path); ``holes``:
        None for a member that was skipped (one step of a progress bar each)."""
        for one, text, named in self.found():
            got = list(self._keyed(one, text, named))
            yield from got or ([None] if holes else [])

    def items(self) -> List[LibraryItem]:
        return list(self.members())

    def _keyed(self, src, text, named):
        try:
            spec = src if isinstance(src, ClipSpec) else self.spec(text)
            item = spec_item(spec.check() if named else spec, self.load)  # a folder's files: checked by discover
        except UnreadableFileError as exc:
            self.skipped.append(exc)
            return
        except OSError as exc:  # a file that went away or cannot be read while its key was made
            self.skipped.append(UnreadableFileError(f"cannot be read ({exc.strerror or exc})", text))
            return
        except ShapeSigError as exc:
            missing = isinstance(exc, ParseError) and not os.path.lexists(ClipSpec.parse(text).path)
            if named and (self.strict or missing):
                raise
            self._named[id(exc)] = text
            self.skipped.append(exc)
            return
        yield item

    def skipped_lines(self) -> List[str]:
        """One line per skipped source, naming it."""
        out = []
        for exc in self.skipped:
            text, line = self._named.get(id(exc)), str(exc)
            out.append(f"{text}: {line}" if text and text not in line else line)
        return out


def as_items(members: Sequence) -> List[LibraryItem]:
    """LibraryItems for a mixed sequence of LibraryItems and Clips."""
    items = []
    for x in members:
        if isinstance(x, LibraryItem):
            items.append(x)
        elif isinstance(x, Clip):
            items.append(clip_item(x))
        else:
            raise ShapeSigError(f"library members must be Clips or LibraryItems, got {type(x).__name__}")
    return items


def unique_labels(specs):
    """Display labels of clip files that tell any two apart: the file name (with ``#ACTION`` for a .blend
    action), with as many parent folders as needed when two files share a name (two ``16_15.bvh``)."""
    parts = [os.path.normpath(ClipSpec.parse(t).path).split(os.sep) for t in specs]
    tails = [ClipSpec.parse(t).action for t in specs]
    depth = [1] * len(specs)
    while True:
        labels = ["/".join(p[-d:]) + (f"#{a}" if a else "") for p, d, a in zip(parts, depth, tails)]
        clash = {lb for lb in labels if labels.count(lb) > 1}
        grow = [i for i, lb in enumerate(labels) if lb in clash and depth[i] < len(parts[i])]
        if not grow:
            return labels
        for i in grow:
            depth[i] += 1


def file_identity(spec) -> str:
    """What tells a clip file apart from one put in its place: its path, size and modification time ("" when it
    cannot be read)."""
    path = os.path.abspath(ClipSpec.parse(spec).path)
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return ""
    return f"{path}|{st.st_size}|{st.st_mtime_ns}"
