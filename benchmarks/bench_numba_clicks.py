"""What numba buys in the panel's real clicks (the bpy module, headless): numba kernels against the numpy ones.

    .venv/bin/python benchmarks/bench_numba_clicks.py [--actions 200] [--repeat 3] [--json OUT]

Each measurement runs in its own Python process (a Blender session) with the package from this checkout,
registered as the add-on, in one of three set-ups:

- ``numba``: numba importable, its on-disk cache (``NUMBA_CACHE_DIR``) already filled by an earlier session;
- ``numba-cold``: numba importable, an empty cache: the first click compiles the kernels it needs (what the first
  session after installing the extension pays);
- ``numpy``: numba blocked (``sys.modules["numba"] = None`` before the add-on is imported, as in a zip without
  numba: ``HAVE_NUMBA`` False everywhere, the numpy DP, SRVT and subsequence kernels).

Clicks, on two files written like ``bench_find_similar.py`` (an armature from tests/data/bvh/07_01.bvh and
actions from the six test BVH clips at 30 fps, each a different crop): the test clips (6 actions) and
``--actions`` actions. Find Similar: ``bpy.ops.shapesig.rank()`` with the panel's default re-rank (the best 10 by
the elastic distance), the file's actions as the library, its index built before (``shapesig.build_index``);
Moments: the same click with Moments on; Blend Actions: ``bpy.ops.shapesig.blend_actions`` on a walk and a run
(aligned, weight 0.5). Later clicks: best and median of ``--repeat``. First click of a session: a fresh process
per click kind and set-up, on the test clips' file (index already built), its first click. Enabling the
add-on (its registration imports the kernel modules, numba with them or not) is timed too. The ranked names are compared between numba and numpy (the
kernels promise identical results). JSON output with the machine, the load and the date.
"""

import argparse
import datetime
import json
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
KINDS = ("find_similar", "moments", "blend")
SETUPS = ("numba", "numba-cold", "numpy")
BLEND_PAIR = ("07_01", "09_02")  # a walk and a run (action names start with the clip name)


# ----------------------------------------------------------------------------------------------------------
# Child: one Blender session


def _session(setup):
    """Import bpy and enable the add-on in ``setup``; seconds spent enabling it (its registration imports the
    kernel modules, and numba with them when it is importable)."""
    if setup == "numpy":
        sys.modules["numba"] = None  # import numba raises ImportError: the add-on's numpy fallbacks
    sys.path.insert(0, str(ROOT))
    import bpy  # noqa: F401

    t0 = time.perf_counter()
    import blender_shapesig

    blender_shapesig.register()
    enable_s = time.perf_counter() - t0
    from blender_shapesig.core.elastic import _dp_kernels, _srvt_kernel

    assert _dp_kernels.HAVE_NUMBA == _srvt_kernel.HAVE_NUMBA == (setup != "numpy"), setup
    return enable_s


def _open(path, n_actions):
    import bpy

    sys.path.insert(0, str(ROOT / "benchmarks"))
    if not path.exists():
        from bench_find_similar import build_file

        build_file(path, n_actions)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    from blender_shapesig.search import library

    arm = bpy.data.objects["Rig"]
    bpy.context.view_layer.objects.active = arm
    s = library.settings_of(bpy.context)
    s.use_file_actions, s.use_folders, s.use_windows = True, False, False
    s.query_action = sorted(a.name for a in bpy.data.actions)[0]
    return s


def _click(kind, settings):
    """One click; (seconds, what it gave: the ranked names or the new action's frame count)."""
    import bpy

    from blender_shapesig.search import library

    if kind == "blend":
        names = sorted(a.name for a in bpy.data.actions)
        a = next(n for n in names if n.startswith(BLEND_PAIR[0]))
        b = next(n for n in names if n.startswith(BLEND_PAIR[1]))
        before = set(bpy.data.actions)
        t0 = time.perf_counter()
        result = bpy.ops.shapesig.blend_actions(action_a=a, action_b=b, weight=0.5, align=True, assign=False)
        seconds = time.perf_counter() - t0
        new = [x for x in bpy.data.actions if x not in before]
        assert result == {"FINISHED"} and len(new) == 1, result
        frames = int(new[0].frame_range[1] - new[0].frame_range[0]) + 1
        bpy.data.actions.remove(new[0])  # the library stays the same for the next click
        return seconds, frames
    settings.use_windows = kind == "moments"
    t0 = time.perf_counter()
    result = bpy.ops.shapesig.rank()
    seconds = time.perf_counter() - t0
    res = library.results_of(bpy.context)
    assert result == {"FINISHED"} and len(res.results) > 0, (result, res.message)
    return seconds, [r.name for r in res.results]


