"""The command line on bad and degenerate input: every failure is exit code 2 with one line on
stderr and nothing on stdout, nothing half-written (no --out file, no matrix), and degenerate but valid clips
(two frames, constant, no rotation channels, 10,000 frames) give finite numbers.

Clips are Acclaim files made from the 09_02 run (pure Python: no bpy) except the subprocess tests at the end
(BVH / .blend through Blender, fuzzed files)."""

import json
import math
import pathlib
import random
import re
import subprocess
import sys

import pytest

from blender_shapesig import cli

ROOT = pathlib.Path(__file__).resolve().parents[2]
ACC = ROOT / "tests" / "data" / "acclaim"
ASF = (ACC / "09-run.asf").read_bytes()
AMC = (ACC / "09_02.amc").read_bytes()


def _frames(amc):
    """(header lines, [frame blocks]) of an AMC file; a block is its lines without the frame number."""
    lines = amc.split(b"\n")
    header, blocks = [], []
    for ln in lines:
        if ln.strip().isdigit():
            blocks.append([])
        elif blocks:
            if ln.strip():
                blocks[-1].append(ln)
        else:
            header.append(ln)
    return header, blocks


def _amc(blocks, header=None):
    header = header if header is not None else _frames(AMC)[0]
    out = list(header)
    for i, b in enumerate(blocks, 1):
        out.append(str(i).encode())
        out.extend(b)
    return b"\n".join(out) + b"\n"


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    """Degenerate AMC takes beside the 09-run skeleton, and one with a skeleton sharing no bones."""
    base = tmp_path_factory.mktemp("robust")
    (base / "09-run.asf").write_bytes(ASF)
    header, blocks = _frames(AMC)
    files = {
        "run": blocks[:60],
        "one": blocks[:1],
        "two": blocks[:2],
        "constant": [blocks[5]] * 40,
        "long": [blocks[k % len(blocks)] for k in range(10000)],
    }
    out = {}
    for name, b in files.items():
        (base / f"{name}.amc").write_bytes(_amc(b, header))
        out[name] = str(base / f"{name}.amc")
    # a skeleton whose bones are all renamed: shares no bones (not even 'root' moves the same way)
    other = base / "other"
    other.mkdir()
    names = sorted({ln.split()[0] for ln in blocks[0]} - {b"root"})
    asf, amc = ASF, _amc(blocks[:30], header)
    for n in names:
        asf = re.sub(rb"\b" + n + rb"\b", b"x_" + n, asf)
        amc = re.sub(rb"\b" + n + rb"\b", b"x_" + n, amc)
    asf = re.sub(rb"\broot\b", b"root", asf)
    (other / "sk.asf").write_bytes(asf)
    (other / "renamed.amc").write_bytes(amc)
    out["renamed"] = str(other / "renamed.amc")
    # no rotation channels: a skeleton with no dof anywhere and a root that only translates
    norot = base / "norot"
    norot.mkdir()
    asf_nr = re.sub(rb"\n\s*dof[^\n]*", b"", ASF)
    asf_nr = re.sub(rb"\n\s*limits[^\n]*(\n\s*\([^\n]*)*", b"", asf_nr)
    asf_nr = re.sub(rb"order TX TY TZ RX RY RZ", b"order TX TY TZ", asf_nr)
    (norot / "sk.asf").write_bytes(asf_nr)
    rows = [[ln for ln in b if ln.split()[0] == b"root"] for b in blocks[:20]]
    rows = [[b" ".join(r[0].split()[:4])] for r in rows]
    (norot / "still.amc").write_bytes(_amc(rows, header))
    out["norot"] = str(norot / "still.amc")
    out["base"] = base
    return out


def error_line(capsys, args):
    """Run the CLI in process; it must fail with exit 2, one stderr line and nothing on stdout."""
    code = cli.main(args + ["--no-progress"])
    out, err = capsys.readouterr()
    assert code == 2, (code, err)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("blender_shapesig: error: "), err
    assert "Traceback" not in err
    return lines[0]


