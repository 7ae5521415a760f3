"""Move the root: the blended root translation of a blend (height blended, horizontal displacements in each
source's heading frame) about the up axis of its clips (``skeleton.root_up``)."""

import numpy as np

from ..geometry import so3

__all__ = ["blend_root_path", "interp_rows"]

def blend_root_path(plan, ps, rots, rotb, up, W):
    """Blended root translation on the grid.

    ps: the sources' translations (N_i, 3); rots: their roots' rotations on the grid (G, 3, 3) (R_i o phi_i);
    rotb: the blended root rotation on the grid; W: one weight per source. The height (component along ``up``)
    is blended directly; horizontal per-interval displacements are expressed in each root's heading frame,
    blended with the weights, turned back with the blended root's heading and integrated from the blended
    start position.
    """
    gs = [interp_rows(phi, t, p) for phi, t, p in zip(plan.phis, plan.times, ps)]
    local = start = height = None
    for w, g, rot in zip(W, gs, rots):
        d = np.diff(g, axis=0)
        d -= np.outer(d @ up, up)
        term = w * so3.turn(d, up, -so3.heading(rot[:-1], up))
        local = term if local is None else local + term
        start = w * g[0] if start is None else start + w * g[0]
        height = w * (g @ up) if height is None else height + w * (g @ up)
    steps = so3.turn(local, up, so3.heading(rotb[:-1], up))
    start_h = start - (start @ up) * up
    path = np.empty_like(gs[0])
    path[0] = start_h
    np.cumsum(steps, axis=0, out=path[1:])
    path[1:] += start_h
    return path + np.outer(height, up)


def interp_rows(x_new, x, values):
    return np.stack([np.interp(x_new, x, values[:, i]) for i in range(values.shape[1])], axis=1)
