"""The clip: ``clip`` (``Clip``, the one currency between readers, maths and writers), ``skeleton`` (rest
skeletons in clip meta, forward kinematics, the up vector), ``trim`` (rest-pose / ramp trimming) and ``prepare``
(the comparison time base: one rate in seconds, low-pass, decimation)."""
