"""The scene of the operator-safety tests (``test_operators_lose_nothing``, ``test_result_targets``,
``test_operator_errors``): the fixtures ``cache_env`` (a fresh index folder, the panel's caches cleared) and ``rig``
(the walk 07_01 playing 'walk', the actions 'walk2', 'run', 'jump' with fake users), and ``operator_error`` (the
one-line error of a refused operator call)."""

import bpy
import pytest

from blender_shapesig.search import library
from blender_shapesig.core import search as index
from tests.helpers.blender_clips import import_bvh


@pytest.fixture
def cache_env(monkeypatch, tmp_path):
    monkeypatch.setenv(index.CACHE_ENV, str(tmp_path / "index"))
    library.CACHES.clear()
    return tmp_path / "index"


@pytest.fixture
def rig(empty_file, cache_env):
    """The walk 07_01's armature, active, playing 'walk' (its only user: no fake user), and the actions 'walk2',
    'run', 'jump' (fake users; their armatures deleted)."""
    arm = import_bvh("07_01.bvh", "walk")
    for f, name in (("07_02.bvh", "walk2"), ("09_02.bvh", "run"), ("13_32.bvh", "jump")):
        other = import_bvh(f, name)
        bpy.data.actions[name].use_fake_user = True
        bpy.data.objects.remove(other)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    bpy.context.scene.shapesig.crop_start = 2
    return arm


def operator_error(op, **kw):
    """The one-line error of a refused operator call."""
    with pytest.raises(RuntimeError) as info:
        op("EXEC_DEFAULT", **kw)
    msg = str(info.value).strip()
    assert "\n" not in msg and "Traceback" not in msg, msg
    return msg
