"""The reading children die with this process: ``spawn`` starts one in its own process group with its temp folder
(``TMPDIR``, where Blender makes its ``blender_*`` folder) inside a folder of ours, and remembers it until
``forget``; ``kill_all`` ends every live child (from a signal handler: no lock taken); ``on_signals`` turns
SIGTERM / SIGHUP into ``Terminated`` after killing them; ``guard_self`` (run first in a child) asks Linux for
SIGKILL when the parent dies (``prctl(PR_SET_PDEATHSIG)``) and watches the parent from a thread everywhere else.
Imports no bpy. See docs/robustness.md."""

import contextlib
import os
import signal
import sys
import threading
import time

__all__ = ["spawn", "forget", "kill_all", "stopping", "guard_self", "guard_args", "on_signals", "Terminated",
           "temp_folder", "sweep"]

_LIVE = {}  # pid -> Popen
_STATE = {"stopping": False, "swept": False}
_TEMP_PREFIX = "shapesig_"  # shapesig_KIND_PID_XXXX: a folder of the process PID


def temp_folder(kind):
    """A ``tempfile.TemporaryDirectory`` for one child (``kind``: "child", "blend") named after this process, so
    that ``sweep`` can tell the folders of processes that died by SIGKILL (nothing of theirs ran) from live ones."""
    import tempfile

    if not _STATE["swept"]:
        _STATE["swept"] = True
        sweep()
    return tempfile.TemporaryDirectory(prefix=f"{_TEMP_PREFIX}{kind}_{os.getpid()}_")


def sweep(folder=None):
    """Remove the children's temp folders (``temp_folder``) left in ``folder`` (default: the temp folder) by
    processes of this user that no longer run. Returns how many were removed."""
    import re
    import shutil
    import stat
    import tempfile

    folder = folder or tempfile.gettempdir()
    removed = 0
    try:
        names = os.listdir(folder)
    except OSError:
        return 0
    for name in names:
        m = re.fullmatch(_TEMP_PREFIX + r"(?:child|blend)_(\d+)_\w+", name)
        if not m or int(m.group(1)) == os.getpid():
            continue
        full = os.path.join(folder, name)
        try:
            st = os.lstat(full)
            if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
                continue
            os.kill(int(m.group(1)), 0)
            continue  # its process runs
        except ProcessLookupError:
            shutil.rmtree(full, ignore_errors=True)
            removed += 1
        except OSError:
            continue
    return removed
_PR_SET_PDEATHSIG = 1


class Terminated(BaseException):
    """This process got SIGTERM or SIGHUP (``on_signals``): its children are already killed."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def stopping() -> bool:
    """True once a signal asked this process to stop: no new child is started."""
    return _STATE["stopping"]


def guard_args() -> dict:
    """What a child needs for ``guard_self``: this process's id, and whether Linux's parent-death signal fits
    (it follows the thread that started the child: only the main thread lives as long as the process)."""
    return {"parent": os.getpid(), "pdeathsig": threading.current_thread() is threading.main_thread()}


def spawn(cmd, tmpdir, **popen_kw):
    """``subprocess.Popen(cmd)`` in a new process group (a terminal's Ctrl-C reaches only this process, which ends
    it), with its temp folder ``tmpdir/tmp`` (removed with ``tmpdir``); remembered until ``forget``. OSError when
    it cannot start, or when this process is stopping."""
    if _STATE["stopping"]:
        raise OSError("this process is stopping")
    tmp = os.path.join(tmpdir, "tmp")
    os.makedirs(tmp, exist_ok=True)
    env = dict(os.environ, TMPDIR=tmp, TMP=tmp, TEMP=tmp)
    import subprocess

    proc = subprocess.Popen(cmd, env=env, start_new_session=True, **popen_kw)
    _LIVE[proc.pid] = proc
    return proc


def forget(proc):
    """``proc`` ended (it was waited for): no longer killed by ``kill_all``."""
    _LIVE.pop(proc.pid, None)


def kill_all():
    """SIGKILL every live child's process group (safe in a signal handler: no lock, no wait)."""
    for pid, proc in list(_LIVE.items()):
        if proc.returncode is None:
            try:
                os.killpg(pid, signal.SIGKILL)
            except OSError:
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass


def _on_signal(signum, _frame):
    _STATE["stopping"] = True
    kill_all()
    raise Terminated(signum)


@contextlib.contextmanager
def on_signals():
    """For the block, in the main thread: SIGTERM and SIGHUP kill the children and raise ``Terminated`` (so
    ``finally`` blocks and ``atexit`` run and remove the temp folders), SIGINT kills them and raises
    KeyboardInterrupt; the handlers before are restored at the end."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {}

    def on_int(_signum, _frame):
        _STATE["stopping"] = True
        kill_all()
        raise KeyboardInterrupt

    for name, handler in (("SIGTERM", _on_signal), ("SIGHUP", _on_signal), ("SIGINT", on_int)):
        sig = getattr(signal, name, None)
        if sig is not None:
            saved[sig] = signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        _STATE["stopping"] = False


def guard_self(args):
    """In a child, first: die with the parent ``args["parent"]`` (``guard_args``)."""
    parent = int(args.get("parent") or 0)
    if not parent:
        return
    if args.get("pdeathsig") and sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # it died before the signal was asked for
        os._exit(1)

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="shapesig-parent-watch", daemon=True).start()
