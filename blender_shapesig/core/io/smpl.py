"""SMPL / SMPL-H / SMPL-X motion files (AMASS ``.npz``), pure numpy: ``load_smpl(path) -> Clip``. The file holds
per-frame axis-angle rotations of the SMPL kinematic tree (``poses``: 3 numbers per joint, the root first; SMPL 24
joints, SMPL-H 52, SMPL-X 55; or SMPL-X's ``root_orient`` + ``pose_body``), the root path ``trans`` (metres, the
world Z up) and the rate (``mocap_framerate`` or ``mocap_frame_rate``); the body's 22 joints are read (fingers,
jaw and eyes are not canonical joints). The body's shape (``betas``) needs the licensed SMPL model to become joint
positions, so the rest skeleton is one mean-shape table (``REST_OFFSETS``, approximate): rotations are exact,
rest positions are not the subject's. See docs/action_io.md, "SMPL and AMASS files".
"""


import numpy as np

from ..clip.clip import Clip
from ..clip.skeleton import rest_meta
from ..geometry import so3
from ..errors import ParseError
from . import files

__all__ = ["load_smpl", "BODY_JOINTS", "BODY_PARENTS", "REST_OFFSETS"]

BODY_JOINTS = ("pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
               "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
               "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist")
BODY_PARENTS = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)
# each joint's offset from its parent in the SMPL body frame (Y up, facing +Z, the body's left at +X), metres:
# an approximate mean (neutral) shape; the pelvis row is its rest position above the model's origin
REST_OFFSETS = np.array([
    [-0.002, -0.241, 0.029], [0.059, -0.082, -0.018], [-0.060, -0.091, -0.014], [0.004, 0.124, -0.038],
    [0.044, -0.387, 0.008], [-0.043, -0.383, -0.005], [0.004, 0.138, 0.027], [-0.015, -0.427, -0.037],
    [0.019, -0.420, -0.035], [-0.002, 0.056, 0.003], [0.041, -0.060, 0.122], [-0.035, -0.062, 0.130],
    [-0.013, 0.212, -0.034], [0.072, 0.114, -0.019], [-0.083, 0.113, -0.024], [0.010, 0.089, 0.050],
    [0.123, 0.045, -0.019], [-0.113, 0.047, -0.008], [0.255, -0.016, -0.023], [-0.260, -0.014, -0.031],
    [0.266, 0.013, -0.007], [-0.269, 0.007, -0.006]])
# the SMPL body frame (Y up, forward +Z) in Blender's axes (Z up, forward -Y)
_C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_JOINT_COUNTS = {72: "SMPL", 156: "SMPL-H", 165: "SMPL-X"}


def _array(z, key, path):
    try:
        return np.asarray(z[key])
    except Exception as exc:  # noqa: BLE001 - numpy's archive and header parsers raise many kinds on damaged bytes
        raise ParseError(f"cannot read {key!r} of the SMPL file ({str(exc).splitlines()[0][:80]})", path) from None


_MAX_MEMBERS = 256  # an AMASS file has about 10 arrays


def _headers(fh, path):
    """``{key: (shape, dtype)}`` of the archive's arrays, from the zip directory and each array's .npy header
    (no array read: what loading it would allocate is known first)."""
    import zipfile

    with zipfile.ZipFile(fh) as zf:
        members = [i for i in zf.infolist() if i.filename.endswith(".npy")]
        if len(zf.infolist()) > _MAX_MEMBERS:
            raise ParseError(f"the archive holds {len(zf.infolist())} members, no SMPL file", path)
        out = {}
        for info in members:
            with zf.open(info) as member:
                version = np.lib.format.read_magic(member)
                read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                    np.lib.format.read_array_header_2_0
                shape, _fortran, dtype = read_header(member)
            out[info.filename[:-4]] = (tuple(int(n) for n in shape), np.dtype(dtype))
    fh.seek(0)
    return out


def _check_headers(heads, path):
    """Refuse, before loading, arrays of the wrong kind or shape, more frames than the cap and clips over the
    memory budget (``files.check_budget``)."""
    for key in ("poses", "root_orient", "pose_body", "trans"):
        if key in heads and heads[key][1].kind not in "fiu":
            raise ParseError(f"{key!r} holds {heads[key][1]} values, not numbers", path)
    shape = heads["poses"][0] if "poses" in heads else heads.get("root_orient", ((),))[0]
    if not shape:
        return
    frames = shape[0]
    if frames < 1 or frames > files.max_frames():
        raise ParseError(f"the SMPL file holds {frames} frames (at most {files.max_frames()})", path)
    wanted = sum(int(np.prod(heads[k][0], dtype=np.float64)) * heads[k][1].itemsize
                 for k in ("poses", "root_orient", "pose_body", "trans") if k in heads)
    files.check_budget(wanted + frames * len(BODY_JOINTS) * 72 * 2, path, "its poses and rotations")


