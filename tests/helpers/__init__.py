"""Helpers shared by several test modules (imported as ``tests.helpers.x``; a helper used by one test module stays
in that module): scenes and clips built from tests/data, hostile and planted files, skeletons written as BVH text,
a PNG reader, and stand-ins for Blender's UI objects."""
