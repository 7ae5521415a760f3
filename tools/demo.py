"""The main job, headless on the bpy module (run by tools/demo.sh):

1. import the sample CMU clips into one file: ASF/AMC with our importer (``shapesig.import_acclaim``), BVH with
   Blender's own importer;
2. rank every action against one query walk with Find Similar's default search, motion and pose window by window
   (``shapesig.build_index`` + ``shapesig.rank``), reported in the panel's words (``core.measure_words``: a
   column only when a row has a value in it);
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
            from blender_shapesig.core.errors import error_line

            report(f"- {title}: FAILED: {error_line(exc)}")
            if os.environ.get("SHAPESIG_DEBUG"):
                traceback.print_exc()
            return None
        report(f"  ({title}: {time.perf_counter() - t0:.2f} s)")
        return result

    return run


def trim_action(action, armature, fps=None):
    """The Daz-friendly BVH files start with the rest pose and a ramp into the motion: find them as every reader
    does (``core.clip.trim.detect_trim``) and set the action's manual frame range to the rest (what an animator does
    in the Action properties), so that search and blends read only the motion. Returns the kept (first, last)
    or None when there is nothing to trim. ``fps``: the action's rate (a BVH file's, which Blender's importer does
    not record; stored as ``shapesig_fps``, the property every reader of this package takes the rate from)."""
    from blender_shapesig.actions import action_io
    from blender_shapesig.core.clip.trim import detect_trim

    if fps is not None:
        action["shapesig_fps"] = float(fps)
    clip = action_io.read_action(action, armature=armature)
    cut = detect_trim(clip.rotations, clip.fps)
    if not cut:
        return None
    first, last = clip.frame_start + cut.head, clip.frame_end - cut.tail
    action.use_frame_range = True
    action.frame_start, action.frame_end = first, last
    return first, last


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
        fps = None
        with quiet_stdout():
            if path.suffix == ".bvh":
                from blender_shapesig.readers.bvh import import_armature

                _arm, frame_time = import_armature(path)  # Blender's importer with the settings every reader uses
                fps = round(1.0 / frame_time, 3)
            else:
                bpy.ops.shapesig.import_acclaim(filepath=str(path), asf_path=str(data / row["skeleton"]))
        new_actions = [a for a in bpy.data.actions if a not in before_actions]
        new_objects = [o for o in bpy.data.objects if o not in before_objects and o.type == "ARMATURE"]
        if not new_actions:
            raise RuntimeError(f"importing {row['file']} created no action")
        action = new_actions[0]
        action.name = f"{name}_{path.suffix[1:]}"
        armature = new_objects[0] if new_objects else bpy.context.object
        kept = trim_action(action, armature, fps)
        if kept is not None:
            report(f"  {action.name}: rest pose and ramp trimmed, frames {kept[0]}..{kept[1]} kept "
                   f"(core.clip.trim, as --trim auto)")
        imported[action.name] = (armature, row["label"])
    report(f"- imported {len(imported)} clips: "
           f"{sum(1 for v in imported.values() if v[1] == 'walk')} walks, "
           f"{sum(1 for v in imported.values() if v[1] == 'run')} runs, "
           f"{sum(1 for v in imported.values() if v[1] == 'jump')} jump "
           f"({len([o for o in bpy.data.objects if o.type == 'ARMATURE'])} armatures)")
    return imported


def result_columns(order_by, any_elastic):
    """The ranking table's value columns (``core.measure_words``): the first measure's (the score, or the similarity
    when the rows are sorted by it or re-ranked by the timing-aligned difference), then the timing-aligned
    difference's when some row has one."""
    from blender_shapesig.core.measure_words import MEASURES

    first = MEASURES["local" if order_by == "local" else "sim"]
    return [first.column] + ([MEASURES["elastic"].column] if any_elastic else [])


def rank(bpy, imported, query_name, report):
    """The search panel's work: index the file's actions, then rank them against the query's action."""
    arm, query_label = imported[query_name]
    ctx = bpy.context
    ctx.view_layer.objects.active = arm
    arm.animation_data.action = bpy.data.actions[query_name]
    s = ctx.scene.shapesig
    s.top = 0
    with quiet_stdout():
        assert bpy.ops.shapesig.build_index() == {"FINISHED"}
        assert bpy.ops.shapesig.rank() == {"FINISHED"}
    from blender_shapesig.core.measure_words import ENGINES, MEASURES, OPTIONS, measure_words

    label = {n: lab for n, (_a, lab) in imported.items()}
    res = bpy.context.window_manager.shapesig_results
    results = list(res.results)
    checked = f", the best {s.rerank} re-ranked by {MEASURES['elastic'].status}" if res.order_by == "elastic" else ""
    engine = f"{OPTIONS['similarity'].label}: {ENGINES[s.similarity].label}"
    report(f"- ranked the file's actions against query {query_name!r} ({query_label}) by "
           f"{measure_words(res.order_by).status} ({engine}){checked} (shapesig.build_index + shapesig.rank):")
    columns = result_columns(res.order_by, any(r.has_elastic for r in results))
    report(f"  | rank | action | label | {' | '.join(columns)} | frames |")
    report("  " + "|---" * (len(columns) + 4) + "|")
    for i, r in enumerate(results, 1):
        values = [f"{r.distance:.4f}"] + ([f"{r.elastic:.3f}" if r.has_elastic else ""] if len(columns) > 1 else [])
        report(f"  | {i} | {r.name} | {label.get(r.name, '?')} | {' | '.join(values)} | {r.frames} |")
    if bpy.context.window_manager.shapesig_results.message:
        report(f"  panel says: {bpy.context.window_manager.shapesig_results.message}")
    top = [label.get(r.name) for r in results[:3]]
    report(f"  labels of the top 3: {top}")
    return results


def blend(bpy, imported, name_a, name_b, report):
    """shapesig.blend_actions on the first armature: a time-aligned geodesic blend at weight 0.5."""
    arm, _ = imported[name_a]
    ctx = bpy.context
    ctx.view_layer.objects.active = arm
    before = set(bpy.data.actions)
    with quiet_stdout():
        result = bpy.ops.shapesig.blend_actions(action_a=name_a, action_b=name_b, weight=0.5, align=True,
                                                assign=True)  # the operator's default depth
    new = [a for a in bpy.data.actions if a not in before]
    if result != {"FINISHED"} or not new:
        raise RuntimeError(f"shapesig.blend_actions returned {result}")
    action = new[0]
    first, last = (int(round(v)) for v in action.frame_range)
    frames = {int(round(a.frame_range[1] - a.frame_range[0])) + 1 for a in (bpy.data.actions[name_a],
                                                                               bpy.data.actions[name_b])}
    from blender_shapesig.core.measure_words import OPTIONS
    from blender_shapesig.core.metrics import DEFAULT_DEPTH
    from blender_shapesig.actions.scene_motion import timing_text

    report(f"- blended {name_a!r} with {name_b!r} at weight 0.5, time-aligned ({OPTIONS['depth'].label} "
           f"{DEFAULT_DEPTH}; source lengths "
           f"{sorted(frames)} frames): new action {action.name!r}, frames {first}..{last} "
           f"({timing_text(action)}), assigned to {arm.name!r} (shapesig.blend_actions)")
    return action


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(ROOT / "tests" / "data"))
    parser.add_argument("--out", default=str(ROOT / "out"))
    args = parser.parse_args(argv)
    data = pathlib.Path(args.data).resolve()
    out = pathlib.Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    # the signature index of this demo lives beside its outputs (a second run reuses it)
    os.environ.setdefault("SHAPESIG_CACHE_DIR", str(out / "cache"))

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
