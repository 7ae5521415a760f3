"""Armatures of other rigs (Blender layer): the one bone map an armature's actions are read with, detected, edited,
stored on the armature, exported, imported and picked from the maps folder (``rigmap``), and another rig's motion
written onto an armature (``retarget``). Detection, the comparison space and the retargeting maths are
``core.rigs``'; the map editor's operators and panel are ``operators/rigmap.py`` and ``panels/rigmap.py``. This file
imports none of them: import the module you need. See docs/rigs.md.
"""
