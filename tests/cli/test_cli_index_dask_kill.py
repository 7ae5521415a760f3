"""``index --scheduler`` when a Dask worker dies mid-run (a real ``LocalCluster`` of two worker processes; the worker
kills its own process with ``os._exit`` in the middle of a task, once the first batch is stored): what the client stored
is kept; with Dask's retries the run finishes on the workers left, and without them it stops with one line; a rerun
computes only the rest (the ``index`` JSON's "computed")."""

import json
import os
import re

import distributed
import pytest

from blender_shapesig import cli
from blender_shapesig.core import search as index
from blender_shapesig.core.search.local import features as ls
from blender_shapesig.core.io import sources


ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLIPS = 300  # batches of 64 (the last 44): the victim dies with most of the library still to do


@pytest.fixture
def library(data_dir, tmp_path):
    """CLIPS distinct BVH files: the test clips, each copy re-timed (its own Frame Time, so its own content)."""
    bases = [p.read_bytes() for p in sorted((data_dir / "bvh").glob("*.bvh"))]
    d = tmp_path / "lib"
    d.mkdir()
    for i in range(CLIPS):
        text = bases[i % len(bases)]
        m = re.search(rb"Frame Time:\s*([0-9.eE+-]+)", text)
        dt = float(m.group(1)) * (1.0 + 0.001 * (i + 1))
        (d / f"c{i:03d}.bvh").write_bytes(text[:m.start(1)] + f"{dt:.9f}".encode() + text[m.end(1):])
    return d


def _stored(folder, cache):
    store, skey = index.SignatureCache(cache), ls.settings_key()
    items = [sources.spec_item(sources.ClipSpec(str(folder / f))) for f in sorted(os.listdir(folder))]
    return sum(store.local.contains(it.key, skey) for it in items)


def _warm_up():
    from blender_shapesig.core.search.local import rank as local_rank  # noqa: F401 - what a task imports first


def _poison(folder):
    """Run on one worker (``client.run``): its process exits in the middle of its first clip after the client
    stored the first batch (64 entry files in ``folder``)."""

    def poison():
        from blender_shapesig.core.search.local import rank as local_rank

        real = local_rank.item_local_entries

        def dying(*args, **kwargs):
            if os.path.isdir(folder) and sum(f.endswith(".npz") for f in os.listdir(folder)) >= 64:
                os._exit(1)
            return real(*args, **kwargs)

        local_rank.item_local_entries = dying

    return poison


def _index(folder, cache, address, capsys):
    code = cli.main(["index", str(folder), "--cache", str(cache), "--scheduler", address, "--json", "--no-progress"])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if code == 0 else None), err


def _cluster(retries):
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": retries}):
        return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)


@pytest.mark.parametrize("retries", [3, 0], ids=["dask-retries", "no-retries"])
def test_a_worker_killed_mid_run_loses_nothing_and_the_rerun_finishes_the_rest(library, tmp_path, capsys,
                                                                               monkeypatch, retries):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([ROOT] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    cache = tmp_path / "cache"
    with _cluster(retries) as cluster, distributed.Client(cluster) as client:
        victim = sorted(client.scheduler_info()["workers"])[0]
        client.run(_warm_up)  # both workers start the run ready (else one may still be importing at batch 2)
        client.run(_poison(str(cache / index.CACHE_SUBDIR)), workers=[victim])
        code, out, err = _index(library, cache, cluster.scheduler_address, capsys)
        assert victim not in client.scheduler_info()["workers"]  # it did die (its nanny may have started another)
    stored = _stored(library, cache)
    if retries:  # the dead worker's task ran again elsewhere: the run finished and stored every clip once
        assert code == 0, err
        assert out["computed"] == CLIPS and out["clips"] == CLIPS and stored == CLIPS
    else:  # the task that was on the dead worker failed: one line, the finished batches kept
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err and "run again" in err and "died" in err, err
        assert 64 <= stored < CLIPS
    # a rerun on a healthy cluster computes only what was not stored, and the library is whole
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        code, out, err = _index(library, cache, c.scheduler_address, capsys)
    assert code == 0, err
    assert out["computed"] == CLIPS - stored and out["clips"] == CLIPS
    assert _stored(library, cache) == CLIPS
