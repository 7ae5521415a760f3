"""Blender tests: run on the real bpy module (our stand-in for ``blender --background``), or inside a
Blender binary through tests/run_in_blender.py.

Each test starts from an empty factory-settings file with the add-on registered.
"""

import gc

import pytest

bpy = pytest.importorskip("bpy", reason="the Blender tests need the bpy module or a Blender binary")


@pytest.fixture(autouse=True)
def _garbage_collected_while_its_data_exists():
    """After each test, Python's cyclic garbage (an exporter's or importer's object graph holding wrappers of
    Blender data) is freed while that data still exists: the next test's file reset frees the data, and a wrapper
    collected after it is the likeliest cause of Blender 4.2's crashes in later tests, in any code (one struck
    during garbage collection right after a glTF export)."""
    yield
    gc.collect()


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


@pytest.fixture
def line_armature(addon):
    """A function making an armature with one upright bone per name, 1 unit apart along X, linked to the scene,
    active and in object mode."""

    def make(bone_names, name="Skel"):
        data = bpy.data.armatures.new(name)
        obj = bpy.data.objects.new(name, data)
        bpy.context.collection.objects.link(obj)
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.mode_set(mode="EDIT")
        for i, b in enumerate(bone_names):
            eb = data.edit_bones.new(b)
            eb.head, eb.tail = (i, 0, 0), (i, 0, 1)
        bpy.ops.object.mode_set(mode="OBJECT")
        return obj

    return make
