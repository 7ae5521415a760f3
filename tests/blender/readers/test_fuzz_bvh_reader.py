"""The BVH fuzz compares like with like (``tools/fuzz_readers.py``, target ``bvh``): a mutant is read by the same
reader with the same options as its original (``differential_case`` with ``read_bvh_raw``, Blender's importer
through ``readers.bvh.import_bvh``), so meaning-preserving mutations (CRLF, CR, tabs, BOM, UTF-16, a latin-1
comment) must give the original's rotations exactly.

A seeded, bounded run (the CI budget of the long fuzz) over 12-frame cuts of the three BVH seed files must give
no failure; the same run with the BVH reader broken so that it mis-reads such layouts (a frame lost in the UTF-8
copy of a BOM / UTF-16 file; X and Z rotation channels swapped in files with CR line ends, as a tokenizer bug
would) must report failures for exactly those preserving mutations. (A reader that mis-reads every file alike,
originals included, is beyond a differential check: the seed files all hold tabs, so a swap on tabs would be.)"""

import contextlib
import importlib.util
import os
import pathlib
import random

import pytest

bpy = pytest.importorskip("bpy")

from blender_shapesig.readers import bvh as bvh_reader  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[3]
DATA = ROOT / "tests" / "data"

_spec = importlib.util.spec_from_file_location("fuzz_readers", ROOT / "tools" / "fuzz_readers.py")
fz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fz)

SEED = 4711
CASES = 150  # every mutation kind 6 times: 42 preserving cases


def _short(path, frames=12):
    lines = path.read_text().split("\n")
    m = lines.index("MOTION")
    return ("\n".join(lines[:m + 1] + [f"Frames: {frames}", lines[m + 2]] + lines[m + 3:m + 3 + frames]) + "\n").encode()


@pytest.fixture
def seeds(tmp_path, empty_file):
    out = []
    for rel in fz.BVH_FILES:
        p = tmp_path / ("seed_" + os.path.basename(rel))
        p.write_bytes(_short(DATA / rel))
        out.append(str(p))
    return out


def _bounded_run(seeds, folder, cases=CASES, seed=SEED, kinds=fz.KINDS):
    """(kind, outcome, detail) of ``cases`` seeded cases, every kind in turn, read like with like."""
    rng = random.Random(seed)
    memo, out = {}, []
    for i in range(cases):
        kind = kinds[i % len(kinds)]
        src = rng.choice(seeds)
        path = os.path.join(folder, f"{i}.bvh")
        with open(path, "wb") as f:
            f.write(fz.mutate(pathlib.Path(src).read_bytes(), kind, rng, "bvh"))
        outcome, detail = fz.differential_case(fz.read_bvh_raw, src, path, kind, timeout=60, memo=memo)
        out.append((kind, outcome, detail))
    return out


def test_bounded_bvh_fuzz_has_no_failure(seeds, tmp_path):
    rows = _bounded_run(seeds, str(tmp_path))
    fails = [r for r in rows if r[1] == "FAIL"]
    assert not fails, fails[:5]
    preserving = [r for r in rows if r[0] in fz.PRESERVING]
    assert len(preserving) == 42 and all(r[1] == "ok" for r in preserving)
    assert {r[1] for r in rows} == {"ok", "error"}  # the run reaches both valid clips and our errors


def _lossy_text(real):
    """``bvh_text`` that loses the last frame when it re-encodes a file (BOM, UTF-16, latin-1)."""

    def bvh_text(path):
        text, plain = real(path)
        if plain:
            return text, plain
        lines = text.replace("\r\n", "\n").rstrip("\n").split("\n")
        i = next(k for k, ln in enumerate(lines) if ln.startswith("Frames:"))
        lines[i] = f"Frames: {int(lines[i].split()[1]) - 1}"
        return "\n".join(lines[:-1]) + "\n", False

    return bvh_text


def _swapping_copy(real):
    """``_utf8`` that hands the importer X and Z rotation channels swapped when the file has CR line ends."""

    @contextlib.contextmanager
    def utf8(path):
        data = pathlib.Path(path).read_bytes()
        if b"\r" not in data:
            with real(path) as readable:
                yield readable
            return
        swapped = data.replace(b"Xrotation", b"\0").replace(b"Zrotation", b"Xrotation").replace(b"\0", b"Zrotation")
        copy = pathlib.Path(path).with_name("swapped_" + pathlib.Path(path).name)
        copy.write_bytes(swapped)
        try:
            yield str(copy)
        finally:
            copy.unlink()

    return utf8


@pytest.mark.parametrize("broken, misread", [
    ("bvh_text", {"bom", "utf16", "utf16_be"}),
    ("_utf8", {"crlf", "cr"}),
])
def test_bounded_fuzz_fails_on_a_reader_that_misreads_layouts(seeds, tmp_path, monkeypatch, broken, misread):
    patch = {"bvh_text": _lossy_text, "_utf8": _swapping_copy}[broken]
    monkeypatch.setattr(bvh_reader, broken, patch(getattr(bvh_reader, broken)))
    rows = _bounded_run(seeds, str(tmp_path), cases=3 * len(fz.KINDS))  # every kind 3 times, the same seed
    failed = {kind for kind, outcome, _ in rows if outcome == "FAIL"}
    assert failed == misread, [r for r in rows if r[1] == "FAIL"][:3]
    for kind, outcome, detail in rows:
        if kind in misread:
            assert outcome == "FAIL" and "changed the result" in detail, (kind, detail)
