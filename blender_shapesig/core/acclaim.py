"""CMU Acclaim ASF/AMC parser (no bpy) (issue 3). Planned API:

  parse_asf(path_or_text) -> Skeleton
  parse_amc(path_or_text, skeleton) -> Motion
  load_acclaim(amc_path, asf_path=None) -> core.Clip  (local bone rotations, root translation)
"""
