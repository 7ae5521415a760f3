"""The signature cache's folder on disk (``SignatureCache`` opens it): where it lives (``default_cache_dir``:
``$SHAPESIG_CACHE_DIR``, the user's cache folder, else ``private_cache_dir``), its own subfolder ``CACHE_SUBDIR``
marked by a ``CACHEDIR.TAG`` the cache wrote, the names of the files it writes there, the checks that refuse a folder
that is not its own or not safe (a symbolic link, another user's, writable by others) and the sweep of what is not a
regular file or was left half-written. See docs/search.md, "The index and its cache".
"""

import errno
import os
import re
import stat

from .local.store import LOCAL_PACK

__all__ = ["default_cache_dir", "private_cache_dir", "CACHE_ENV", "CACHE_SUBDIR"]

CACHE_ENV = "SHAPESIG_CACHE_DIR"
_PACK = "light_pack.bin"  # the light pack's file name (see SignatureCache.save_pack)
# The cache's own folder inside the folder a user names (--cache, $SHAPESIG_CACHE_DIR, the Index Folder), its
# marker (the Cache Directory Tagging format: backup tools skip the folder) and the names of what it writes.
CACHE_SUBDIR = "blender_shapesig-cache"
PRIVATE_PREFIX = "blender_shapesig-"  # the per-user fallback folder's name: this and the user's id
_TAG = "CACHEDIR.TAG"
_TAG_TEXT = ("Signature: 8a477f597d28d172789f06886806bc55\n"
             "# This file is a cache directory tag created by blender_shapesig.\n"
             "# Every file here was written by it and is rebuilt when needed.\n")
_TMP_PREFIX, _TMP_SUFFIX = ".shapesig-", ".tmp"
_OWN_FILE = re.compile(r"(?:[0-9a-f]{40}\.(?:npz|png)|fingerprints-[0-9a-f]{40}\.json|"
                       + re.escape(_PACK) + "|" + re.escape(LOCAL_PACK) + "|"
                       + re.escape(_TMP_PREFIX) + r"\w+"
                       + re.escape(_TMP_SUFFIX) + ")")
_ENTRY_FILE = re.compile(r"[0-9a-f]{40}\.npz")


class _Refused(Exception):
    """A folder the cache will not use (not its own, or unsafe); the message says why."""


def private_cache_dir() -> str:
    """The per-user fallback folder in the temporary folder (``blender_shapesig-<uid>``), used when there is no
    usable home or XDG cache folder; ``SignatureCache`` creates it mode 0700 and refuses it when it is a
    symlink, not a folder, owned by another user or writable by others."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    import tempfile

    return os.path.join(tempfile.gettempdir(), PRIVATE_PREFIX + (str(uid) if uid is not None else "user"))


def _user_cache_base():
    """XDG_CACHE_HOME (absolute), else ~/.cache when the home folder exists and is writable, else None."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and os.path.isabs(xdg):
        return xdg
    home = os.path.expanduser("~")
    if os.path.isabs(home) and os.path.isdir(home):
        base = os.path.join(home, ".cache")
        if os.access(base if os.path.isdir(base) else home, os.W_OK):
            return base
    return None


def default_cache_dir() -> str:
    """The folder the cache lives in (its own subfolder ``CACHE_SUBDIR`` is made there): ``$SHAPESIG_CACHE_DIR``
    if set, else the user's cache folder (XDG_CACHE_HOME, else ~/.cache), else ``private_cache_dir()``.
    Blender's Index Folder preference, when set, names another one."""
    return os.environ.get(CACHE_ENV) or _user_cache_base() or private_cache_dir()


def _check_private(path):
    """Make the per-user fallback folder (mode 0700) and check that it is safe to use; _Refused if not."""
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    st = os.lstat(path)
    if stat.S_ISLNK(st.st_mode):
        raise _Refused(f"{path} is a symbolic link")
    if not stat.S_ISDIR(st.st_mode):
        raise _Refused(f"{path} is not a folder")
    if not hasattr(os, "getuid"):
        return  # Windows: the temporary folder is the user's own
    if st.st_uid != os.getuid():
        raise _Refused(f"{path} belongs to another user")
    if st.st_mode & 0o022:
        raise _Refused(f"{path} is writable by other users")


def _check_own_folder(folder):
    """The cache's own folder: a real folder (not a symbolic link: the files would be written where it points) of
    this user, not writable by other users; _Refused (or NotADirectoryError) otherwise."""
    st = os.lstat(folder)
    if stat.S_ISLNK(st.st_mode):
        raise _Refused(f"{folder} is a symbolic link")
    if not stat.S_ISDIR(st.st_mode):
        raise NotADirectoryError(errno.ENOTDIR, "not a folder", folder)
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        raise _Refused(f"{folder} belongs to another user")
    if st.st_mode & 0o002:
        raise _Refused(f"{folder} is writable by every user")


_STALE_SECONDS = 600.0  # a temporary file older than this was left by a process that died writing it


def _sweep(folder):
    """Remove what has one of the cache's own names but is not a regular file (a FIFO would hang ``np.load``, a
    link would be read where it points) and the temporary files of writes that never finished."""
    import time

    now = time.time()
    with os.scandir(folder) as listing:  # the kind of each file from the listing: a stat only for temporary files
        for e in listing:
            n = e.name
            if not _OWN_FILE.fullmatch(n):
                continue
            try:
                stale = n.startswith(_TMP_PREFIX) and n.endswith(_TMP_SUFFIX) and \
                    now - e.stat(follow_symlinks=False).st_mtime > _STALE_SECONDS
                if not e.is_file(follow_symlinks=False) or stale:
                    os.remove(e.path)
            except OSError:
                pass


def _marked(folder) -> bool:
    """True when ``folder`` holds the marker this cache writes."""
    try:
        with open(os.path.join(folder, _TAG), encoding="utf-8", errors="replace") as f:
            return f.read(len(_TAG_TEXT) + 1) == _TAG_TEXT
    except OSError:
        return False
