#!/usr/bin/env python
"""A rendered contact sheet of a walk x run blend before and after ``core.blend.feet.lock_feet`` (docs/blending.md,
"Planted feet"), headless with the bpy module (Workbench engine):

  .venv/bin/python experiments/render_contact_sheet.py --data ../shared/data/cmu [--weight 0.5] [--frames 6]
      [--out docs/img/feet_contact_sheet.png]

The blend is the benchmark's 07_01 x 09_02 stride (benchmarks/bench_foot_drift.py) on 07_01's rig, imported with
``readers.acclaim.import_acclaim``; both versions are written with ``action_io.write_action``. The armature is
skinned with one box per bone (an Armature modifier) and walks over a floor of 25 cm tiles, seen from the side by
a fixed orthographic camera: a planted foot stays on its tile from frame to frame (a red post marks where the
planted right ball stands mid-stance). Rows:
the blend, the planted blend; columns: evenly spaced frames over the first ``span`` seconds (the right foot's
stance).
"""

import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for path in (ROOT, os.path.join(ROOT, "benchmarks")):
    if path not in sys.path:
        sys.path.insert(0, path)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from bench_foot_drift import ANIM, ASF, CLIPS, blend_pair, load  # noqa: E402
from blender_shapesig import compat  # noqa: E402
from blender_shapesig.actions import action_io  # noqa: E402
from blender_shapesig.core.blend import contacts, feet  # noqa: E402
from blender_shapesig.readers.acclaim import import_acclaim  # noqa: E402


