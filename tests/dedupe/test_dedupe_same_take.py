"""``dedupe`` and the same take in another file (issue 41): its pair distance is ``rank``'s sim^3 (on the joints both
rigs have), the same take in two formats or skeletons is clustered through the search's take test, two takes are
never merged, and the report names the test every near miss failed. On tests/data: six CMU takes each in two files
(AMC and cgspeed Daz BVH, AMC and MotionBuilder BVH, Daz and iClone BVH) and three takes in one file each."""

import os
import pathlib
import shutil

import pytest

from blender_shapesig.core import search as index
from blender_shapesig.core.search import dedupe, make_entry
from blender_shapesig.core.measure_words import MEASURES
from blender_shapesig.core.io import sources
from blender_shapesig.dedupe import dedupe_library

DATA = pathlib.Path(__file__).resolve().parents[1] / "data"
ACC = DATA / "acclaim"
ASF = {"07": "07-walk.asf", "09": "09-run.asf", "16": "16.asf"}
# (file, its take): the six takes in two files, and three in one
FILES = [("acclaim/07_01.amc", "07_01"), ("bvh/07_01.bvh", "07_01"), ("acclaim/07_02.amc", "07_02"),
         ("bvh/07_02.bvh", "07_02"), ("acclaim/09_02.amc", "09_02"), ("bvh/09_02.bvh", "09_02"),
         ("acclaim/09_03.amc", "09_03"), ("bvh/09_03.bvh", "09_03"), ("acclaim/16_15.amc", "16_15"),
         ("acclaim/16_15.bvh", "16_15"), ("cross_rig/02_03.bvh", "02_03"), ("cross_rig/002_03.bvh", "02_03"),
         ("bvh/08_01.bvh", "08_01"), ("bvh/13_32.bvh", "13_32"), ("acclaim/09_05.amc", "09_05")]


def _spec(rel):
    asf = str(ACC / ASF[pathlib.Path(rel).name[:2]]) if rel.endswith(".amc") else None
    return sources.ClipSpec(str(DATA / rel), asf=asf, bone_map="auto")


@pytest.mark.parametrize("a,b", [("acclaim/07_01.amc", "bvh/07_01.bvh"), ("cross_rig/002_03.bvh", "cross_rig/02_03.bvh"),
                                 ("bvh/07_01.bvh", "bvh/09_02.bvh"), ("acclaim/16_15.amc", "bvh/13_32.bvh")])
def test_pair_sim_is_ranks_sim3(a, b):
    ca, cb = sources.read_one(_spec(a)), sources.read_one(_spec(b))
    want = index.rank_clips(ca, [cb], metric="sim3")[0].distance
    assert dedupe.pair_sim(make_entry(ca), make_entry(cb)) == pytest.approx(want, rel=1e-6, abs=1e-7)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    base = tmp_path_factory.mktemp("same_take")
    specs, take_of = [], {}
    for rel, take in FILES:  # each file in its own folder: the readers pair an .amc with the .asf beside it
        folder = base / rel.replace("/", "_").replace(".", "_")
        folder.mkdir()
        shutil.copy(DATA / rel, folder / pathlib.Path(rel).name)
        spec = _spec(rel)
        specs.append(sources.ClipSpec(str(folder / pathlib.Path(rel).name), asf=spec.asf, bone_map="auto"))
        take_of[os.path.abspath(specs[-1].path)] = take
    out = dedupe_library(specs, str(base / "report"), plots=False)
    return out, take_of


def test_the_same_take_in_two_files_is_clustered_and_two_takes_never(report):
    out, take_of = report
    takes = [{take_of[os.path.abspath(m)] for m in c} for c in out["clusters"]]
    assert all(len(t) == 1 for t in takes), out["clusters"]  # no cluster holds two takes
    clustered = {t.pop() for t, c in zip(takes, out["clusters"]) if len(c) == 2}
    assert clustered == {"07_01", "07_02", "09_02", "09_03", "16_15", "02_03"}, out["near_misses"]


def test_every_near_miss_names_the_test_it_failed(report):
    out, _ = report
    assert out["near_misses"]
    for row in out["near_misses"]:
        gates = (MEASURES["sim"].status, MEASURES["relative"].status)  # in the report's words
        assert row["failed"].startswith(tuple(f"copy test: {g} " for g in gates) + ("complete linkage",)), row
        if row["failed"].startswith("copy test"):
            assert "; same-take test: " in row["failed"]
    assert f"{MEASURES['take'].status} <= " in out["rule"]
