"""What makes an action that action, for the local search's windows (issue 41; an option, ``local.ACTION_WEIGHT``):
from the local features alone (the key points relative to the pelvis in the body's frame and the pelvis' path in
the turning frame, ``local.features``), per window the pelvis' mean velocity in the body's frame (walking backward
is not walking), the feet's height above the clip's ground (the lower ankle's median height: airborne phases, a
lifted foot; the clip's lowest ankle would move with a crop), the range of the pelvis' height, how far the hands
reach forward and up, the limbs' speeds; and each window's motion energy, so that the still windows around a short
action can be left out (``active_rows``). Leg lengths and seconds, no rig or rate dependence beyond the features'.
Measurements: experiments/local_search/RESULTS.md (issue 41)."""

import numpy as np

__all__ = ["ACTION_PARTS", "GROUND", "TIME", "sequence_channels", "action_channels", "window_action", "window_energy",
           "active_rows"]

ACTION_PARTS = 10  # per window: velocity (3), feet heights (2), pelvis height (1), hands forward and up (2),
# arms' and legs' speeds (2)

GROUND = 50.0  # percentile of the lower ankle's height over the clip taken as its ground (50: the median)
TIME = 0.25  # seconds: velocities enter as the distance travelled in this time (leg lengths, like the pose)

# the key points' rows in ``local.POINTS`` order
_SHOULDER, _WRIST, _ANKLE = (1, 2), (5, 6), (9, 10)
_ARMS, _LEGS = (3, 4, 5, 6), (7, 8, 9, 10)


def action_channels(feat) -> np.ndarray:
    """(T, 10): the pelvis' velocity in the body's frame (3, leg lengths per second), the two ankles' heights above
    the clip's ground (2, the lower ankle's median height), the pelvis' height above it (1), how far the hands reach
    forward of the shoulders and up above them (2, the further hand; forward: a forward walk's direction in
    ``local.features``' frame, -y), and the mean speed of the arms' and of the legs' key points relative to the
    pelvis (2, leg lengths per second)."""
    pose = np.asarray(feat["pose"], float).reshape(len(feat["pose"]), -1, 3)
    motion = np.asarray(feat["motion"], float)
    rate = float(feat["rate"])
    T = len(pose)
    grad = (lambda x: np.gradient(x, axis=0) * rate) if T > 1 else (lambda x: np.zeros_like(x))
    vel = grad(motion[:, :3])
    pz = motion[:, 2]
    ankles = pz[:, None] + pose[:, list(_ANKLE), 2]
    ground = float(np.percentile(ankles.min(axis=1), GROUND)) if T else 0.0
    hands = pose[:, list(_WRIST)] - pose[:, list(_SHOULDER)]
    v = np.linalg.norm(grad(pose), axis=2)
    return np.column_stack([vel, ankles - ground, pz - ground, (-hands[..., 1]).max(axis=1), hands[..., 2].max(axis=1),
                            v[:, list(_ARMS)].mean(axis=1), v[:, list(_LEGS)].mean(axis=1)])


def sequence_channels(feat) -> np.ndarray:
    """(T, 6) for the second stage: the velocity times ``TIME`` (3), the feet's and the pelvis' heights (3)."""
    c = action_channels(feat)
    return np.column_stack([TIME * c[:, :3], c[:, 3:6]])


def window_action(channels, starts, w) -> np.ndarray:
    """(windows, ACTION_PARTS): per window the mean velocity (3), the highest the lower foot gets (airborne) and the
    mean height of the higher foot (2), the range of the pelvis' height (1), the furthest the hands reach forward and
    up (2), the arms' and legs' mean speeds (2); velocities and speeds times ``TIME``."""
    out = np.empty((len(starts), ACTION_PARTS))
    for k, s in enumerate(starts):
        c = channels[s:s + w]
        low, high = c[:, 3:5].min(axis=1), c[:, 3:5].max(axis=1)
        out[k] = [*(TIME * c[:, :3].mean(axis=0)), low.max(), high.mean(), np.ptp(c[:, 5]), c[:, 6].max(),
                  c[:, 7].max(), *(TIME * c[:, 8:10].mean(axis=0))]
    return out


def window_energy(feat, starts, w) -> np.ndarray:
    """(windows,) how much happens in each window: the key points' and the pelvis' path length (leg lengths)."""
    X = np.column_stack([np.asarray(feat["pose"], float), np.asarray(feat["motion"], float)[:, :3]])
    step = np.concatenate([[0.0], np.linalg.norm(np.diff(X, axis=0), axis=1)]) if len(X) > 1 else np.zeros(len(X))
    c = np.concatenate([[0.0], np.cumsum(step)])
    e = np.minimum(starts + w, len(X))
    return c[e] - c[np.minimum(starts + 1, e)]


def active_rows(energy, share) -> np.ndarray:
    """Boolean mask of the windows whose energy is at least ``share`` of the clip's largest (at least one)."""
    energy = np.asarray(energy, float)
    if not len(energy) or share <= 0:
        return np.ones(len(energy), bool)
    return energy >= share * energy.max() - 1e-12

