"""Reading FBX clips (Blender's FBX importer in the reading child) against the same motion as BVH through
Blender's BVH importer, and a folder of 10 FBX files read by one child against one child per file; both in the same
run.

    .venv/bin/python benchmarks/bench_read_formats.py [--bvh tests/data/bvh/07_01.bvh] [--files 10] [--json OUT]

The FBX is written here by Blender's FBX exporter from the BVH (imported with its importer; a small skinned cube
makes the exporter write the bind pose). Times are wall seconds (the child's CPU is not this process's), best and
median of the repeats:

* ``bvh_importer``: ``readers.bvh.import_bvh`` (Blender's BVH importer in this process) - the baseline;
* ``fbx_child_warm``: ``core.io.sources.read`` of the FBX with the reading child already running (what each file
  of a folder costs); ``fbx_here``: ``readers.interchange.read_interchange_here`` in this process (the importers
  side by side); ``fbx_child_cold``: the first read, a child started for it;
* ``folder_batched``: the folder's files read one after the other (one child); ``folder_child_per_file``: the
  child closed after each file (a start-up per file, the cost without batching).
"""

import argparse
import json
import os
import pathlib
import shutil
import tempfile

import _common as harness  # noqa: E402  (puts the repository on sys.path)

import bpy  # noqa: E402

import blender_shapesig  # noqa: E402,F401  (registers the readers)
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.readers import child  # noqa: E402
from blender_shapesig.readers.bvh import import_bvh  # noqa: E402
from blender_shapesig.readers.interchange import read_interchange_here  # noqa: E402


def write_fbx(bvh, out):
    """``out``: the BVH's motion as an FBX written by Blender's exporter (every frame, the bind pose)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=str(bvh), rotate_mode="NATIVE", update_scene_fps=True,
                            update_scene_duration=True)
    arm = bpy.context.object
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, int(arm.animation_data.action.frame_range[1])
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    cube = bpy.context.object
    cube.parent = arm
    cube.modifiers.new("rig", "ARMATURE").object = arm
    cube.vertex_groups.new(name=arm.data.bones[0].name).add(list(range(8)), 1.0, "REPLACE")
    bpy.ops.export_scene.fbx(filepath=str(out), object_types={"ARMATURE", "MESH"}, add_leaf_bones=False,
                             bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _read(path):
    return sources.read(sources.ClipSpec(str(path), trim="none", bone_map="none"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bvh", type=pathlib.Path, default=harness.ROOT / "tests" / "data" / "bvh" / "07_01.bvh")
    ap.add_argument("--files", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", type=pathlib.Path)
    args = ap.parse_args(argv)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="shapesig_bench_formats_"))
    try:
        fbx = tmp / "walk.fbx"
        write_fbx(args.bvh, fbx)
        folder = tmp / "folder"
        folder.mkdir()
        for i in range(args.files):
            shutil.copy(fbx, folder / f"walk_{i:02d}.fbx")
        files = sorted(folder.iterdir())
        (clip,) = _read(fbx)
        ref = import_bvh(str(args.bvh))
        assert clip.frames == ref.frames and clip.fps == ref.fps, (clip.frames, ref.frames, clip.fps, ref.fps)

        def cold():
            child.close()
            return _read(fbx)

        def each_own_child():
            for f in files:
                child.close()
                _read(f)
            child.close()

        def batched():
            child.close()
            for f in files:
                _read(f)

        r = args.repeat
        out = {"bvh": str(args.bvh.relative_to(harness.ROOT)) if args.bvh.is_relative_to(harness.ROOT) else
               args.bvh.name, "frames": ref.frames, "bones": len(ref.bones), "fbx_bytes": os.path.getsize(fbx)}
        times = {
            "bvh_importer": harness.timed(lambda: import_bvh(str(args.bvh)), repeat=r),
            "fbx_here": harness.timed(lambda: read_interchange_here(str(fbx)), repeat=r),
            "fbx_child_warm": harness.timed(lambda: _read(fbx), repeat=r),
            "fbx_child_cold": harness.timed(cold, repeat=max(2, r // 2)),
            "folder_batched": harness.timed(batched, repeat=max(2, r // 2)),
            "folder_child_per_file": harness.timed(each_own_child, repeat=max(2, r // 2)),
        }
        child.close()
        out["seconds"] = {k: {"best": round(t.wall_min, 4), "median": round(t.wall_median, 4)} for k, t in times.items()}
        base = times["bvh_importer"].wall_median
        out["ratio_fbx_child_warm_to_bvh"] = round(times["fbx_child_warm"].wall_median / base, 2)
        out["ratio_fbx_here_to_bvh"] = round(times["fbx_here"].wall_median / base, 2)
        out["ratio_fbx_child_cold_to_bvh"] = round(times["fbx_child_cold"].wall_median / base, 2)
        out["folder_speedup_batched"] = round(times["folder_child_per_file"].wall_median /
                                              times["folder_batched"].wall_median, 2)
        out["starts_per_folder_batched"] = 1
        out["machine"] = harness.machine()
        if args.json:
            harness.write_json(args.json, out)
        print(json.dumps({k: v for k, v in out.items() if k != "machine"}, indent=2))
    finally:
        child.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
