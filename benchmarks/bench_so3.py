"""Benchmark of core.geometry.so3 against scipy's Rotation (same run, same inputs, ratios reported).

Usage (from the repository root):

    .venv/bin/python benchmarks/bench_so3.py [--repeat 200] [--json FILE]

Inputs: 9,300 rotation matrices, the size of the SRVT of a 300-frame, 31-joint clip:
* ``clip``: the first 300 frames of CMU 07_01 (tests/data) moved to P* (R[k] R[0]^T per joint): angles
  from 0 to ~2 rad, as the SRVT and the stillness rule see them;
* ``uniform``: uniformly random rotations (half of them beyond pi/2, where so3.log takes the axis from
  the symmetric part).

Timed (minimum over repeats of the thread's CPU time; the contenders run interleaved so that load from
other processes hits both alike): ``so3.log`` vs ``Rotation.from_matrix(R).as_rotvec()``, ``so3.exp`` vs
``Rotation.from_rotvec(v).as_matrix()``, ``so3.relative_rotvecs`` vs the matrix product plus scipy's log,
and the largest difference between the two answers. Nothing is asserted.
"""

import argparse
import json
import os
import pathlib
import platform
import sys
import time

import numpy as np
import scipy
from scipy.spatial.transform import Rotation

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from blender_shapesig.core.geometry import so3  # noqa: E402
from blender_shapesig.core.io.acclaim import load_acclaim  # noqa: E402

TESTS = ROOT / "tests" / "data" / "acclaim"


def interleaved(fns, repeat):
    """Minimum thread CPU time (ms) of each function, calling them in turn ``repeat`` times."""
    best = {k: float("inf") for k in fns}
    for _ in range(repeat):
        for k, fn in fns.items():
            t0 = time.thread_time()
            fn()
            best[k] = min(best[k], time.thread_time() - t0)
    return {k: round(v * 1e3, 4) for k, v in best.items()}


def scipy_log(R):
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).as_rotvec().reshape(R.shape[:-2] + (3,))


def scipy_relative(R):
    rel = R[1:] @ np.swapaxes(R[:-1], -1, -2)
    return scipy_log(rel)


def case(R, repeat):
    flat = R.reshape(-1, 3, 3)
    v = so3.log(flat)
    out = {"matrices": int(flat.shape[0])}
    t = interleaved({"so3": lambda: so3.log(flat), "scipy": lambda: scipy_log(flat)}, repeat)
    out["log_ms"] = dict(t, ratio=round(t["scipy"] / t["so3"], 2))
    out["log_max_difference"] = float(np.abs(v - scipy_log(flat)).max())
    t = interleaved({"so3": lambda: so3.exp(v), "scipy": lambda: Rotation.from_rotvec(v).as_matrix()}, repeat)
    out["exp_ms"] = dict(t, ratio=round(t["scipy"] / t["so3"], 2))
    out["exp_max_difference"] = float(np.abs(so3.exp(v) - Rotation.from_rotvec(v).as_matrix()).max())
    if R.ndim == 4:
        t = interleaved({"so3": lambda: so3.relative_rotvecs(R), "scipy": lambda: scipy_relative(R)}, repeat)
        out["relative_rotvecs_ms"] = dict(t, ratio=round(t["scipy"] / t["so3"], 2))
        out["relative_rotvecs_max_difference"] = float(np.abs(so3.relative_rotvecs(R) - scipy_relative(R)).max())
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--json", type=pathlib.Path, help="also write the results to this file")
    args = ap.parse_args(argv)
    R = load_acclaim(TESTS / "07_01.amc", TESTS / "07-walk.asf").rotations[:300]
    R = R @ np.swapaxes(R[0], -1, -2)[None]
    uniform = Rotation.random(R.shape[0] * R.shape[1], random_state=0).as_matrix()
    res = {
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
                    "cpu_count": os.cpu_count()},
        "clip_07_01_300x31": case(R, args.repeat),
        "uniform_9300": case(uniform, args.repeat),
        "load_average_1min": os.getloadavg()[0],
    }
    print(json.dumps(res, indent=2))
    if args.json:
        args.json.write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    main()