def ok_json(capsys, args):
    code = cli.main(args + ["--json", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


# --------------------------------------------------------------------------------------- degenerate clips


@pytest.mark.parametrize("metric", ["l2", "elastic"])
def test_one_frame_clip_needs_two_for_l2_and_elastic(capsys, clips, metric):
    line = error_line(capsys, ["distance", clips["one"], clips["run"], "--metric", metric])
    assert "clip 'one' has 1 frame" in line and "two frames" in line


@pytest.mark.parametrize("metric", ["sim", "group", "concat", "linear", "l2", "elastic"])
@pytest.mark.parametrize("clip", ["two", "constant", "norot_vs_self"])
def test_degenerate_but_valid_clips_give_finite_distances(capsys, clips, metric, clip):
    if clip == "norot_vs_self":
        a = b = clips["norot"]
    else:
        a, b = clips[clip], clips["run"]
    d = ok_json(capsys, ["distance", a, b, "--metric", metric])["distance"]
    assert d is not None and math.isfinite(d)
    if clip == "norot_vs_self":
        assert d == 0.0
    elif clip == "constant":
        assert d > 0


def test_one_frame_signature_distance_is_a_number(capsys, clips):
    d = ok_json(capsys, ["distance", clips["one"], clips["run"], "--metric", "sim"])["distance"]
    assert d is not None and math.isfinite(d)


def test_no_shared_bones(capsys, clips):
    """Read by bone names (``--bone-map none``), a CMU BVH (hip, abdomen, ..., head) and the renamed Acclaim take
    (root, x_lfemur, ..., x_head) share no bone; the automatic map finds the renamed joints by their words and
    the hierarchy and compares them."""
    pytest.importorskip("bpy")
    bvh = str(ROOT / "tests" / "data" / "bvh" / "09_02.bvh")
    by_names = ["--bone-map", "none"]
    for metric in ("sim", "elastic", "l2"):
        line = error_line(capsys, ["distance", clips["renamed"], bvh, "--metric", metric] + by_names)
        assert "share no bones" in line
    assert cli.main(["distance", clips["renamed"], bvh, "--json"]) == 0
    assert json.loads(capsys.readouterr()[0])["coverage"] >= 0.9
    out = clips["base"] / "x.blend"
    line = error_line(capsys, ["blend", clips["renamed"], bvh, "--weight", "0.5", "--out", str(out)] + by_names)
    assert "share no bones" in line and not out.exists()
    line = error_line(capsys, ["matrix", clips["renamed"], bvh, "--out", str(clips["base"] / "m"), "--no-figures"]
                      + by_names)
    assert "share no bones" in line and not (clips["base"] / "m").exists()  # not even the folder
    # rank skips a library clip that shares no bones, with a one-line warning naming it (bones by name:
    # --bone-map none; with the default map, "run" is mapped onto canonical joints and shares none either)
    code = cli.main(["rank", clips["renamed"], bvh, clips["run"], "--json", "--no-progress", "--bone-map", "none",
                     "--metric", "sim3",
                     "--allow-partial"])  # "run" shares under half of the moving bones: a partial match
    out_text, err = capsys.readouterr()
    assert code == 0
    assert [r["clip"] for r in json.loads(out_text)["results"]] == ["run"]
    warnings = err.strip().splitlines()
    assert all(w.startswith("blender_shapesig: warning:") for w in warnings)
    assert any("09_02" in w and "shares no bones" in w for w in warnings), warnings
    # Acclaim skeletons always share 'root': all other bones renamed leaves a root-only comparison
    # (by name; under half of the moving bones: refused naming the coverage unless --allow-partial)
    by_name = ["distance", clips["run"], clips["renamed"], "--metric", "sim", "--bone-map", "none"]
    assert "coverage 0.0" in error_line(capsys, by_name)
    d = ok_json(capsys, by_name + ["--allow-partial"])["distance"]
    assert math.isfinite(d)


def test_rank_with_degenerate_library(capsys, clips):
    got = ok_json(capsys, ["rank", clips["run"], clips["two"], clips["constant"], clips["long"], "--metric", "sim3",
                           "--rerank", "3"])
    rows = {r["clip"]: r for r in got["results"]}
    assert set(rows) == {"two", "constant", "long"}
    for r in rows.values():
        assert r["distance"] is not None and math.isfinite(r["distance"])
        assert r["elastic"] is not None and math.isfinite(r["elastic"])
    line = error_line(capsys, ["rank", clips["one"], clips["run"]])
    assert "one" in line and "frame" in line


def test_long_clip_signature_distance(capsys, clips):
    """10,000 frames: the signature path is linear in the frames (the elastic DP is not: docs/robustness.md)."""
    d = ok_json(capsys, ["distance", clips["long"], clips["run"], "--metric", "sim"])["distance"]
    assert math.isfinite(d)


def test_blend_errors_write_nothing(capsys, clips, tmp_path):
    out = tmp_path / "out.blend"
    cases = [
        (["blend", clips["one"], clips["run"], "--weight", "0.5", "--align"], "two frames"),
        (["blend", clips["run"], clips["two"], "--weight", "1.5"], "--weight: expected a finite number in [0, 1], got 1.5"),
        (["blend", clips["run"], clips["two"]], "give --weight"),
        (["blend", clips["run"], str(tmp_path / "missing.amc"), "--weight", "0.5"], "not found"),
    ]
    for args, needle in cases:
        line = error_line(capsys, args + ["--out", str(out)])
        assert needle in line, line
        assert not out.exists()
    line = error_line(capsys, ["blend", clips["run"], clips["two"], "--weight", "0.5", "--out",
                               str(tmp_path / "no" / "such" / "dir" / "x.blend")])
    assert "does not exist" in line


def test_matrix_errors_write_no_matrix(capsys, clips, tmp_path):
    out = tmp_path / "m"
    line = error_line(capsys, ["matrix", clips["run"], clips["one"], clips["two"], "--metric", "elastic",
                               "--out", str(out), "--no-figures", "--workers", "1"])
    assert "two frames" in line
    assert not (out / "matrix.csv").exists() and not (out / "matrix.npy").exists()
    got = ok_json(capsys, ["matrix", clips["run"], clips["two"], clips["constant"], "--metric", "sim",
                           "--out", str(out), "--no-figures", "--workers", "1"])
    text = pathlib.Path(got["matrix"]).read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower()


def test_bad_amc_files(capsys, clips, tmp_path):
    header, blocks = _frames(AMC)
    rng = random.Random(4)
    bad = {
        "nan": _amc([blocks[0], [b"root nan 0 0 0 0 0"] + blocks[1][1:]], header),
        "truncated": AMC[: len(AMC) // 2],
        "empty": b"",
        "binary": bytes(rng.randrange(256) for _ in range(3000)),
        "utf16_garbage": "\u4e00\u4e01".encode("utf-16-le") * 100,
    }
    for name, data in bad.items():
        p = clips["base"] / f"bad_{name}.amc"
        p.write_bytes(data)
        for cmd in (["distance", str(p), clips["run"]], ["rank", str(p), clips["run"]],
                    ["matrix", clips["run"], str(p), "--out", str(tmp_path / name)]):
            line = error_line(capsys, cmd)
            assert f"bad_{name}.amc" in line, line
            assert not (tmp_path / name / "matrix.csv").exists()
        # a bad library clip is skipped with a one-line warning naming the file
        code = cli.main(["rank", clips["run"], str(p), clips["two"], "--json", "--no-progress"])
        out_text, err = capsys.readouterr()
        assert code == 0
        assert [r["clip"] for r in json.loads(out_text)["results"]] == ["two"]
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("blender_shapesig: warning:") and f"bad_{name}.amc" in lines[0]


def test_usage_errors_are_one_line(capsys, clips):
    line = error_line(capsys, ["distance", clips["run"], clips["two"], "--metric", "nope"])
    assert "unknown metric" in line
    line = error_line(capsys, ["distance", clips["run"], clips["two"], "--depth", "0", "--metric", "elastic"])
    assert "depth" in line
    line = error_line(capsys, ["distance", clips["run"], clips["two"], "--level", "99"])
    assert "level" in line
    line = error_line(capsys, ["distance", clips["run"], clips["two"], "--start", "500", "--end", "400"])
    assert "500..400" in line and "must end at or after it starts" in line
    line = error_line(capsys, ["distance", clips["run"], str(clips["base"])])
    assert "folder" in line or "unsupported" in line
    line = error_line(capsys, ["distance", clips["run"], str(clips["base"] / "09-run.asf")])
    assert "unsupported file type .asf" in line


# ------------------------------------------------------------------ through Blender, in a subprocess


def _run(args, timeout=300):
    return subprocess.run([sys.executable, "-m", "blender_shapesig", *args, "--no-progress"], cwd=str(ROOT),
                          capture_output=True, text=True, timeout=timeout)


def test_corrupt_bvh_and_blend_end_to_end(tmp_path):
    pytest.importorskip("bpy")
    bvh = (ROOT / "tests" / "data" / "bvh" / "09_03.bvh").read_bytes()
    files = {
        "cut.bvh": bvh[: len(bvh) // 2],
        "nan.bvh": bvh.replace(b"\n0", b"\nnan", 1) if b"\n0" in bvh else bvh[:-30] + b" nan\n",
        "junk.blend": b"BLENDER17-01v0500" + bytes(random.Random(2).randrange(256) for _ in range(4000)),
        "empty.blend": b"",
        "text.blend": b"hello\n",
    }
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    good = str(ACC / "09_02.amc")
    for name in files:
        p = _run(["distance", str(tmp_path / name), good, "--asf", str(ACC / "09-run.asf")])
        assert p.returncode == 2, (name, p.returncode, p.stderr[-500:])
        assert p.stdout == ""
        ours = [ln for ln in p.stderr.splitlines() if ln.startswith("blender_shapesig: error:")]
        assert len(ours) == 1 and name in ours[0], (name, p.stderr[-800:])
        assert p.stderr.strip().splitlines()[-1] == ours[0]
        assert "Traceback" not in p.stderr


def test_rank_cache_corrupt_or_outdated_is_rebuilt(capsys, clips, tmp_path):
    cache = tmp_path / "cache"
    args = ["rank", clips["run"], clips["two"], clips["constant"], clips["norot"], "--cache", str(cache)]
    first = ok_json(capsys, args)
    files = sorted((cache / "blender_shapesig-cache").glob("*.npz"))
    assert len(files) >= 3
    for i, f in enumerate(files):
        blob = f.read_bytes()
        f.write_bytes([blob[: len(blob) // 3], b"\x00" * 100, b"PK\x03\x04garbage"][i % 3])
    again = ok_json(capsys, args)
    assert again["results"] == first["results"]
    assert again["cache"]["misses"] >= len(files)  # every damaged entry was recomputed
    third = ok_json(capsys, args)
    assert third["results"] == first["results"] and third["cache"]["misses"] == 0  # and written back
    (cache / "blender_shapesig-cache" / "manifest.json").write_text("{not json")
    fourth = ok_json(capsys, args)
    assert fourth["results"] == first["results"] and fourth["cache"]["misses"] >= len(files)


@pytest.fixture(scope="module")
def degenerate_blend(tmp_path_factory):
    """A .blend with the 09_02 run ('run') and degenerate actions of its armature: 'one' (1 frame), 'nan'
    (a NaN key), 'const' (60 equal frames), 'loc' (location keys only)."""
    bpy = pytest.importorskip("bpy")
    import blender_shapesig

    registered_here = False
    try:
        bpy.ops.shapesig.import_acclaim.get_rna_type()
    except (AttributeError, KeyError):
        blender_shapesig.register()
        registered_here = True  # unregistered below: the Blender tests' session fixture registers it
    try:
        return _write_degenerate_blend(bpy, tmp_path_factory)
    finally:
        if registered_here:
            blender_shapesig.unregister()


def _write_degenerate_blend(bpy, tmp_path_factory):
    import numpy as np

    from blender_shapesig import compat
    from blender_shapesig.actions import action_io
    from blender_shapesig.core.clip.clip import Clip

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.shapesig.import_acclaim("EXEC_DEFAULT", filepath=str(ACC / "09_02.amc"), asf_path=str(ACC / "09-run.asf"))
    arm = bpy.context.view_layer.objects.active
    bpy.data.actions["09_02"].name = "run"
    src = action_io.read_action(bpy.data.actions["run"], armature=arm, exclude_unkeyed=True)
    action_io.write_action(src.crop(1, 1), armature=arm, name="one")
    nan = action_io.write_action(src.crop(1, 40), armature=arm, name="nan")
    fc = next(f for f in compat.all_action_fcurves(nan) if "rotation" in f.data_path)
    co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
    fc.keyframe_points.foreach_get("co", co)
    co[7] = np.nan
    fc.keyframe_points.foreach_set("co", co)
    const = Clip(name="const", bones=src.bones, rotations=np.repeat(src.rotations[4:5], 60, axis=0),
                 rotation_modes=src.rotation_modes)
    action_io.write_action(const, armature=arm, name="const")
    loc = bpy.data.actions.new("loc")
    loc.use_fake_user = True
    bag, _slot = compat.ensure_channelbag(loc, "OBJECT", name=arm.name)
    f = compat.new_fcurve(bag, 'pose.bones["root"].location', 0, "root")
    f.keyframe_points.add(3)
    f.keyframe_points.foreach_set("co", np.array([1, 0, 2, 1, 3, 0], dtype=np.float32))
    path = tmp_path_factory.mktemp("blend") / "degenerate.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return str(path)


def test_degenerate_actions_in_a_blend_file(capsys, degenerate_blend, tmp_path):
    b = degenerate_blend
    assert "'one' has 1 frame" in error_line(capsys, ["distance", f"{b}#one", f"{b}#run", "--metric", "elastic"])
    assert "NaN or infinite" in error_line(capsys, ["distance", f"{b}#nan", f"{b}#run"])
    # the whole file: one bad action makes it an error naming that action
    assert "action 'nan'" in error_line(capsys, ["distance", b, f"{b}#run"])
    assert "no action 'nope'" in error_line(capsys, ["distance", f"{b}#nope", f"{b}#run"])
    out = tmp_path / "x.blend"
    assert "NaN" in error_line(capsys, ["blend", f"{b}#run", f"{b}#nan", "--weight", "0.5", "--out", str(out)])
    assert not out.exists()
    for metric in ("sim", "elastic", "l2"):
        d = ok_json(capsys, ["distance", f"{b}#const", f"{b}#run", "--metric", metric])["distance"]
        assert d is not None and math.isfinite(d) and d > 0
    # an action that only moves the root: one joint of the rigs' canonical joints, refused unless asked
    assert "coverage 0.05" in error_line(capsys, ["distance", f"{b}#loc", f"{b}#run", "--metric", "sim"])
    d = ok_json(capsys, ["distance", f"{b}#loc", f"{b}#run", "--metric", "sim", "--allow-partial"])["distance"]
    assert d is not None and math.isfinite(d)
    got = ok_json(capsys, ["blend", f"{b}#run", f"{b}#const", "--weight", "0.5", "--out", str(out)])
    assert out.exists() and len(got["actions"]) == 1
