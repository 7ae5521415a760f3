"""Panels and UI lists (sidebar tab "ShapeSig")."""

import bpy

from . import search

classes = search.classes
register, unregister = bpy.utils.register_classes_factory(classes)
