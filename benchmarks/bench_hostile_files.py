"""Time and peak memory of refusing hostile clip files (``core.io.files`` caps), each case in a fresh subprocess.

    .venv/bin/python benchmarks/bench_hostile_files.py [--json]

Cases, written into a temporary folder: a 500 MB BVH (a real header with ``Frames: 5000000``, made sparse with
``os.truncate``: over the size cap), a 100 MB BVH with one 100 MB line (under the size cap: the line cap), a BVH
whose header claims 5,000,000 frames (the frame cap, from the header), and a folder holding a FIFO, a link to
/dev/zero, a dangling and a looping link next to a real take (discovery). Each case runs ``sources.read`` (or
``sources.library``) in its own Python and reports the wall time from the call and the process' peak RSS
(``VmHWM`` of ``/proc/self/status``, else ``resource.getrusage``), and, for scale, the peak of the same Python reading the real 09_02.bvh.
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
BVH = ROOT / "tests" / "data" / "bvh"

CHILD = r"""
import json, resource, sys, time
from blender_shapesig.core.io import sources
t0 = time.perf_counter()
try:
    out = sources.library(sys.argv[2]) if sys.argv[1] == "library" else sources.read(sys.argv[2])
    outcome = f"{len(out)} clip(s)"
except Exception as exc:
    outcome = f"{type(exc).__name__}: {exc}"
try:  # the peak of this process image (ru_maxrss also counts a large parent's size at the fork)
    peak = int(next(ln.split()[1] for ln in open("/proc/self/status") if ln.startswith("VmHWM")))
except OSError:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"seconds": time.perf_counter() - t0, "peak_rss_mb": peak / 1024, "outcome": outcome}))
"""


def _header(frames):
    return (BVH / "09_02.bvh").read_text().split("MOTION")[0] + f"MOTION\nFrames: {frames}\nFrame Time: 0.008333\n"


def _cases(tmp):
    tmp = pathlib.Path(tmp)
    huge = tmp / "huge.bvh"
    huge.write_text(_header(5_000_000))
    os.truncate(huge, 500 * 2 ** 20)
    line = tmp / "line.bvh"
    line.write_text(_header(10))
    with open(line, "a") as fh:
        for _ in range(50):
            fh.write("1 " * 2 ** 20)  # one 100 MB line
    claims = tmp / "claims.bvh"
    data = (BVH / "09_02.bvh").read_text().split("MOTION")[1].strip().splitlines()[2:]
    claims.write_text(_header(5_000_000) + "\n".join(data) + "\n")
    lib = tmp / "lib"
    lib.mkdir()
    (lib / "09_02.bvh").write_bytes((BVH / "09_02.bvh").read_bytes())
    os.mkfifo(lib / "x.bvh")
    os.symlink("/dev/zero", lib / "z.bvh")
    os.symlink(lib / "nowhere.bvh", lib / "d.bvh")
    os.symlink("l.bvh", lib / "l.bvh")
    return [("500 MB BVH, Frames: 5000000", "read", huge), ("100 MB BVH, one 100 MB line", "read", line),
            ("BVH claiming 5,000,000 frames", "read", claims), ("folder: FIFO, /dev/zero, 2 bad links", "library", lib),
            ("real 09_02.bvh (for scale)", "read", BVH / "09_02.bvh")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="shapesig_hostile_") as tmp:
        for name, how, path in _cases(tmp):
            proc = subprocess.run([sys.executable, "-c", CHILD, how, str(path)], capture_output=True, text=True,
                                  cwd=ROOT, timeout=300, check=True)
            rows.append(dict(json.loads(proc.stdout), case=name))
    if args.json:
        print(json.dumps({"cases": rows}))
        return
    print(f"{'case':38s} {'seconds':>8s} {'peak RSS':>9s}  outcome")
    for r in rows:
        print(f"{r['case']:38s} {r['seconds']:8.3f} {r['peak_rss_mb']:7.0f} MB  {r['outcome'][-90:]}")


if __name__ == "__main__":
    main()
