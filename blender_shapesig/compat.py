"""Every difference between Blender versions (4.2 LTS .. 5.0) lives here (issue 3).

Feature-detect on instances (e.g. ``hasattr(action, "layers")``), never on version numbers alone.
Planned API (used by action_io and the operators):
  action_fcurves(action, slot=None) -> iterable of FCurves (4.2: action.fcurves; 4.4+: channelbag)
  ensure_channelbag(action, id_type="OBJECT") -> object with .fcurves.new/.groups.new (creates slot/layer/strip)
  assign_action(obj, action)   # sets animation_data.action and, on 4.4+, the slot
"""
