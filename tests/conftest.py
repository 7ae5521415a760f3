"""Shared test set-up: the repository root on sys.path and paths to the bundled CMU clips."""

import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="session")
def data_dir():
    return DATA


@pytest.fixture(autouse=True)
def _private_signature_cache(tmp_path_factory, monkeypatch):
    """``rank`` caches signatures per user by default: tests use a fresh folder, never the user's."""
    monkeypatch.setenv("SHAPESIG_CACHE_DIR", str(tmp_path_factory.mktemp("signature_cache")))


def bvh_channel_rotations(path):
    """An independent reading of a BVH file (no package code): (joint names, one (frames, 3, 3) array of each
    joint's rotation R = R_c1 R_c2 R_c3 from its Euler channels in file order (scipy's intrinsic upper-case
    sequence; the identity for a joint without rotation channels), the motion data (frames, channels))."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    tokens = pathlib.Path(path).read_text().split()
    joints, i = [], 0
    while tokens[i] != "MOTION":
        if tokens[i] in ("ROOT", "JOINT"):
            joints.append([tokens[i + 1], []])
            i += 2
        elif tokens[i] == "CHANNELS":
            n = int(tokens[i + 1])
            joints[-1][1] = tokens[i + 2:i + 2 + n]
            i += 2 + n
        else:
            i += 1
    data = np.array([float(x) for x in tokens[i + 6:]]).reshape(-1, sum(len(c) for _, c in joints))
    rotations, col = [], 0
    for _name, chans in joints:
        rot = [k for k, c in enumerate(chans) if c.endswith("rotation")]
        seq = "".join(chans[k][0] for k in rot).upper()
        rotations.append(Rotation.from_euler(seq, data[:, [col + k for k in rot]], degrees=True).as_matrix()
                         if rot else np.broadcast_to(np.eye(3), (len(data), 3, 3)))
        col += len(chans)
    return [name for name, _ in joints], rotations, data


@pytest.fixture(scope="session")
def bvh_channels():
    """``bvh_channel_rotations``: the BVH reference the readers are checked against."""
    return bvh_channel_rotations


# Blender 4.2's bpy module frees Python-defined classes of its space types after the interpreter has finalized and
# crashes at process exit (SIGSEGV in bpy_class_free from ~SpaceType, depending only on the heap's layout: a plain
# `import bpy` plus a dataclass can trigger it); 5.0 and 5.2 do not. Once pytest has reported, such a process
# leaves with the session's own exit status instead of running the C exit handlers.
_SESSION = {}


def pytest_sessionfinish(session, exitstatus):
    _SESSION["status"] = int(exitstatus)


def pytest_unconfigure(config):
    bpy = sys.modules.get("bpy")
    if bpy is not None and tuple(bpy.app.version) < (4, 3, 0) and "status" in _SESSION:
        import os

        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_SESSION["status"])
