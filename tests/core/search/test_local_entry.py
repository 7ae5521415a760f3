"""``local.entry``: the local search's typed entries survive the store's files and its library file field by field
(arrays bit for bit, in their disk types), a refusal stays a refusal with its line, and an older recipe's entry
(no take, no description) reads back without them."""

import numpy as np

from blender_shapesig.core.search import SignatureCache
from blender_shapesig.core.search.local import description, features as local, take
from blender_shapesig.core.search.local.entry import ARRAYS, LocalEntry, Refusal


def _entry(rng, name, with_take=True):
    e = LocalEntry(windows=rng.standard_normal((5, local.DIM)).astype(np.float16),
                   sequence=rng.standard_normal((7, 3 * len(local.POINTS))).astype(np.float16),
                   path=rng.standard_normal(10).astype(np.float32),
                   name=name, frames=40, bones=3, trimmed=(2, 39, 1, 40), joints=("a", "b", "c"), still=("c",),
                   rig_joints=("hips",), first=1 if with_take else None)  # (an older entry has no first frame)
    if with_take:
        e.take, e.seconds = rng.standard_normal(take.DIM).astype(np.float32), np.float32(1.3)
        e.take_mask = (rng.random(len(take.JOINTS)) < 0.5).astype(np.uint8)
        e.describe = rng.standard_normal(len(description.PARTS)).astype(np.float32)
    return e


def _same(a, b):
    for k, dt in ARRAYS.items():
        x, y = getattr(a, k), getattr(b, k)
        assert (x is None) == (y is None), k
        if x is not None:
            assert np.asarray(y).dtype == dt and np.array_equal(np.asarray(x), np.asarray(y)), k
    assert (a.name, a.frames, a.first, a.bones, tuple(a.trimmed), a.joints, a.still, a.rig_joints) == \
        (b.name, b.frames, b.first, b.bones, tuple(b.trimmed), b.joints, b.still, b.rig_joints)
    assert float(a.seconds) == float(b.seconds)


def test_entries_and_refusals_round_trip_through_files_and_the_library_file(tmp_path):
    rng = np.random.default_rng(7)
    got = [_entry(rng, "new"), Refusal("arm", "local search needs the legs"), _entry(rng, "old", with_take=False)]
    store = SignatureCache(tmp_path)
    store.local.put("k", "s", got)
    store.local.save_pack()
    fresh = SignatureCache(tmp_path)  # reads the library file (memory-mapped)
    back = fresh.local.get("k", "s")
    assert fresh.stats["writes"] == 0 and [type(e) for e in back] == [LocalEntry, Refusal, LocalEntry]
    _same(got[0], back[0])
    _same(got[2], back[2])
    assert back[1].refused == "local search needs the legs" and back[1].name == "arm" and not back[0].refused
    assert back[0].rows is not None
    fresh.local.release()  # the arrays are copied out of the map, the entries keep every field
    assert back[0].rows is None and not isinstance(np.asarray(back[0].windows).base, np.memmap)
    _same(got[0], back[0])
    (tmp_path / "blender_shapesig-cache" / "local_pack.bin").unlink()
    _same(got[0], SignatureCache(tmp_path).local.get("k", "s")[0])  # from its own file


def test_nbytes_counts_the_arrays_it_has():
    e = _entry(np.random.default_rng(1), "x")
    assert e.nbytes() == sum(np.asarray(getattr(e, k)).nbytes for k in ARRAYS)
    e.take = e.take_mask = e.describe = None
    assert e.nbytes() == e.windows.nbytes + e.sequence.nbytes + e.path.nbytes and set(e.arrays()) == {
        "windows", "sequence", "path"}
