"""A clip library folder with hostile entries beside real takes, for the tests of which files are opened."""

import os
import pathlib
import shutil

BVH = pathlib.Path(__file__).resolve().parent / "data" / "bvh"
HOSTILE = ("x.bvh", "z.bvh", "d.bvh", "l.bvh")


def hostile_library(folder, real):
    """``folder`` (made) with the CMU takes ``real`` (names in tests/data/bvh), a FIFO x.bvh, a link to /dev/zero
    z.bvh, a dangling link d.bvh and a link to itself l.bvh; returns the folder."""
    folder = pathlib.Path(folder)
    folder.mkdir()
    for name in real:
        shutil.copy(BVH / f"{name}.bvh", folder / f"{name}.bvh")
    os.mkfifo(folder / "x.bvh")
    os.symlink("/dev/zero", folder / "z.bvh")
    os.symlink(folder / "nowhere.bvh", folder / "d.bvh")
    os.symlink("l.bvh", folder / "l.bvh")
    return folder
