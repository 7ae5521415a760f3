"""Panels and UI lists (sidebar tab "ShapeSig")."""

import bpy

from . import rigmap, search

# the search panels first: the Bone Map subpanels name them as parents
classes = search.classes + rigmap.classes
register, unregister = bpy.utils.register_classes_factory(classes)
