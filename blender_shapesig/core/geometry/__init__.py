"""Rotations and curves in SO(3)^d: ``so3`` (log/exp, increments, Euler and quaternion conversions, the
rotation a->b, headings about an up axis) and ``curves`` (the SRVT, d_P*, geodesic interpolation)."""
