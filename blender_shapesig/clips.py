"""Load clips from files for the command line and folder libraries (issue 3). Planned API:

  load_clips(spec, asf=None, fps=None) -> list[core.Clip]
      spec: FILE.bvh (Blender's importer), FILE.amc (core.acclaim; skeleton = asf or the only .asf
      beside it), FILE.blend (every armature action), FILE.blend#ACTION
"""
