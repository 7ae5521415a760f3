"""Actions in Blender and the motion they hold (Blender layer): an action read as a ``Clip`` and a clip written as a
new action (``action_io``, in the spaces of ``action_spaces``, channels parsed by ``bone_channels``), its content
hashes and session fingerprints (``action_hashes``, ``action_changes``), the armature it belongs to (``owners``), its
frame rate, known or visibly assumed (``frame_rates``), an armature's motion as the scene shows it and motion written
back so (``scene_motion``; Rigify-like control rigs through ``control_rigs``) and the command line's .blend writer
(``write_blend_file``). Version differences go through ``compat``. This file imports none of them: import the module
you need. See docs/action_io.md.
"""
