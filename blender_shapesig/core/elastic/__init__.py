"""The elastic shape distance d_S* (thesis sec. 4.3): the dynamic programme over reparametrizations and what is
built on it. ``elastic``: ``elastic_align``/``elastic_distance``; ``warps``: warps checked, curves reparametrized;
``_dp_kernels`` / ``_dp_numpy``: the DP in numba and numpy (one floating-point contract); ``_srvt_kernel``: the
compiled SRVT of the DP's matrices; ``_workspace``: the per-thread arrays one call reuses; ``subsequence``: the
free-window DP of moments; ``explain``: why two clips differ (per-joint shares, cost over time). See
docs/elastic.md."""

# the DP search depth D used when none is given (every caller, the command line and the panel)
DEFAULT_DEPTH = 9
