"""Acclaim skeletons and takes as Blender data, the armature builder behind ``shapesig.import_acclaim``:
``import_acclaim(context, asf_path, amc_paths)`` builds an armature from the ASF and one action per AMC take, and
``clip_to_pose`` maps core Acclaim clips (and blends of them) onto such an armature. On any error nothing is left
created. Geometry (axes, rolls, pose rotations): docs/action_io.md, "Importer".
"""

import os

import bpy
import numpy as np

from .. import compat
from ..actions import action_io, action_spaces
from ..core.clip.clip import Clip
from ..core.errors import ShapeSigError
from ..core.io.acclaim import ASF_TO_BLENDER, parse_amc, parse_asf, to_blender_axes
from ..core.io.acclaim import find_asf

__all__ = ["import_acclaim", "choose_files", "clip_to_pose", "pose_clip", "rest_geometry", "AXIS_CONVERSION"]

AXIS_CONVERSION = ASF_TO_BLENDER  # ASF Y up -> Blender Z up


def choose_files(paths, asf_path=""):
    """(skeleton, [takes]) of the files an animator picked: ``asf_path`` when given, else the one .asf picked,
    else the only .asf beside the first .amc. ShapeSigError (one line) for anything else."""
    if not paths:
        raise ShapeSigError("no file given")
    bad = [p for p in paths if os.path.splitext(p)[1].lower() not in (".asf", ".amc")]
    if bad:
        raise ShapeSigError(f"not an .asf or .amc file: {bad[0]}")
    missing = [p for p in paths if not os.path.isfile(p)]
    if missing:
        raise ShapeSigError(f"no such file: {missing[0]}")
    asfs = [p for p in paths if p.lower().endswith(".asf")]
    amcs = [p for p in paths if p.lower().endswith(".amc")]
    if asf_path:
        if not os.path.isfile(asf_path):
            raise ShapeSigError(f"no such skeleton file: {asf_path}")
        return asf_path, amcs
    if len(asfs) > 1:
        raise ShapeSigError("several .asf files selected; select one skeleton")
    return (asfs[0] if asfs else find_asf(amcs[0])), amcs


def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else None


def rest_geometry(skeleton, scale=1.0):
    """Per bone (skeleton order): Blender rest head, tail (armature space) and the wanted Z axis for the roll.

    Returns (heads, tails, z_axes) arrays (bones, 3)."""
    A = AXIS_CONVERSION
    s = skeleton.meters_per_unit * scale
    heads, tails = skeleton.rest_heads_tails()
    lengths = [b.length for b in skeleton.bones.values() if b.length > 0]
    short = (0.25 * float(np.median(lengths)) if lengths else 1.0) * s
    bh, bt, bz = [], [], []
    for i, bone in enumerate(skeleton.bones.values()):
        AC = A @ bone.axis_matrix
        head = s * (A @ heads[i])
        y = _unit(A @ bone.direction) if bone.length > 0 else None
        length = bone.length * s
        if y is None or length < 1e-6 * max(short, 1e-9):
            # the root and zero-length bones: along the axis frame's Y
            y = AC[:, 1]
            length = short
        tail = head + y * length
        x = AC[:, 0] - np.dot(AC[:, 0], y) * y
        if np.linalg.norm(x) < 1e-6:
            z = AC[:, 2] - np.dot(AC[:, 2], y) * y
            z = z / np.linalg.norm(z)
        else:
            x = x / np.linalg.norm(x)
            z = np.cross(x, y)
        bh.append(head)
        bt.append(tail)
        bz.append(z)
    return np.array(bh), np.array(bt), np.array(bz)


def pose_clip(motion, rest_rotations, name, scale=1.0, frame_step=1, fps=120.0, rotation_mode="QUATERNION"):
    """The motion as a Clip of pose-bone rotations for an armature whose bones (skeleton order) have the
    armature-space rest rotations ``rest_rotations`` (bones, 3, 3), and the root's location."""
    sk = motion.skeleton
    A = AXIS_CONVERSION
    C = sk.axis_matrices()
    M = motion.amc_rotations()[::frame_step]
    B = np.asarray(rest_rotations)
    # P = B^T A C M C^T A^T B = K M K^T with K = B^T A C
    K = np.swapaxes(B, -1, -2) @ A[None] @ C
    P = K[None] @ M @ np.swapaxes(K, -1, -2)[None]
    s = sk.meters_per_unit * scale
    T = motion.root_translation()[::frame_step]
    rest_head = s * (A @ sk.root_position)
    loc = (s * T @ A.T - rest_head) @ B[0]  # B^T v for row vectors
    if rotation_mode == "NATIVE":
        modes = tuple(sk.root_axis if n == "root" else b.rotation_order for n, b in sk.bones.items())
    else:
        modes = (rotation_mode,) * len(sk.bones)
    return Clip(
        name=name, bones=sk.bone_names, rotations=P, fps=fps / frame_step,
        frame_start=1, root_translation=loc, root_bone="root", rotation_modes=modes,
        source=motion.path or "", meta={"format": "acclaim", "asf": sk.path},
    )


