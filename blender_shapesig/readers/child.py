"""Reading clip files with Blender in a child process that serves many files: ``read_in_child(reader, args, path)``
sends one request to the reading child (``_child_main``) and returns its clips, or raises its one-line error. A
file that crashes Blender's importer ends only the child (a ParseError for that file; the next file starts a new
child), a read that takes longer than ``read_timeout`` (60 s plus 2 s per MB) or is interrupted kills it. One child serves every read of this process
(one at a time; threads wait their turn): starting Blender costs about 0.7 s, so a folder of ten files costs one
start-up, not ten. It ends ``IDLE_SECONDS`` after its last read, after ``MAX_FILES`` files (what importers leak
stays bounded), at ``close()`` and at exit. Imports no bpy (the command line does not need it). The protocol:
docs/dev/blender_layer.md.
"""

import atexit
import json
import os
import queue
import subprocess
import sys
import threading
import time

from ..core.clip.clip import Clip
from ..core.errors import ParseError
from ._blend_file_child import read_result
from ._child_main import PREFIX
from .guard import forget, guard_args, spawn, temp_folder

__all__ = ["read_in_child", "read_timeout", "close", "child_command", "CHILD_TIMEOUT", "IDLE_SECONDS", "MAX_FILES",
           "starts"]

CHILD_TIMEOUT = 600.0
IDLE_SECONDS = 20.0
MAX_FILES = 200
_LOCK = threading.RLock()
_STATE = {"child": None, "timer": None, "starts": 0}


def child_command(script, args_json):
    """The command that runs ``script``: the Blender binary in background mode inside Blender, else this Python
    (which has the bpy module; the command line never imports bpy for this)."""
    bpy = sys.modules.get("bpy")
    binary = getattr(getattr(bpy, "app", None), "binary_path", "") or ""
    if binary and os.path.basename(binary).lower().startswith("blender"):
        return [binary, "--background", "--factory-startup", "--python-exit-code", "3", "--python", script,
                "--", args_json]
    return [sys.executable, script, args_json]


class _Child:
    """One reading child: its process, a thread collecting its reply lines, a folder for the result files."""

    def __init__(self):
        package_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        args = json.dumps({"package_dir": os.path.dirname(package_root), "package": os.path.basename(package_root),
                           "sys_path": [p for p in sys.path if p], **guard_args()})
        self.tmp = temp_folder("child")
        self.log = open(os.path.join(self.tmp.name, "stderr.txt"), "w+b")
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_child_main.py")
        try:
            self.proc = spawn(child_command(script, args), self.tmp.name, stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=self.log, bufsize=0)
        except OSError as exc:
            self.log.close()
            self.tmp.cleanup()
            raise ParseError(f"cannot start a process to read clip files: {exc}") from None
        _STATE["starts"] += 1
        self.replies, self.files, self.used = queue.Queue(), 0, time.monotonic()
        threading.Thread(target=self._collect, name="shapesig-child-replies", daemon=True).start()

    def _collect(self):
        for raw in iter(self.proc.stdout.readline, b""):
            if raw.startswith(PREFIX + b"done "):
                self.replies.put(raw[len(PREFIX) + 5:].rstrip(b"\r\n").decode("utf-8", "replace"))
        self.replies.put(None)  # the child ended

    def alive(self):
        return self.proc.poll() is None

    def read(self, reader, args, path, kind, timeout):
        out = os.path.join(self.tmp.name, f"{self.files}.npz")
        self.files += 1
        try:
            self.proc.stdin.write(json.dumps({"reader": reader, "args": args, "out": out}).encode() + b"\n")
            self.proc.stdin.flush()
        except OSError:
            pass  # it ended: the reply queue says so
        deadline = time.monotonic() + timeout
        try:
            done = self.replies.get(timeout=timeout)
            while done is not None and done != out:  # an answer to an earlier request (never left unread)
                done = self.replies.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            self.close(kill=True)
            raise ParseError(f"reading the {kind} file took more than {timeout:.0f} s", path) from None
        except BaseException:
            self.close(kill=True)  # interrupted (Esc, an alarm): the child's state is unknown
            raise
        self.used = time.monotonic()
        if done is None or not os.path.isfile(out):
            raise ParseError(self._crash_text(kind), path)
        try:
            clips, error = read_result(out, Clip)
        finally:
            os.remove(out)
        if error is not None:
            raise ParseError(error)
        return clips

    def _crash_text(self, kind):
        code = self.proc.wait(timeout=30)
        if code < 0 or code > 128:
            return f"damaged {kind} file: Blender crashed reading it"
        self.log.seek(0)
        lines = [ln for ln in self.log.read().decode("utf-8", "replace").splitlines() if ln.strip()]
        return f"could not read the {kind} file ({lines[-1].strip()[:200] if lines else f'exit {code}'})"

    def close(self, kill=False):
        try:
            if not kill:
                self.proc.stdin.close()  # the child's loop ends with its input
                self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            kill = True
        if kill and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        forget(self.proc)
        self.log.close()
        self.tmp.cleanup()


def read_timeout(path) -> float:
    """Seconds a read of ``path`` may take: 60 plus 2 per MB, at most ``CHILD_TIMEOUT``."""
    try:
        mb = os.path.getsize(path) / 2 ** 20
    except OSError:
        mb = 0.0
    return min(CHILD_TIMEOUT, 60.0 + 2.0 * mb)


def read_in_child(reader, args, path, kind):
    """The clips the child's ``reader`` ("interchange", "blend") reads with ``args`` (JSON values); ParseError
    (one line naming ``path``, a ``kind`` of file such as "FBX") when it fails, crashes or takes longer than
    ``read_timeout(path)``."""
    with _LOCK:
        child = _STATE["child"]
        if child is None or not child.alive():
            if child is not None:
                child.close(kill=True)
            child = _STATE["child"] = _Child()
        try:
            return child.read(reader, args, path, kind, read_timeout(path))
        finally:
            if not child.alive() or child.files >= MAX_FILES:
                close()
            else:
                _arm_timer()


def _arm_timer():
    timer = _STATE["timer"]
    if timer is not None:
        timer.cancel()
    timer = _STATE["timer"] = threading.Timer(IDLE_SECONDS, _close_if_idle)
    timer.daemon = True
    timer.start()


def _close_if_idle():
    with _LOCK:
        child = _STATE["child"]
        if child is not None and time.monotonic() - child.used >= IDLE_SECONDS - 0.5:
            close()


def close():
    """End the reading child (if one runs)."""
    with _LOCK:
        child, _STATE["child"] = _STATE["child"], None
        if child is not None:
            child.close(kill=not child.alive())


def starts() -> int:
    """How many reading children this process has started (the benchmark and tests count start-ups)."""
    return _STATE["starts"]


atexit.register(close)
