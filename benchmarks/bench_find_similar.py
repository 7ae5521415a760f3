"""Find Similar in a .blend with many actions (the bpy module, headless): change detection, library items,
ranking with the built index; the one-off index build; the index's memory.

    .venv/bin/python benchmarks/bench_find_similar.py [--actions 1000] [--blend FILE] [--mixed] [--repeat 5] [--json OUT]

1. The file: an armature imported from tests/data/bvh/07_01.bvh (43 bones, Blender's importer) and ``--actions``
   actions written with ``action_io.write_action`` from the six test BVH clips (read by ``core.io.bvh``,
   every 4th frame: 30 fps as in the issue's file), each cropped differently (16-84 frames, 132 F-curves each,
   1,000 distinct contents). With ``--mixed`` (give another ``--blend``): 33-130-frame crops at 120, 30 and 60 fps,
   the 60 fps third without a recorded rate (the scene's assumed). Saved to ``--blend`` (built once, reused when it
   exists).
2. Index build (the one-off cost): ``library.library_items`` + ``core.search.build_index`` into a fresh folder:
   actions per second; the same-run baseline: the build again into another folder with OpenBLAS's own threads.
3. A click (what the search operator does, without writing the UI results): the query item,
   ``library.library_items`` (change detection through ``action_io.action_fingerprint``) and
   ``core.search.rank_clips`` with the built index (re-rank off). Cold: the first click of a session (every
   action's fingerprint, ``action_io.read_hash``, computed; the baseline: ``action_io.action_hash`` of every
   action, the key every click computed before); warm: later clicks (best of ``--repeat``) and a click after one action was edited. Then the click as
   the UI runs it, ``bpy.ops.shapesig.rank()`` (results written to the window manager, no undo step), beside the
   same run's baseline of one whole-file undo push (what each click cost when the operator was an UNDO one).
4. The first click of a fresh session (``--fresh`` runs): a new process opens the saved file, waits for the add-on's
   kernel warm-up (started at enable, long done when a user clicks) and runs ``bpy.ops.shapesig.rank()`` once with
   the index of step 2, with the fingerprints stored in the index folder by an earlier session
   (``action_changes``), against the same-run baseline of the same fresh click with the stored fingerprints
   deleted first (every action's ``read_hash`` computed, as before they were stored); best of ``--fresh`` each,
   alternated.
5. Memory: the index in memory (numpy arrays and Python objects; tracemalloc) after loading every entry from the
   folder and ranking with every clip compared exactly, per clip and scaled to 2,600 (the store also caps the
   directions it holds at its ``memory_limit``).
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time
import tracemalloc

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

import blender_shapesig  # noqa: E402
import dataclasses  # noqa: E402

from blender_shapesig.actions import action_changes, action_io  # noqa: E402
from blender_shapesig.search import library  # noqa: E402
from blender_shapesig.core import blas, search as index  # noqa: E402
from blender_shapesig.core.io.bvh import load_bvh  # noqa: E402
from blender_shapesig.readers.bvh import import_armature  # noqa: E402

BVH = ROOT / "tests" / "data" / "bvh"


def _at_30fps(clip):
    """Every 4th frame of a 120 fps clip (the issue's file holds 30 fps CMU clips)."""
    return dataclasses.replace(clip, rotations=clip.rotations[::4], root_translation=clip.root_translation[::4],
                               fps=30.0)


def _every(clip, step):
    """Every ``step``-th frame of a 120 fps clip (120 / step fps)."""
    return dataclasses.replace(clip, rotations=clip.rotations[::step], root_translation=clip.root_translation[::step],
                               fps=clip.fps / step)


# ``--mixed``: a file as an animator's: clips of 33-130 frames at three rates, one in three without a recorded rate
# (the scene's assumed: ``frame_rates.rate_of``), the others recorded as the importers record them
MIXED = ((1, True), (4, True), (2, False))  # (every step-th frame of the 120 fps source, rate recorded)


def build_file(path, n_actions, mixed=False):
    from blender_shapesig.actions import frame_rates

    bpy.ops.wm.read_factory_settings(use_empty=True)
    arm, _ = import_armature(str(BVH / "07_01.bvh"))
    arm.name = "Rig"
    bpy.data.actions.remove(arm.animation_data.action)
    sources = [load_bvh(p) for p in sorted(BVH.glob("*.bvh"))]
    clips = [_every(c, 4) for c in sources]
    t0 = time.perf_counter()
    for n in range(n_actions):
        clip = clips[n % len(clips)]
        k = n // len(clips)  # every action a different crop: 1,000 distinct contents (and index entries)
        start, end = 2 + k % 10, clip.frame_end - k // 10
        if mixed:
            step, recorded = MIXED[n % len(MIXED)]
            clip = _every(sources[n % len(sources)], step)
            length = 33 + (n * 37) % 98  # 33-130 frames
            start = 1 + (n * 13) % max(clip.frames - length, 1)
            end = min(start + length - 1, clip.frame_end)
        a = action_io.write_action(clip.crop(start, end), armature=arm, name=f"{clip.name}_{n:04d}")
        if mixed and recorded:
            frame_rates.record(a, clip.fps, "import")
        if n == 0:
            action_io.assign_action(arm, a)
    build_s = time.perf_counter() - t0
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return build_s


SIMILARITY = ["local"]  # --similarity


def settings_for(context):
    s = library.settings_of(context)
    s.use_file_actions = True
    s.use_folders = False
    s.rerank = 0
    s.top = 10
    s.similarity = SIMILARITY[0]
    return s


def click(context, settings, cache):
    t0, c0 = time.perf_counter(), time.process_time()
    obj, action, q = library.query_item(context, settings)
    items = [it for it in library.library_items(context, settings, obj) if it.key != q.key]
    t1 = time.perf_counter()
    metric = "local" if settings.similarity == "local" else "sim"  # the panel's Similarity
    res = index.rank_clips(q, items, metric=metric, level=settings.level, rerank=0, top=10, cache=cache)
    t2, c2 = time.perf_counter(), time.process_time()
    return {"wall_ms": (t2 - t0) * 1e3, "cpu_ms": (c2 - c0) * 1e3, "items_ms": (t1 - t0) * 1e3,
            "rank_ms": (t2 - t1) * 1e3, "results": len(res)}


def build_with_blas_threads(items):
    """The same-run baseline of the build: read and sign every item again into a fresh folder with OpenBLAS's own
    threads (one per core), as before ``core.blas.one_blas_thread``; seconds and actions per second."""
    saved = list(blas._API)
    blas._API[:] = [None]  # one_blas_thread does nothing
    try:
        with tempfile.TemporaryDirectory() as other:
            t0 = time.perf_counter()
            index.build_index(items, cache=index.SignatureCache(other))
            seconds = time.perf_counter() - t0
    finally:
        blas._API[:] = saved
    return {"build_s": round(seconds, 2), "blas_threads": blas.blas_threads()}


def operator_clicks(context, folder, repeat):
    """The click as the UI runs it: ``bpy.ops.shapesig.rank()`` (its synchronous path: the same RankJob the modal
    one steps), results written to the window manager, the index in ``folder``; the panel's own report of the
    click (``seconds``). Baseline, the same run: one whole-file undo push (what the click cost when ``shapesig.rank``
    was an UNDO operator; None when the headless module keeps no undo stack)."""
    os.environ[index.CACHE_ENV] = folder  # get_cache: the benchmark's index, not the user's
    library.CACHES.clear()
    bpy.ops.shapesig.rank()  # first: the folder's entries loaded into the session's cache
    walls = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        bpy.ops.shapesig.rank()
        walls.append((time.perf_counter() - t0) * 1e3)
    res = library.results_of(context)
    out = {"wall_ms_best": min(walls), "wall_ms_median": sorted(walls)[len(walls) // 2],
           "panel_reports_ms": res.seconds * 1e3, "rows": len(res.results)}
    try:
        pushes = []
        for _ in range(3):  # the first push of a session writes the whole file; later ones share unchanged data
            t0 = time.perf_counter()
            bpy.ops.ed.undo_push(message="bench")
            pushes.append((time.perf_counter() - t0) * 1e3)
        out["baseline_undo_push_ms"] = {"first": pushes[0], "later_best": min(pushes[1:])}
    except RuntimeError as exc:  # no undo stack without a window
        out["baseline_undo_push_ms"] = None
        out["undo_push_error"] = str(exc).splitlines()[0]
    return out


def fresh_click(blend):
    """(In a new process: ``--fresh-click``) open ``blend``, click once, print the click's JSON."""
    blender_shapesig.register()
    for t in list(blender_shapesig._WARM_UP):
        t.join()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    context = bpy.context
    context.view_layer.objects.active = bpy.data.objects["Rig"]
    settings_for(context)
    t0 = time.perf_counter()
    bpy.ops.shapesig.rank()
    wall = (time.perf_counter() - t0) * 1e3
    res = library.results_of(context)
    print("FRESH" + json.dumps({"wall_ms": wall, "panel_reports_ms": res.seconds * 1e3,
                                "rows": [r.name for r in res.results], **action_changes.store_stats()}))


def fresh_session_clicks(blend, folder, runs):
    """The first click of ``runs`` fresh sessions with the stored fingerprints and ``runs`` without (the store
    deleted first: the baseline), alternated; the best of each and their ratio."""
    import subprocess

    from blender_shapesig.core.search.cache_folder import CACHE_SUBDIR

    env = dict(os.environ, **{index.CACHE_ENV: folder})
    got = {"stored": [], "recomputed": []}
    for _ in range(runs):
        for kind in ("recomputed", "stored"):  # the baseline writes the store the next run reads
            if kind == "recomputed":
                for p in pathlib.Path(folder, CACHE_SUBDIR).glob("fingerprints-*.json"):
                    p.unlink()
            done = subprocess.run([sys.executable, __file__, "--fresh-click", "--blend", str(blend),
                                   "--similarity", SIMILARITY[0]], env=env, capture_output=True, text=True,
                                  timeout=900)
            line = [ln for ln in done.stdout.splitlines() if ln.startswith("FRESH")]
            if not line:
                raise RuntimeError(done.stderr[-2000:])
            got[kind].append(json.loads(line[-1][len("FRESH"):]))
    best = {k: min(v, key=lambda r: r["wall_ms"]) for k, v in got.items()}
    assert best["stored"]["rows"] == best["recomputed"]["rows"]
    return {"stored_ms": best["stored"]["wall_ms"], "recomputed_ms": best["recomputed"]["wall_ms"],
            "ratio": best["stored"]["wall_ms"] / best["recomputed"]["wall_ms"],
            "stored_all_ms": [round(r["wall_ms"], 1) for r in got["stored"]],
            "recomputed_all_ms": [round(r["wall_ms"], 1) for r in got["recomputed"]],
            "fingerprints_stored_used": best["stored"]["stored"], "computed": best["stored"]["computed"],
            "baseline_computed": best["recomputed"]["computed"], "same_rows": True}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--actions", type=int, default=1000)
    ap.add_argument("--blend", type=pathlib.Path,
                    default=pathlib.Path(tempfile.gettempdir()) / "shapesig_bench_actions.blend")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", type=pathlib.Path)
    ap.add_argument("--fresh", type=int, default=3, help="fresh sessions timed with and without stored fingerprints")
    ap.add_argument("--fresh-click", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--mixed", action="store_true",
                    help="a file of 33-130-frame actions at 120, 30 and 60 fps, a third without a recorded rate")
    ap.add_argument("--similarity", choices=("local", "sim"), default="local",
                    help="the panel's Similarity: local (Motion and pose, the default) or sim (Motion only)")
    args = ap.parse_args(argv)
    SIMILARITY[0] = args.similarity
    if args.fresh_click:
        return fresh_click(args.blend)
    out = {"actions": args.actions, "mixed": args.mixed, "load_average_1min": os.getloadavg()[0]}
    blender_shapesig.register()
    if not args.blend.exists():
        out["file_build_s"] = round(build_file(args.blend, args.actions, args.mixed), 1)
    bpy.ops.wm.open_mainfile(filepath=str(args.blend))
    context = bpy.context
    arm = bpy.data.objects["Rig"]
    context.view_layer.objects.active = arm
    settings = settings_for(context)
    out["actions_in_file"] = len(bpy.data.actions)
    out["fcurves_per_action"] = len(next(iter(bpy.data.actions)).layers[0].strips[0].channelbags[0].fcurves)

    # the baseline every click paid before: action_hash of every action
    t0 = time.perf_counter()
    for a in bpy.data.actions:
        action_io.action_hash(a)
    out["baseline_action_hash_all_ms"] = round((time.perf_counter() - t0) * 1e3, 1)
    t0 = time.perf_counter()
    for a in bpy.data.actions:
        action_changes.action_fingerprint(a)
    t1 = time.perf_counter()
    for a in bpy.data.actions:
        action_changes.action_fingerprint(a)
    out["fingerprints_all_ms"] = {"first": round((t1 - t0) * 1e3, 1),
                                  "remembered": round((time.perf_counter() - t1) * 1e3, 1)}

    with tempfile.TemporaryDirectory() as folder:
        cache = index.SignatureCache(folder)
        action_changes.forget_fingerprints()
        t0 = time.perf_counter()
        obj, action, q = library.query_item(context, settings)
        items = [q] + [it for it in library.library_items(context, settings, obj) if it.key != q.key]
        t1 = time.perf_counter()
        index.build_index(items, cache=cache)
        t2 = time.perf_counter()
        out["index_build"] = {"items": len(items), "items_s": round(t1 - t0, 2), "build_s": round(t2 - t1, 2),
                              "entries_computed": cache.stats["misses"],
                              "actions_per_s": round(len(items) / (t2 - t0), 1)}
        out["index_build_blas_threads_baseline"] = build_with_blas_threads(items)
        tracemalloc.start()
        fresh = index.SignatureCache(folder)
        index.build_index(items, cache=fresh)  # every entry loaded from the folder into memory
        # ranked with every clip compared exactly: every direction held (within the store's memory limit)
        index.rank_clips(items[0], items[1:], metric="sim", level=settings.level, cache=fresh)
        mem = tracemalloc.get_traced_memory()[0]
        tracemalloc.stop()
        out["index_memory"] = {"bytes_per_clip": int(mem / len(items)),
                               "mb_for_2600": round(mem / len(items) * 2600 / 2**20, 1)}

        action_changes.forget_fingerprints()
        out["click_cold"] = click(context, settings, cache)
        warm = [click(context, settings, cache) for _ in range(args.repeat)]
        out["click_warm_best"] = min(warm, key=lambda r: r["wall_ms"])
        edited = bpy.data.actions[5]
        fc = edited.layers[0].strips[0].channelbags[0].fcurves[3]
        fc.keyframe_points[10].co.y += 0.1
        context.view_layer.update()
        out["click_after_one_edit"] = click(context, settings, cache)
        out["operator_click"] = operator_clicks(context, folder, args.repeat)
        if args.fresh:
            out["fresh_session_first_click"] = fresh_session_clicks(args.blend, folder, args.fresh)
    for k, v in list(out.items()):
        if isinstance(v, dict):
            out[k] = {kk: (round(vv, 2) if isinstance(vv, float) else vv) for kk, vv in v.items()}
    print(json.dumps(out, indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