def _poses(z, path):
    """(frames, 22, 3) axis-angle of the body joints and the model name."""
    if "poses" in z.files:
        poses = _array(z, "poses", path)
        if poses.ndim != 2 or poses.shape[1] not in _JOINT_COUNTS:
            raise ParseError(f"'poses' has shape {poses.shape}; an SMPL file has 72 (SMPL), 156 (SMPL-H) or 165 "
                             f"(SMPL-X) numbers per frame", path)
        model = _JOINT_COUNTS[poses.shape[1]]
        return poses[:, :66].reshape(len(poses), 22, 3), model
    if "root_orient" in z.files and "pose_body" in z.files:
        root, body = _array(z, "root_orient", path), _array(z, "pose_body", path)
        if root.ndim != 2 or root.shape[1] != 3 or body.shape != (len(root), 63):
            raise ParseError(f"'root_orient' {root.shape} and 'pose_body' {body.shape} are not an SMPL-X body", path)
        return np.concatenate([root, body], axis=1).reshape(len(root), 22, 3), "SMPL-X"
    raise ParseError("not an SMPL/AMASS motion file (no 'poses' or 'root_orient'/'pose_body' array)", path)


def _rate(z, path):
    for key in ("mocap_framerate", "mocap_frame_rate", "fps", "frame_rate"):
        if key in z.files:
            try:
                fps = float(_array(z, key, path))
            except (TypeError, ValueError):
                raise ParseError(f"{key!r} is not a number", path) from None
            if not np.isfinite(fps) or fps <= 0 or fps > 10_000:
                raise ParseError(f"{key!r} is {fps}, not a frame rate", path)
            return fps
    raise ParseError("the SMPL file has no frame rate ('mocap_framerate' or 'mocap_frame_rate')", path)


def _blender_rotations(aa):
    """(F, 22, 3) axis-angle -> (F, 22, 3, 3) rotations in Blender's axes (module docstring), in chunks of frames
    (one float64 array of the result, no full-size temporaries)."""
    out = np.empty(aa.shape[:2] + (3, 3))
    for f0 in range(0, len(aa), _CHUNK):
        R = so3.exp(aa[f0:f0 + _CHUNK])
        X = _C[None, None] @ R @ _C.T[None, None]  # the body frame's rotations in Blender's axes
        X[:, 0] = R[:, 0] @ _C.T  # the root: from the rest (standing in Blender's axes) to the file's world
        out[f0:f0 + _CHUNK] = X
    return out


_CHUNK = 4096


def load_smpl(path) -> Clip:
    """The body motion of an SMPL / SMPL-H / SMPL-X ``.npz`` as a Clip in Blender's axes (module docstring):
    local rotations relative to the mean-shape rest (``rotation_space`` "armature"), the pelvis's path in
    metres. One-line ParseError for anything else (not a zip of arrays, other keys, bad shapes or numbers)."""
    path = str(path)
    try:
        with files.open_regular(path) as fh:
            _check_headers(_headers(fh, path), path)
            with np.load(fh, allow_pickle=False) as z:
                aa, model = _poses(z, path)
                fps = _rate(z, path)
                trans = _array(z, "trans", path) if "trans" in z.files else None
    except ParseError:
        raise
    except Exception as exc:  # noqa: BLE001 - zipfile, zlib, numpy's header tokenizer: any damage is one line
        raise ParseError(f"not an SMPL/AMASS .npz file ({str(exc).splitlines()[0][:80]})", path) from None
    frames = len(aa)
    if frames < 1 or frames > files.max_frames():
        raise ParseError(f"the SMPL file holds {frames} frames (at most {files.max_frames()})", path)
    if not np.all(np.isfinite(aa)):
        raise ParseError("the SMPL poses hold numbers that are not finite", path)
    if trans is not None and (trans.shape != (frames, 3) or not np.all(np.isfinite(trans))):
        raise ParseError(f"'trans' has shape {trans.shape}; expected ({frames}, 3) finite numbers", path)
    X = _blender_rotations(aa)
    heads = np.zeros((22, 3))
    for j, p in enumerate(BODY_PARENTS):
        heads[j] = (heads[p] if p >= 0 else 0.0) + (_C @ REST_OFFSETS[j] if p >= 0 else 0.0)
    tails = heads.copy()
    for j, p in enumerate(BODY_PARENTS):  # each bone to its first child (leaves: along the parent's bone)
        kids = [k for k, q in enumerate(BODY_PARENTS) if q == j]
        tails[j] = heads[kids[0]] if kids else heads[j] + 0.5 * (heads[j] - heads[p])
    root = None if trans is None else trans.astype(np.float64) + REST_OFFSETS[0]
    meta = {"format": "smpl", "model": model, "parents": {b: (BODY_JOINTS[p] if p >= 0 else None)
                                                          for b, p in zip(BODY_JOINTS, BODY_PARENTS)},
            "rotation_space": "armature", "up_axis": "Z", "unit_meters": 1.0,
            **rest_meta(BODY_JOINTS, heads, tails)}
    name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    return Clip(name=name, bones=BODY_JOINTS, rotations=X, fps=fps, frame_start=1, root_translation=root,
                root_bone="pelvis", source=path, meta=meta)
