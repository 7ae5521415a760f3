"""The main job, headless on the bpy module (run by tools/demo.sh):

1. import the sample CMU clips into one file: ASF/AMC with our importer (``shapesig.import_acclaim``), BVH with
   Blender's own importer;
2. rank every action against one query walk by the normalized log-signature distance (eq. 9.1), re-ranking
   the top 3 by the elastic distance (``shapesig.build_index`` + ``shapesig.rank``);
3. make one time-aligned SRVT geodesic blend of a walk and a run (``shapesig.blend_actions``);
4. save ``OUT/demo.blend`` and print a short report (also written to ``OUT/demo_report.md``).

A stage whose feature is not available says so plainly and the job goes on with the rest.
"""

import argparse
import contextlib
import os
import pathlib
import sys
import time
import traceback

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


@contextlib.contextmanager
def quiet_stdout():
    """Blender's C code prints to fd 1; keep the report readable by sending that to /dev/null."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    try:
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


class Report:
    def __init__(self):
        self.lines = []

    def __call__(self, text=""):
        print(text, flush=True)
        self.lines.append(text)


def stage(report, title):
    """Decorator-like helper: run a stage, report its time, and say plainly what failed."""

    def run(fn, *args):
        t0 = time.perf_counter()
        try:
            result = fn(*args)
        except NotImplementedError as exc:
            report(f"- {title}: NOT AVAILABLE YET ({exc})")
            return None
        except Exception as exc:  # the demo reports and goes on
            report(f"- {title}: FAILED: {type(exc).__name__}: {exc}")
            if os.environ.get("SHAPESIG_DEBUG"):
                traceback.print_exc()
            return None
        report(f"  ({title}: {time.perf_counter() - t0:.2f} s)")
        return result

    return run


def import_clips(bpy, data, report):
    """Import the sample clips; returns {action name: (armature object, label)}."""
    import csv

    imported = {}
    with open(data / "labels.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        path = data / row["file"]
        name = path.stem
        before_objects = set(bpy.data.objects)
        before_actions = set(bpy.data.actions)
        with quiet_stdout():
            if path.suffix == ".bvh":
                bpy.ops.import_anim.bvh(filepath=str(path), rotate_mode="NATIVE", update_scene_fps=False,
                                        update_scene_duration=False)
            else:
                bpy.ops.shapesig.import_acclaim(filepath=str(path), asf_path=str(data / row["skeleton"]))
        new_actions = [a for a in bpy.data.actions if a not in before_actions]
        new_objects = [o for o in bpy.data.objects if o not in before_objects and o.type == "ARMATURE"]
        if not new_actions:
            raise RuntimeError(f"importing {row['file']} created no action")
        action = new_actions[0]
        action.name = f"{name}_{path.suffix[1:]}"
        armature = new_objects[0] if new_objects else bpy.context.object
        # BVH files from this conversion start with a rest pose: the search skips frame 1 via the label file.
        action["shapesig_start"] = int(row["start"]) if row["start"] else int(action.frame_range[0])
        imported[action.name] = (armature, row["label"])
    report(f"- imported {len(imported)} clips: "
           f"{sum(1 for v in imported.values() if v[1] == 'walk')} walks, "
           f"{sum(1 for v in imported.values() if v[1] == 'run')} runs, "
           f"{sum(1 for v in imported.values() if v[1] == 'jump')} jump "
           f"({len([o for o in bpy.data.objects if o.type == 'ARMATURE'])} armatures)")
    return imported


def rank(bpy, imported, query_name, report):
    from blender_shapesig import action_io
    from blender_shapesig.core.search import rank_clips

    clips = {}
    for name, (arm, _label) in imported.items():
        action = bpy.data.actions[name]
        start = action.get("shapesig_start")
        end = int(action.frame_range[1])
        clips[name] = action_io.read_action(action, armature=arm, frame_range=(start, end))
    query = clips[query_name]
    library = [c for n, c in clips.items() if n != query_name]
    results = rank_clips(query, library, metric="sim", level=3, rerank=3)
    label = {n: lab for n, (_a, lab) in imported.items()}
    report(f"- ranked {len(library)} actions against query {query_name!r} ({label[query_name]}) by sim^3, "
           f"top 3 re-ranked by elastic distance d_S*:")
    report("  | rank | action | label | sim^3 | d_S* |")
    report("  |---|---|---|---|---|")
    for i, r in enumerate(results, 1):
        el = "" if r.elastic is None else f"{r.elastic:.3f}"
        report(f"  | {i} | {r.name} | {label.get(r.name, '?')} | {r.distance:.4f} | {el} |")
    top = [label.get(r.name) for r in results[:3]]
    report(f"  top 3 labels: {top}")
    return results


def blend(bpy, imported, name_a, name_b, report):
    from blender_shapesig import action_io
    from blender_shapesig.core.blend import blend_clips

    arm_a, _ = imported[name_a]
    arm_b, _ = imported[name_b]
    act_a, act_b = bpy.data.actions[name_a], bpy.data.actions[name_b]
    a = action_io.read_action(act_a, armature=arm_a,
                              frame_range=(act_a.get("shapesig_start"), int(act_a.frame_range[1])))
    b = action_io.read_action(act_b, armature=arm_b,
                              frame_range=(act_b.get("shapesig_start"), int(act_b.frame_range[1])))
    out = blend_clips(a, b, 0.5, align=True, depth=9)
    action = action_io.write_action(out, armature=arm_a, assign=True)
    report(f"- blended {name_a!r} ({a.frames} frames) with {name_b!r} ({b.frames} frames) at weight 0.5, "
           f"time-aligned (D = 9): new action {action.name!r}, {out.frames} frames, on armature {arm_a.name!r}")
    return action


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(ROOT / "tests" / "data"))
    parser.add_argument("--out", default=str(ROOT / "out"))
    args = parser.parse_args(argv)
    data = pathlib.Path(args.data).resolve()
    out = pathlib.Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)

    report = Report()
    t_start = time.perf_counter()
    with quiet_stdout():
        import bpy
        import blender_shapesig

        bpy.ops.wm.read_factory_settings(use_empty=True)
        blender_shapesig.register()
    report(f"# blender_shapesig demo (Blender {bpy.app.version_string}, bpy module, headless)")
    report("")

    imported = stage(report, "import")(import_clips, bpy, data, report) or {}
    query = "07_01_bvh"
    if query in imported:
        stage(report, "rank")(rank, bpy, imported, query, report)
    if "07_01_bvh" in imported and "09_02_bvh" in imported:
        stage(report, "blend")(blend, bpy, imported, "07_01_bvh", "09_02_bvh", report)

    blend_path = out / "demo.blend"
    with quiet_stdout():
        bpy.ops.wm.save_as_mainfile(filepath=str(blend_path), check_existing=False)
    report(f"- saved {blend_path.relative_to(ROOT) if blend_path.is_relative_to(ROOT) else blend_path} "
           f"({len(bpy.data.actions)} actions, {blend_path.stat().st_size / 1e6:.1f} MB)")
    report(f"- total {time.perf_counter() - t_start:.1f} s")
    (out / "demo_report.md").write_text("\n".join(report.lines) + "\n")
    blender_shapesig.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
