"""``rank QUERY FOLDER``: a folder stands for its clip files, several skeletons in one folder (HDM05's layout: each
``.amc`` belongs to the ``.asf`` its name starts with), and a folder's file that cannot be keyed is skipped with a
warning, not a failure. Real CMU clips from tests/data renamed into that layout."""

import json
import pathlib
import shutil

import pytest

from blender_shapesig import cli

ACC = pathlib.Path(__file__).resolve().parents[1] / "data" / "acclaim"


@pytest.fixture
def hdm_layout(tmp_path):
    """Two skeletons in one folder: actor 'aa' (the CMU 07 walker) and 'bb' (the 09 runner)."""
    folder = tmp_path / "train"
    folder.mkdir()
    shutil.copy(ACC / "07-walk.asf", folder / "HDM_aa.asf")
    shutil.copy(ACC / "09-run.asf", folder / "HDM_bb.asf")
    for src, dst in (("07_01", "HDM_aa_walk_001"), ("07_02", "HDM_aa_walk_002"), ("09_02", "HDM_bb_run_001"),
                     ("09_03", "HDM_bb_run_002")):
        shutil.copy(ACC / f"{src}.amc", folder / f"{dst}_120.amc")
    return folder


def _rank(capsys, *args):
    code = cli.main(["rank", *args, "--json", "--no-cache", "--no-progress"])
    out = capsys.readouterr()
    return code, out


def test_a_folder_with_several_skeletons_ranks_in_place(hdm_layout, capsys):
    code, out = _rank(capsys, str(hdm_layout / "HDM_aa_walk_001_120.amc"), str(hdm_layout), "--metric", "sim3")
    assert code == 0, out.err
    rows = json.loads(out.out)["results"]
    names = [r["clip"] for r in rows]
    assert len(rows) == 4 and names[0] == "HDM_aa_walk_001_120"  # the query itself is in the folder
    assert names[1] == "HDM_aa_walk_002_120"  # the other walk before the runs


def test_a_folder_file_without_its_skeleton_is_skipped_with_a_warning(hdm_layout, capsys):
    shutil.copy(ACC / "16_15.amc", hdm_layout / "HDM_cc_walk_001_120.amc")  # no HDM_cc.asf
    code, out = _rank(capsys, str(hdm_layout / "HDM_aa_walk_001_120.amc"), str(hdm_layout), "--metric", "sim3")
    assert code == 0, out.err
    data = json.loads(out.out)
    assert len(data["results"]) == 4 and any("HDM_cc_walk_001_120" in s for s in data["skipped"])
    assert out.err.count("warning") == 1
    # named on its own, the same file is an error (exit 2, one line)
    code, out = _rank(capsys, str(hdm_layout / "HDM_aa_walk_001_120.amc"), str(hdm_layout / "HDM_cc_walk_001_120.amc"))
    assert code == 2 and len(out.err.strip().splitlines()) == 1 and ".asf" in out.err
