"""Blender actions <-> core.Clip (issue 3). Planned API:

  read_action(action, armature=None, bones=None, frame_range=None, include_unkeyed=True) -> core.Clip
      every rotation mode; root translation; clip.meta["still_bones"], clip.meta["fcurve_hash"]
  write_action(clip, armature, name=None, rotation_modes=None) -> bpy.types.Action
      new action, one key per frame per channel, keyframe_points.add + foreach_set
  action_hash(action) -> str   # hash of the action's F-curve data (keys, handles, modes)
  armature_actions(armature=None) -> list of actions that animate pose bones
"""