def _body(arm, width=0.035):
    """A mesh of one box per bone (rest pose, armature space), each box weighted to its bone, deformed by arm."""
    verts, faces, groups = [], [], []
    cube = np.array([[x, y, z] for x in (0, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    for bone in arm.data.bones:
        head, tail = np.array(bone.head_local), np.array(bone.tail_local)
        axis = tail - head
        if np.linalg.norm(axis) < 1e-4 or bone.parent is None:
            continue
        y = axis / np.linalg.norm(axis)
        x = np.cross(y, [0.0, 0.0, 1.0] if abs(y[2]) < 0.9 else [1.0, 0.0, 0.0])
        x /= np.linalg.norm(x)
        z = np.cross(x, y)
        base = len(verts)
        for c in cube:
            verts.append(head + c[0] * axis + c[1] * width * x + c[2] * width * z)
        faces += [tuple(base + i for i in q) for q in quads]
        groups.append((bone.name, range(base, base + 8)))
    mesh = bpy.data.meshes.new("body")
    mesh.from_pydata([tuple(v) for v in verts], [], faces)
    obj = bpy.data.objects.new("body", mesh)
    bpy.context.collection.objects.link(obj)
    obj.matrix_world = arm.matrix_world
    for name, idx in groups:
        obj.vertex_groups.new(name=name).add(list(idx), 1.0, "REPLACE")
    obj.modifiers.new("skin", "ARMATURE").object = arm
    obj.color = (0.85, 0.45, 0.2, 1.0)
    return obj


def _floor(center, along, length, tile=0.25):
    """A floor of alternating grey tiles around ``center`` (x, y), ``length`` metres along ``along``."""
    n = int(np.ceil(length / tile)) + 6
    light = bpy.data.materials.new("tile_light")
    light.diffuse_color = (0.8, 0.8, 0.8, 1.0)
    dark = bpy.data.materials.new("tile_dark")
    dark.diffuse_color = (0.35, 0.35, 0.4, 1.0)
    side = np.array([-along[1], along[0]])
    verts, faces, mats = [], [], []
    for i in range(-n // 2, n // 2):
        for j in range(-4, 4):
            base = len(verts)
            for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = center + (i + di) * tile * along + (j + dj) * tile * side
                verts.append((p[0], p[1], 0.0))
            faces.append((base, base + 1, base + 2, base + 3))
            mats.append((i + j) % 2)
    mesh = bpy.data.meshes.new("floor")
    mesh.from_pydata(verts, [], faces)
    mesh.materials.append(light)
    mesh.materials.append(dark)
    for poly, m in zip(mesh.polygons, mats):
        poly.material_index = m
    obj = bpy.data.objects.new("floor", mesh)
    bpy.context.collection.objects.link(obj)
    return obj


def _camera(center, along, length, height=1.0):
    """An orthographic camera looking across the direction of travel at the lower body."""
    side = np.array([-along[1], along[0], 0.0])
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    bpy.context.collection.objects.link(cam)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = length
    target = np.array([center[0], center[1], height * 0.45])
    cam.location = tuple(target - 4.0 * side + np.array([0.0, 0.0, 1.6]))
    direction = target - np.array(cam.location)
    import mathutils

    cam.rotation_euler = mathutils.Vector(direction).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = cam
    return cam


def render(data, weight, count, out, span=0.45):
    a, b = load(data, "07_01"), load(data, "09_02")
    blend = blend_pair(a, b, weight)
    locked, _report = feet.lock_feet(blend, [a, b])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    path, asf = CLIPS["07_01"][:2]
    assert path.startswith(ANIM) and asf.startswith(ASF)
    arm, _actions = import_acclaim(bpy.context, os.path.join(data, asf), [os.path.join(data, path)])
    actions = [action_io.write_action(c, armature=arm, name=n) for c, n in ((blend, "blend"), (locked, "planted"))]
    _body(arm)
    root = blend.root_translation
    along = (root[-1] - root[0])[:2]
    along /= np.linalg.norm(along)
    center = 0.5 * (root[0, :2] + root[-1, :2])
    frames = np.linspace(blend.frame_start, blend.frame_start + span * blend.fps, count).round().astype(int)
    stretch = root[frames - blend.frame_start, :2]
    center = 0.5 * (stretch[0] + stretch[-1])
    length = float(np.linalg.norm(stretch[-1] - stretch[0])) + 1.1
    _floor(center, along, length + 4.0)
    _camera(center, along, length)
    _post(locked, [a, b], span)
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "OBJECT"
    scene.render.resolution_x, scene.render.resolution_y = 480, 400
    scene.render.image_settings.file_format = "PNG"
    tmp = tempfile.mkdtemp(prefix="shapesig_sheet_")
    images = []
    floor = bpy.data.objects["floor"]
    floor.color = (1.0, 1.0, 1.0, 1.0)
    scene.display.shading.color_type = "MATERIAL"
    bpy.data.objects["body"].active_material = _body_material()
    for action in actions:
        compat.assign_action(arm, action)
        row = []
        for f in frames:
            scene.frame_set(int(f))
            scene.render.filepath = os.path.join(tmp, f"{action.name}_{f}.png")
            bpy.ops.render.render(write_still=True)
            row.append(scene.render.filepath)
        images.append(row)
    _sheet(images, frames, blend, out, weight)
    return out


def _post(locked, sources, span):
    """A thin red post where the planted right ball stands mid-stance (a fixed reference for the eye)."""
    work = feet._working_clip(locked, sources)
    ball = contacts.feet_positions(work)["R"]["ball"][int(0.5 * span * locked.fps)]
    bpy.ops.mesh.primitive_cylinder_add(radius=0.012, depth=0.5, location=(ball[0], ball[1], 0.25))
    post = bpy.context.active_object
    mat = bpy.data.materials.new("post")
    mat.diffuse_color = (0.9, 0.05, 0.05, 1.0)
    post.active_material = mat
    return post


def _body_material():
    mat = bpy.data.materials.new("body")
    mat.diffuse_color = (0.85, 0.45, 0.2, 1.0)
    return mat


def _sheet(images, frames, blend, out, weight):
    """The rendered frames in a grid (matplotlib), rows labelled."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, cols = len(images), len(images[0])
    fig, axes = plt.subplots(rows, cols, figsize=(2.4 * cols, 2.0 * rows + 0.5))
    for r, (row, label) in enumerate(zip(images, ("blend", "planted (lock_feet)"))):
        for c, png in enumerate(row):
            ax = axes[r, c]
            ax.imshow(plt.imread(png))
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"{(frames[c] - blend.frame_start) / blend.fps:.2f} s", fontsize=9)
            if c == 0:
                ax.set_ylabel(label, fontsize=9)
    fig.suptitle(f"07_01 x 09_02, w = {weight:g}: the right foot's stance (tiles 25 cm)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=130)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="the CMU data folder (the one with INDEX.md)")
    parser.add_argument("--weight", type=float, default=0.5)
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "img", "feet_contact_sheet.png"))
    args = parser.parse_args(argv)
    print(render(args.data, args.weight, args.frames, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