def child(args):
    """Print one JSON line: enable time, then the clicks asked for."""
    out = {"setup": args.setup, "enable_s": _session(args.setup)}
    import bpy

    settings = _open(pathlib.Path(args.blend), args.actions)
    out["actions"] = len(bpy.data.actions)
    if args.index:  # the file's index, built once (not part of any click)
        t0 = time.perf_counter()
        assert bpy.ops.shapesig.build_index() == {"FINISHED"}
        out["index_s"] = time.perf_counter() - t0
    if args.first:
        out["first"], out["gave"] = _click(args.first, settings)
    else:
        for kind in KINDS:
            _click(kind, settings)  # the session's first click of this kind (loads the index, compiles)
            times, gave = [], None
            for _ in range(args.repeat):
                s, gave = _click(kind, settings)
                times.append(s)
            out[kind] = {"best_s": min(times), "median_s": sorted(times)[len(times) // 2], "gave": gave}
    print("BENCH " + json.dumps(out), flush=True)


# ----------------------------------------------------------------------------------------------------------
# Parent


def _run(setup, blend, actions, index_dir, numba_dir, first=None, index=False, repeat=3):
    env = dict(os.environ, SHAPESIG_CACHE_DIR=str(index_dir), NUMBA_CACHE_DIR=str(numba_dir))
    cmd = [sys.executable, __file__, "--child", "--setup", setup, "--blend", str(blend), "--actions", str(actions),
           "--repeat", str(repeat)] + (["--first", first] if first else []) + (["--index"] if index else [])
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("BENCH ")), None)
    if proc.returncode != 0 or line is None:
        sys.stderr.write(proc.stdout[-3000:] + proc.stderr[-3000:])
        raise SystemExit(f"bench_numba_clicks: the {setup} session failed ({' '.join(cmd)})")
    out = json.loads(line[len("BENCH "):])
    out["process_s"] = time.perf_counter() - t0
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--actions", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", type=pathlib.Path)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--setup", choices=SETUPS, help=argparse.SUPPRESS)
    ap.add_argument("--blend", help=argparse.SUPPRESS)
    ap.add_argument("--first", choices=KINDS, help=argparse.SUPPRESS)
    ap.add_argument("--index", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return child(args)

    out = {"machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                       "cpus": os.cpu_count(), "python": platform.python_version()},
           "date": datetime.datetime.now().isoformat(timespec="seconds"),
           "load_average_1min_start": round(os.getloadavg()[0], 2), "repeat": args.repeat}
    with tempfile.TemporaryDirectory(prefix="shapesig-bench-numba-") as tmp:
        tmp = pathlib.Path(tmp)
        warm_numba = tmp / "numba-warm"
        files = {"test_clips": (tmp / "test_clips.blend", 6), "library": (tmp / "library.blend", args.actions)}
        later = {}
        for name, (blend, n) in files.items():
            later[name] = {}
            for setup in ("numba", "numpy"):  # numba first: it fills the warm numba cache and the index
                later[name][setup] = _run(setup, blend, n, tmp / f"index-{name}", warm_numba, index=True,
                                          repeat=args.repeat)
        first = {}
        blend, n = files["test_clips"]
        for setup in SETUPS:
            first[setup] = {}
            for kind in KINDS:
                numba_dir = warm_numba if setup == "numba" else tmp / f"numba-cold-{kind}"
                first[setup][kind] = _run(setup, blend, n, tmp / "index-test_clips", numba_dir, first=kind)
    out["actions"] = {name: later[name]["numba"]["actions"] for name in later}
    out["enable_s"] = {setup: round(later["test_clips"][setup]["enable_s"], 3) for setup in ("numba", "numpy")}
    out["later_clicks"] = {}
    for name, per in later.items():
        rows = {}
        for kind in KINDS:
            nb, np_ = per["numba"][kind], per["numpy"][kind]
            rows[kind] = {"numba_s": round(nb["median_s"], 3), "numpy_s": round(np_["median_s"], 3),
                          "numba_best_s": round(nb["best_s"], 3), "numpy_best_s": round(np_["best_s"], 3),
                          "numpy_over_numba": round(np_["median_s"] / nb["median_s"], 2),
                          "seconds_lost": round(np_["median_s"] - nb["median_s"], 3),
                          "same_result": nb["gave"] == np_["gave"]}
        out["later_clicks"][name] = rows
    out["first_click"] = {}
    for kind in KINDS:
        row = {setup: round(first[setup][kind]["first"], 3) for setup in SETUPS}
        row["numba_cold_over_numpy"] = round(row["numba-cold"] / row["numpy"], 2)
        row["numpy_over_numba"] = round(row["numpy"] / row["numba"], 2)
        row["same_result"] = first["numba"][kind]["gave"] == first["numpy"][kind]["gave"]
        out["first_click"][kind] = row
    out["load_average_1min_end"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out, indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
