"""Blender tests: run on the real bpy module (our stand-in for ``blender --background``), or inside a
Blender binary through tests/run_in_blender.py.

Each test starts from an empty factory-settings file with the add-on registered.
"""

import pytest

bpy = pytest.importorskip("bpy", reason="the Blender tests need the bpy module or a Blender binary")


@pytest.fixture(scope="session")
def addon():
    import blender_shapesig

    blender_shapesig.register()
    yield blender_shapesig
    blender_shapesig.unregister()


@pytest.fixture
def empty_file(addon):
    """An empty scene (factory settings, no objects) with the add-on registered."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield bpy.context
