"""Read the actions of a .blend file in a child process (see ``readers.blend_file.read_blend_file``): a damaged file
that crashes Blender's reader ends only this process. Run by this Python with the bpy module or by the Blender
binary in background mode, with one JSON argument; the clips come back as an .npz. The protocol:
docs/dev/blender_layer.md.
"""

import importlib
import json
import os
import sys

import numpy as np

# meta entries that travel back (JSON values; rest_rotations as an array); the rest skeleton for forward
# kinematics (planted feet, the hips of a blend across rigs)
_META_KEYS = ("rotation_space", "up_axis", "format", "action", "slot", "fcurve_hash", "still_bones",
              "missing_rotation_bones", "parents", "rest_heads", "rest_tails", "rig", "animation")


def write_result(out, clips=None, error=None):
    arrays, header = {}, {}
    if error is not None:
        header["error"] = str(error).splitlines()[0] if str(error) else type(error).__name__
    else:
        header["clips"] = []
        for i, c in enumerate(clips):
            arrays[f"rotations{i}"] = c.rotations
            if c.root_translation is not None:
                arrays[f"root{i}"] = c.root_translation
            if "rest_rotations" in c.meta:
                arrays[f"rest{i}"] = np.asarray(c.meta["rest_rotations"])
            meta = {k: (list(v) if isinstance(v, tuple) else v) for k, v in c.meta.items() if k in _META_KEYS}
            header["clips"].append({
                "name": c.name, "bones": list(c.bones), "fps": c.fps, "frame_start": c.frame_start,
                "root_bone": c.root_bone, "rotation_modes": list(c.rotation_modes), "source": c.source,
                "meta": meta,
            })
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    tmp = out + ".part"
    with open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    os.replace(tmp, out)


def read_result(out, clip_type):
    """The clips (or the error message) written by ``write_result``: (clips, error)."""
    with np.load(out, allow_pickle=False) as data:
        header = json.loads(bytes(data["header"]).decode())
        if "error" in header:
            return None, header["error"]
        clips = []
        for i, h in enumerate(header["clips"]):
            meta = {k: (tuple(v) if isinstance(v, list) else v) for k, v in h["meta"].items()}
            if f"rest{i}" in data:
                meta["rest_rotations"] = np.array(data[f"rest{i}"])
            clips.append(clip_type(
                name=h["name"], bones=tuple(h["bones"]), rotations=np.array(data[f"rotations{i}"]),
                fps=h["fps"], frame_start=h["frame_start"],
                root_translation=np.array(data[f"root{i}"]) if f"root{i}" in data else None,
                root_bone=h["root_bone"], rotation_modes=tuple(h["rotation_modes"]), source=h["source"], meta=meta,
            ))
        return clips, None


def boot(args):
    """A reading child's first steps (this one's and ``_child_main``'s): the package and the parent's ``sys.path``
    importable, then ``guard.guard_self`` (die with the parent)."""
    for p in [args["package_dir"]] + list(args["sys_path"]):
        if p not in sys.path:
            sys.path.append(p)
    importlib.import_module(f"{args['package']}.readers.guard").guard_self(args)


def main(argv):
    args = json.loads(argv[-1])
    boot(args)
    reader = importlib.import_module(f"{args['package']}.readers.blend_file")
    errors = importlib.import_module(f"{args['package']}.core.errors")
    try:
        clips = reader.read_blend_here(args["path"], args["action"], args["space"], args.get("rig", False))
    except errors.ShapeSigError as exc:
        write_result(args["out"], error=exc)
    else:
        write_result(args["out"], clips=clips)


if __name__ == "__main__":
    main(sys.argv)
