#!/usr/bin/env python
"""The pictures of docs/search.md, "Pictures": the result list of a Find Similar click over the demo clips as the
panel shows it, drawn from the panel's data (``window_manager.shapesig_results``: each row's label, score, frames
and ``preview_path``), and the strips of a walk, a run, a jump and a moment (headless, the bpy module):

  .venv/bin/python experiments/render_result_list.py [--out docs/img]

The six CMU BVH clips of tests/data/bvh are imported with Blender's importer as actions of one armature (the query:
walk 07_01); Find Similar runs with the panel's defaults; the picture job is stepped to its end. The list is laid
out with matplotlib (text), the pictures are the rows' PNG files as the add-on wrote them (core.raster).
"""

import argparse
import contextlib
import io
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import blender_shapesig  # noqa: E402
from blender_shapesig.search import thumbnails  # noqa: E402
from blender_shapesig.core import search as index  # noqa: E402
from blender_shapesig.core.search import thumbnails as core_thumbs  # noqa: E402
from blender_shapesig.core.io import sources  # noqa: E402
from blender_shapesig.core.raster import write_png  # noqa: E402
from tests.helpers.png import read_png  # noqa: E402

BVH = os.path.join(ROOT, "tests", "data", "bvh")
CLIPS = {"walk 07_01": "07_01", "walk 07_02": "07_02", "walk 08_01": "08_01", "run 09_02": "09_02",
         "run 09_03": "09_03", "jump 13_32": "13_32"}


def find_similar():
    import addon_utils

    addon_utils.enable("io_anim_bvh", default_set=False)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    arm = None
    for name, clip in CLIPS.items():
        with contextlib.redirect_stdout(io.StringIO()):
            bpy.ops.import_anim.bvh(filepath=os.path.join(BVH, clip + ".bvh"), rotate_mode="NATIVE", frame_start=1,
                                    use_fps_scale=False, update_scene_fps=False, update_scene_duration=False)
        obj = bpy.context.view_layer.objects.active
        obj.animation_data.action.name = name
        obj.animation_data.action.use_fake_user = True
        if arm is None:
            arm = obj
        else:
            bpy.data.objects.remove(obj)
    bpy.context.view_layer.objects.active = arm
    bpy.context.scene.shapesig.fps = 120.0
    bpy.ops.shapesig.rank()
    job = thumbnails.current_job()
    while not job.finished:
        job.step()
    return bpy.context.window_manager.shapesig_results


def draw_list(res, path):
    """The list as the panel lays it out: header, one row per result (picture, label, score, frames), the active
    row highlighted, its larger picture below."""
    from blender_shapesig.evaluation.plots import pyplot

    plt = pyplot()
    rows = list(res.results)
    fig = plt.figure(figsize=(5.2, 0.42 * len(rows) + 2.6), dpi=100, facecolor="#303030")
    top = 1.0 - 0.3 / fig.get_figheight()
    h = 0.42 / fig.get_figheight()
    fig.text(0.03, top, f"Similar to {res.query_name}, sorted by {res.order_by} (best first)", color="#ddd",
             fontsize=8, va="top")
    fig.text(0.03, top - 0.6 * h, "Clip", color="#aaa", fontsize=8, va="top")
    fig.text(0.62, top - 0.6 * h, f"{res.order_by} \u25b2", color="#aaa", fontsize=8, va="top")
    fig.text(0.85, top - 0.6 * h, "Frames", color="#aaa", fontsize=8, va="top")
    for i, r in enumerate(rows):
        y = top - (i + 1.6) * h
        if i == res.results_index:
            fig.patches.append(plt.Rectangle((0.02, y - 0.05 * h), 0.96, 0.95 * h, transform=fig.transFigure,
                                             color="#4772b3", zorder=-1))
        ax = fig.add_axes([0.03, y, 0.16, 0.85 * h])
        ax.imshow(read_png(r.preview_path))
        ax.axis("off")
        fig.text(0.21, y + 0.4 * h, r.label or r.name, color="#eee", fontsize=9, va="center")
        fig.text(0.62, y + 0.4 * h, f"{r.distance:.4f}", color="#eee", fontsize=9, va="center")
        fig.text(0.85, y + 0.4 * h, f"{r.frames} f", color="#eee", fontsize=9, va="center")
    active = rows[res.results_index]
    big_h = 1.9 / fig.get_figheight()
    ax = fig.add_axes([0.1, 0.03, 0.8, big_h])
    ax.imshow(read_png(active.preview_path))
    ax.axis("off")
    fig.savefig(path, facecolor=fig.get_facecolor())
    plt.close(fig)


def draw_strips(path):
    """Walk, run, jump, and a moment of the jump (its window marked), one strip each, stacked."""
    store = index.SignatureCache(None)
    items = sources.library([os.path.join(BVH, f"{c}.bvh") for c in ("07_01", "09_02", "13_32")])
    strips = [core_thumbs.entry_strip(core_thumbs.local_entry_of(it, store)) for it in items]
    strips.append(core_thumbs.entry_strip(core_thumbs.local_entry_of(items[2], store), window=(0.45, 0.75)))
    gap = np.full((4, strips[0].shape[1], 4), 255, np.uint8)
    write_png(path, np.concatenate([x for s in strips for x in (s, gap)][:-1]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "img"))
    args = ap.parse_args()
    os.environ[index.CACHE_ENV] = tempfile.mkdtemp(prefix="shapesig-pictures-")
    blender_shapesig.register()
    try:
        res = find_similar()
        draw_list(res, os.path.join(args.out, "search_result_list.png"))
        draw_strips(os.path.join(args.out, "search_strips.png"))
    finally:
        blender_shapesig.unregister()


if __name__ == "__main__":
    main()
