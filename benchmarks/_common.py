"""The benchmarks' one harness: a timer that reports CPU and wall time over repeats, the machine a run was made
on, JSON results stamped with that machine and the date, and the clip loader. Every benchmark states its
speed as a ratio against a baseline timed in the same run with ``timed``; absolute numbers say where it ran."""

import datetime
import json
import os
import pathlib
import platform
import statistics
import sys
import time
from dataclasses import asdict, dataclass

ROOT = pathlib.Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

__all__ = ["ROOT", "Timing", "timed", "machine", "write_json", "load_clip"]

_CPU_CLOCKS = {"process": time.process_time, "thread": time.thread_time}


@dataclass
class Timing:
    """Seconds over the timed repeats (a warm-up run is not among them): CPU and wall, minimum and median."""

    cpu_min: float
    cpu_median: float
    wall_min: float
    wall_median: float
    repeat: int

    def as_dict(self):
        return asdict(self)


def timed(fn, repeat=5, warmup=1, cleanup=None, cpu="process"):
    """Time ``fn()`` ``repeat`` times after ``warmup`` untimed runs. ``cleanup(result)`` runs after each call,
    outside the timing. ``cpu``: "process" (every thread of the process) or "thread" (the calling thread)."""
    clock = _CPU_CLOCKS[cpu]
    cpu_s, wall_s = [], []
    for i in range(warmup + repeat):
        c0, w0 = clock(), time.perf_counter()
        out = fn()
        c1, w1 = clock(), time.perf_counter()
        if cleanup is not None:
            cleanup(out)
        if i >= warmup:
            cpu_s.append(c1 - c0)
            wall_s.append(w1 - w0)
    return Timing(min(cpu_s), statistics.median(cpu_s), min(wall_s), statistics.median(wall_s), repeat)


def machine():
    """Where and when: date, host CPU count, platform, Python, numpy, load average at the call."""
    import numpy as np

    out = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
           "cpus": os.cpu_count(), "platform": platform.platform(), "machine": platform.machine(),
           "python": platform.python_version(), "numpy": np.__version__}
    try:
        out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    bpy = sys.modules.get("bpy")
    if bpy is not None:
        out["blender"] = bpy.app.version_string
    return out


def write_json(path, results):
    """Write ``results`` (a dict) with ``machine()`` under "machine" to ``path``; returns the dict written."""
    out = dict(results)
    out.setdefault("machine", machine())
    pathlib.Path(path).write_text(json.dumps(out, indent=2, default=float) + "\n", encoding="utf-8")
    return out


def load_clip(path, asf=None, **options):
    """The one clip a file names, through the package's front door (``core.io.sources.read_one``)."""
    from blender_shapesig.core.io.sources import read_one

    return read_one(os.fspath(path), asf=asf, **options)
