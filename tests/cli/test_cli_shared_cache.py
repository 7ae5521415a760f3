"""The command line and the panel share signature-cache entries: a folder library indexed the way the panel's
folder libraries are (``core.io.sources.library`` + ``core.search.build_index``) is a cache hit for ``rank`` on the
same files, because both key a file by ``ClipSpec.key`` (its bytes, skeleton, action and crop). .amc only: no bpy."""

import json
import pathlib
import shutil

from blender_shapesig import cli
from blender_shapesig.core import search as search
from blender_shapesig.core.io import sources

ACC = pathlib.Path(__file__).resolve().parents[1] / "data" / "acclaim"


def _rank(capsys, args):
    assert cli.main(args + ["--json", "--no-progress"]) == 0
    return json.loads(capsys.readouterr().out)


def test_panel_built_entries_are_cli_cache_hits(capsys, tmp_path):
    folder = tmp_path / "library"
    folder.mkdir()
    for name in ("09-run.asf", "09_02.amc", "09_03.amc"):  # one skeleton: found beside the takes
        shutil.copy2(ACC / name, folder / name)
    cache_dir = tmp_path / "cache"

    # what the panel's folder library does
    items = sources.library([folder], start=2)
    built = search.build_index(items, cache=search.SignatureCache(str(cache_dir)))
    # each take: its signature entry and its local-search entry (one read)
    assert built["clips"] == 2 and not built["errors"] and built["stats"]["misses"] == 4

    takes = [str(folder / "09_02.amc"), str(folder / "09_03.amc")]
    out = _rank(capsys, ["rank", takes[0], *takes, "--cache", str(cache_dir), "--start", "2"])
    assert out["cache"]["misses"] == 0 and out["cache"]["hits"] > 0, out["cache"]
    assert [r["clip"] for r in out["results"]][0] == "09_02"

    # another crop is another key: the CLI computes it (the keys are not equal by accident)
    other = _rank(capsys, ["rank", takes[0], *takes, "--cache", str(cache_dir), "--start", "3"])
    assert other["cache"]["misses"] > 0, other["cache"]
