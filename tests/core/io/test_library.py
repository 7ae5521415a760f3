"""``sources.Library``: a library as a person names it, keyed one member at a time, with what it left out and why
(the command line's rank and index, dedupe and ``sources.library`` share it)."""

import os
import pathlib
import shutil

import pytest

from blender_shapesig.core.errors import ShapeSigError, UnreadableFileError
from blender_shapesig.core.io.sources import ClipSpec, Library, library

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


@pytest.fixture
def folder(tmp_path):
    """Two BVH files, an .amc whose skeleton is not there and a FIFO (never opened)."""
    for name in ("07_01.bvh", "09_02.bvh"):
        shutil.copy(DATA / "bvh" / name, tmp_path / name)
    shutil.copy(DATA / "acclaim" / "07_01.amc", tmp_path / "lonely.amc")
    os.mkfifo(tmp_path / "pipe.bvh")
    return tmp_path


def test_a_folder_gives_its_clips_and_says_what_it_left_out(folder):
    lib = Library([str(folder)])
    assert [it.name for it in lib.items()] == ["07_01", "09_02"]
    assert len(lib.skipped) == 2 and sum(isinstance(e, UnreadableFileError) for e in lib.skipped) == 1  # the FIFO
    lines = lib.skipped_lines()
    assert any("lonely.amc" in line for line in lines) and any("pipe.bvh" in line for line in lines)


def test_members_are_keyed_one_at_a_time(folder):
    asked = []

    def spec(text):
        asked.append(os.path.basename(text))
        return ClipSpec.parse(text)

    members = Library([str(folder)], spec).members()
    assert next(members).name == "07_01" and asked == ["07_01.bvh"]
    assert next(members).name == "09_02" and asked == ["07_01.bvh", "09_02.bvh"]


def test_a_named_source_that_cannot_be_keyed_raises_only_when_strict(folder):
    amc = str(folder / "lonely.amc")
    with pytest.raises(ShapeSigError):
        Library([amc]).items()
    lib = Library([amc], strict=False)
    assert lib.items() == [] and len(lib.skipped) == 1 and "lonely.amc" in lib.skipped_lines()[0]


def test_a_named_source_that_does_not_exist_always_raises(folder):
    for strict in (True, False):
        with pytest.raises(ShapeSigError, match="not found"):
            Library([str(folder / "nope.bvh")], strict=strict).items()


def test_files_the_readers_never_open_are_skipped_even_when_named(folder):
    lib = Library([str(folder / "pipe.bvh"), str(folder / "07_01.bvh")])
    assert [it.name for it in lib.items()] == ["07_01"]
    assert len(lib.skipped) == 1 and isinstance(lib.skipped[0], UnreadableFileError)


def test_unique_leaves_a_source_met_again_out(folder):
    named = str(folder / "07_01.bvh")
    assert [it.name for it in Library([named, str(folder), named], strict=False).items()] == \
        ["07_01", "07_01", "09_02", "07_01"]
    assert [it.name for it in Library([named, str(folder), named], strict=False, unique=True).items()] == \
        ["07_01", "09_02"]
    assert [it.name for it in library([named, str(folder)])] == ["07_01", "09_02"]


def test_holes_give_one_step_per_member_found(folder):
    """A progress bar's library (the panel's folders): ``len`` counts the members found (the FIFO is left out at
    discovery, unopened), ``members(holes=True)`` yields one step each, None for the .amc that cannot be keyed."""
    lib = Library([str(folder)], strict=False)
    assert len(lib) == 3
    got = list(lib.members(holes=True))
    assert [None if it is None else it.name for it in got] == ["07_01", "09_02", None]
    assert [it.name for it in Library([str(folder)]).members()] == ["07_01", "09_02"]
