"""Blends and transitions on armatures (Blender layer), the Blender half of ``core.blend``: ``blend_actions`` reads
two or more actions, blends them and writes each blend as a new action (or an NLA strip with an editable clock);
``transitions`` finds the best cuts between two actions and writes one new joined action. Sources are never
modified; on any error nothing is created. The operators are ``operators/blend.py`` and ``operators/transition.py``.
This file imports none of them: import the module you need. See docs/blending.md and docs/transitions.md.
"""
