"""Saved bone-map JSON files that are not bone maps: not UTF-8, nested 200,000 deep, not an object,
larger than the 1 MB cap. Each is one ParseError naming the file from ``core.rigs.load_map``, and one line on
stderr with exit 2 from the command line's ``--bone-map FILE.json`` (no Python exception names); a good map
still works beside them."""

import os

import pytest

from blender_shapesig import cli
from blender_shapesig.core import rigs
from blender_shapesig.core.errors import ParseError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
ACC = os.path.join(ROOT, "tests", "data", "acclaim")

BAD_MAPS = {
    "latin1.json": ('{"lfemur": "thigh.L", "t\xeate": "head"}'.encode("latin-1"), "not UTF-8 text"),
    "deep.json": (b"[" * 200_000, "nested too deeply"),
    "deep_object.json": (b'{"a":' * 200_000, "nested too deeply"),  # 1,000,000 bytes: under the cap
    "list.json": (b'["lfemur", "thigh.L"]', "must be a JSON object"),
    "number.json": (b"42", "must be a JSON object"),
    "huge.json": (b'{"lfemur": "thigh.L", "#pad": "' + b"x" * (rigs.MAX_MAP_BYTES + 10) + b'"}', "larger than 1 MB"),
    "long_number.json": (b'{"a": ' + b"9" * 5000 + b"}", "not valid JSON"),
}


@pytest.fixture(scope="module")
def bad_maps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("maps")
    for name, (data, _) in BAD_MAPS.items():
        (folder / name).write_bytes(data)
    return folder


@pytest.mark.parametrize("name", sorted(BAD_MAPS))
def test_load_map_gives_one_line_naming_the_file(bad_maps, name):
    with pytest.raises(ParseError) as info:
        rigs.load_map(bad_maps / name)
    msg = str(info.value)
    assert msg.startswith(str(bad_maps / name) + ": ") and BAD_MAPS[name][1] in msg, msg
    assert "\n" not in msg and len(msg) < 400


def test_parse_map_of_text_and_bytes():
    good = {"lfemur": "thigh.L", "root": "hips"}
    text = '{"#rig": "cmu", "lfemur": "thigh.L", "root": "hips"}'
    assert rigs.parse_map(text) == good == rigs.parse_map(b"\xef\xbb\xbf" + text.encode())  # a BOM is fine
    with pytest.raises(ParseError, match=r"^stored map: the bone map is nested too deeply"):
        rigs.parse_map("[" * 200_000, "stored map")


@pytest.mark.parametrize("name", sorted(BAD_MAPS))
def test_cli_bone_map_file_is_one_line_exit_2(bad_maps, name, capsys):
    args = ["distance", os.path.join(ACC, "07_01.amc"), os.path.join(ACC, "07_02.amc"),
            "--asf", os.path.join(ACC, "07-walk.asf"), "--bone-map", str(bad_maps / name)]
    assert cli.main(args) == 2
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert out == "" and len(lines) == 1, err
    assert lines[0].startswith(f"blender_shapesig: error: {bad_maps / name}: ") and BAD_MAPS[name][1] in lines[0]
    assert "Error:" not in lines[0] and "Traceback" not in err


def test_cli_good_map_beside_the_bad_ones_still_works(bad_maps, tmp_path, capsys):
    import json

    path = rigs.save_map(tmp_path / "cmu.json", {"lfemur": "thigh.L", "rfemur": "thigh.R", "root": "hips"})
    args = ["distance", os.path.join(ACC, "07_01.amc"), os.path.join(ACC, "07_02.amc"),
            "--asf", os.path.join(ACC, "07-walk.asf"), "--bone-map", path, "--json", "--allow-partial"]
    assert cli.main(args) == 0
    assert json.loads(capsys.readouterr().out)["distance"] > 0


@pytest.mark.parametrize("kind", ["fifo", "dangling link", "link to /dev/zero"])
def test_a_map_that_is_not_a_regular_file_is_refused_without_blocking(tmp_path, kind):
    """A FIFO named .json (which would block a plain open), a dangling link or a device: one line, at once (run in a
    child with a time limit, so a regression fails instead of hanging the suite)."""
    import subprocess
    import sys

    path = tmp_path / "map.json"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dangling link":
        os.symlink(tmp_path / "missing.json", path)
    else:
        os.symlink("/dev/zero", path)
    code = ("import sys\nfrom blender_shapesig.core import rigs\nfrom blender_shapesig.core.errors import ParseError\n"
            "try:\n    rigs.load_map(sys.argv[1])\nexcept ParseError as exc:\n    print(exc)\n")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=60,
                         cwd=root)
    lines = out.stdout.strip().splitlines()
    assert out.returncode == 0 and len(lines) == 1 and "map.json" in lines[0], (out.stdout, out.stderr)