def clip_to_pose(clip, armature):
    """A core Acclaim clip (``core.io.acclaim.load_acclaim``: ``L = C M C^-1`` in ASF Y-up axes, root translation
    in ASF units, or the same already in Blender axes), or anything computed from such clips (e.g. a blend),
    converted to the pose-bone rotations and root location of an armature made by this importer
    (``P = B^T A L A^T B``, ``loc = B_root^T (s A T - rest head)``). Bones the armature lacks raise
    ShapeSigError."""
    props = armature.data.get("shapesig_acclaim") if armature is not None else None
    if props is None:
        raise ShapeSigError(f"{getattr(armature, 'name', armature)!r} was not made by the Acclaim importer")
    if clip.meta.get("rotation_space") == "asf":
        scale = float(props["units_to_blender"]) / float(clip.meta.get("meters_per_unit", 1.0))
        clip = to_blender_axes(clip, scale)
    return action_spaces.to_pose_space(clip, armature)


def _build_armature(context, skeleton, name, scale):
    """A new armature object linked to the active collection; returns (object, bone name map)."""
    heads, tails, zs = rest_geometry(skeleton, scale)
    arm_data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, arm_data)
    context.collection.objects.link(obj)
    for o in context.view_layer.objects:
        if o.select_get():
            o.select_set(False)
    context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT", toggle=False)
    try:
        ebs = arm_data.edit_bones
        names = {}
        for i, bone in enumerate(skeleton.bones.values()):
            eb = ebs.new(bone.name)
            eb.head = heads[i].tolist()
            eb.tail = tails[i].tolist()
            eb.align_roll(zs[i].tolist())
            names[bone.name] = eb.name
            if bone.parent is not None:
                eb.parent = ebs[names[bone.parent]]
                eb.use_connect = False
    finally:
        bpy.ops.object.mode_set(mode="OBJECT", toggle=False)
    # what clip_to_pose needs to map core Acclaim clips onto this armature
    arm_data["shapesig_acclaim"] = {"asf": skeleton.path or "", "units_to_blender": skeleton.meters_per_unit * scale}
    return obj, names


def import_acclaim(context, asf_path, amc_paths, scale=1.0, frame_step=1, fps=120.0,
                   rotation_mode="QUATERNION", update_scene=False):
    """Import an ASF skeleton and AMC takes. Everything is parsed and computed before anything is created;
    on error whatever was created is removed and the ShapeSigError propagates. Returns (object, [actions])."""
    if frame_step < 1:
        raise ShapeSigError("frame step must be at least 1")
    if not fps > 0:
        raise ShapeSigError("fps must be positive")
    if not scale > 0:
        raise ShapeSigError("scale must be positive")
    skeleton = parse_asf(asf_path)
    motions = [parse_amc(p, skeleton) for p in amc_paths]
    name = os.path.splitext(os.path.basename(asf_path))[0]
    with np.errstate(all="ignore"):
        geometry = np.concatenate(rest_geometry(skeleton, scale)[:2])
    if not (np.all(np.isfinite(geometry)) and np.abs(geometry).max() < 1e30):
        raise ShapeSigError(f"{asf_path}: the skeleton's bone positions are not finite or too large for Blender "
                            f"(check its :units length and the bone lengths, or the scale)")

    if context.object is not None and context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT", toggle=False)
    created_actions = []
    obj = None
    try:
        obj, names = _build_armature(context, skeleton, name, scale)
        if any(names[n] != n for n in names):
            renamed = [n for n in names if names[n] != n]
            raise ShapeSigError(f"bone name(s) too long for Blender: {', '.join(renamed[:3])}")
        rest = np.array([np.array(obj.data.bones[names[n]].matrix_local.to_3x3()) for n in skeleton.bone_names])
        for pb in obj.pose.bones:
            pb.rotation_mode = "QUATERNION" if rotation_mode == "NATIVE" else rotation_mode
        if rotation_mode == "NATIVE":
            for n, bone in skeleton.bones.items():
                obj.pose.bones[names[n]].rotation_mode = skeleton.root_axis if n == "root" else bone.rotation_order
        for path, motion in zip(amc_paths, motions):
            clip = pose_clip(motion, rest, os.path.splitext(os.path.basename(path))[0], scale=scale,
                             frame_step=frame_step, fps=fps, rotation_mode=rotation_mode)
            created_actions.append(action_io.write_action(clip, armature=obj, fake_user=True))
        if created_actions:
            compat.assign_action(obj, created_actions[0])
            if update_scene:
                scene = context.scene
                clip_fps = fps / frame_step
                scene.render.fps = max(1, int(round(clip_fps)))
                scene.render.fps_base = scene.render.fps / clip_fps
                scene.frame_start = 1
                scene.frame_end = max(m.frames for m in motions) // frame_step + 1
    except BaseException:
        for action in created_actions:
            compat.remove_action(action)
        if obj is not None:
            data = obj.data
            bpy.data.objects.remove(obj, do_unlink=True)
            bpy.data.armatures.remove(data, do_unlink=True)
        raise
    return obj, created_actions
