"""The extension package: the top-level manifest, staging, wheel selection and the built zip, checked with
Blender's own validator (bl_pkg/cli/blender_ext.py from the bpy module; no Blender binary needed).

Fast: no network. The zip build uses only wheels already in the cache (tools/build_extension.py fills it);
without them it builds the wheel-less zip, so the manifest and package layout are always validated.
"""

import importlib.util
import json
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "tools" / "build_extension.py"


def _load_build_module():
    spec = importlib.util.spec_from_file_location("_shapesig_build_extension", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


be = _load_build_module()

try:
    BLENDER_EXT, TAGS = be.find_blender_ext()
except be.BuildError as ex:  # pragma: no cover - the dev venv always has bpy
    pytest.skip(f"Blender's extension builder not available: {ex}", allow_module_level=True)
BEXT = be.load_blender_ext(BLENDER_EXT)


def _validate(path):
    return subprocess.run([sys.executable, str(BLENDER_EXT), "validate", str(path), "--valid-tags", str(TAGS)],
                          capture_output=True, text=True)


@pytest.fixture(scope="module")
def manifest():
    with open(ROOT / "blender_manifest.toml", "rb") as fh:
        return tomllib.load(fh)


# ---------------------------------------------------------------------------------------------------------
# The source manifest


def test_manifest_fields(manifest):
    assert manifest["schema_version"] == "1.0.0"
    assert manifest["id"] == "blender_shapesig"
    assert manifest["type"] == "add-on"
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["license"] and all(lic.startswith("SPDX:") for lic in manifest["license"])
    tagline = manifest["tagline"]
    assert len(tagline) < 64 and tagline[-1].isalnum(), tagline
    assert "files" in manifest["permissions"]
    # The build adds these per platform; the source must not pin them.
    assert "platforms" not in manifest and "wheels" not in manifest


def test_manifest_tags_are_blenders(manifest):
    valid = BEXT.pkg_manifest_tags_load_valid_map(str(TAGS))
    assert isinstance(valid, dict), valid
    assert manifest["tags"] and set(manifest["tags"]) <= valid["add-on"]


def test_staged_manifest_adds_lists_before_tables():
    source = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
    wheels = ["./wheels/scipy-1.15.3-cp311-cp311-win_amd64.whl"]
    text = be.staged_manifest_text(source, ["linux-x64", "windows-x64"], wheels)
    data = tomllib.loads(text)
    assert data["platforms"] == ["linux-x64", "windows-x64"]
    assert data["wheels"] == wheels
    assert data["permissions"] == tomllib.loads(source)["permissions"]  # still a table, not swallowed
    with pytest.raises(be.BuildError, match="platforms"):
        be.staged_manifest_text('platforms = ["linux-x64"]\n' + source, ["linux-x64"], [])


def test_staged_manifest_carries_each_pythons_blender_range():
    """cp311 (Blender 4.2 to 5.0): min 4.2.0, max 5.1.0 (exclusive); cp313 (5.1+): min 5.1.0, no max."""
    source = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
    assert be.BLENDER_RANGE == {"cp311": ("4.2.0", "5.1.0"), "cp313": ("5.1.0", None)}
    old = tomllib.loads(be.staged_manifest_text(source, ["linux-x64"], [], be.BLENDER_RANGE["cp311"]))
    new = tomllib.loads(be.staged_manifest_text(source, ["linux-x64"], [], be.BLENDER_RANGE["cp313"]))
    assert (old["blender_version_min"], old["blender_version_max"]) == ("4.2.0", "5.1.0")
    assert new["blender_version_min"] == "5.1.0" and "blender_version_max" not in new
    assert new["permissions"] == tomllib.loads(source)["permissions"]
    # a raised source minimum is never lowered; the source must not set the maximum itself
    raised = source.replace('blender_version_min = "4.2.0"', 'blender_version_min = "4.4.0"')
    assert tomllib.loads(be.staged_manifest_text(raised, ["linux-x64"], [], ("4.2.0", "5.1.0")))[
        "blender_version_min"] == "4.4.0"
    with pytest.raises(be.BuildError, match="blender_version_max"):
        be.staged_manifest_text('blender_version_max = "6.0.0"\n' + source, ["linux-x64"], [])


def test_staged_package_passes_blenders_validator(tmp_path):
    pkg = be.stage(tmp_path, ["linux-x64"], [], "cp311")  # the range's maximum too
    assert (pkg / "__init__.py").is_file() and (pkg / "blender_manifest.toml").is_file()
    assert not list(pkg.rglob("__pycache__"))
    proc = _validate(pkg)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def _other_builders():
    """Blender's builders from the other venvs (the development ones, ``.venv-bpy-*``, or the install test's,
    ``.venv-install-*``: CI makes those first), one per Blender version, run with their own Python."""
    found, versions = [], set()
    for pattern in (".venv-bpy-*", ".venv-install-*"):
        for ext in sorted(ROOT.glob(pattern + "/lib/python3*/site-packages/bpy/*/scripts/addons_core/bl_pkg/cli/"
                                              "blender_ext.py")):
            venv, version = ext.parents[9], ext.parents[4].name
            if (venv / "bin" / "python").exists() and ext.resolve() != BLENDER_EXT.resolve() \
                    and version != BLENDER_EXT.parents[4].name and version not in versions:
                versions.add(version)
                found.append(pytest.param(venv / "bin" / "python", ext, id=f"bpy-{version}"))
    return found or [pytest.param(None, None, id="none", marks=pytest.mark.skip(
        reason="no .venv-bpy-* or .venv-install-* with another Blender version"))]


@pytest.mark.parametrize("python,builder", _other_builders())
def test_staged_package_passes_older_blenders_validator(tmp_path, python, builder):
    """blender_version_min is 4.2: the 4.2 LTS builder must accept the staged manifest (with a maximum) too."""
    pkg = be.stage(tmp_path, ["linux-x64"], [], "cp311")
    tags = builder.parents[3] / "modules" / "_bpy_internal" / "extensions" / "tags.py"
    proc = subprocess.run([str(python), str(builder), "validate", str(pkg), "--valid-tags", str(tags)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_validator_rejects_a_bad_manifest(tmp_path):
    """The validation above can fail: a tag outside Blender's list and a punctuated tagline are rejected."""
    pkg = be.stage(tmp_path, ["linux-x64"], [])
    good = (pkg / "blender_manifest.toml").read_text(encoding="utf-8")
    (pkg / "blender_manifest.toml").write_text(good.replace('"Import-Export"', '"Motion Capture"'))
    proc = _validate(pkg)
    assert proc.returncode != 0 and "Motion Capture" in proc.stdout + proc.stderr
    (pkg / "blender_manifest.toml").write_text(good.replace("by their shape", "by their shape."))
    assert _validate(pkg).returncode != 0


# ---------------------------------------------------------------------------------------------------------
# Wheel selection (fake wheel files in a temporary cache, offline)


def _touch(cache, *names):
    for n in names:
        (cache / n).write_bytes(b"")


def test_wheel_selection_per_platform(tmp_path):
    _touch(tmp_path,
           "scipy-1.15.3-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl",
           "scipy-1.15.3-cp311-cp311-win_amd64.whl",
           "scipy-1.15.3-cp311-cp311-macosx_10_13_x86_64.whl",
           "scipy-1.14.1-cp311-cp311-macosx_12_0_arm64.whl",  # wrong version: macos-arm64 has no scipy
           "scipy-1.15.3-cp312-cp312-macosx_12_0_arm64.whl",  # wrong Python
           "numba-0.68.1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
           "llvmlite-0.50.0-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
           "numba-0.68.1-cp311-cp311-win_amd64.whl",  # numba without llvmlite is useless: not bundled
           "numpy-1.26.4-cp311-cp311-win_amd64.whl",
           # Python 3.13 (Blender 5.1+): macos-x64 has no cp313 scipy, so no cp313 wheels at all there
           "scipy-1.18.1-cp313-cp313-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
           "scipy-1.18.1-cp313-cp313-win_amd64.whl",
           "scipy-1.15.3-cp313-cp313-macosx_10_13_x86_64.whl",  # cp313 pins scipy 1.18.1: not this one
           "scipy-1.18.1-cp313-cp313-macosx_14_0_arm64.whl",  # macOS 14 only: too new for Blender's macOS 12
           "numba-0.68.1-cp313-cp313-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
           "llvmlite-0.50.0-cp313-cp313-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl",
           "numba-0.68.1-cp313-cp313-win_amd64.whl")
    chosen, notes = be.collect_wheels(BEXT, tmp_path, list(be.PLATFORMS), offline=True, without={"iisignature"})
    names = {k: sorted("-".join(w.name.split("-")[:3:2]) for w in ws) for k, ws in chosen.items()}
    # one zip per platform and Python, each with that Python's wheels only
    assert names == {("linux-x64", "cp311"): ["llvmlite-cp311", "numba-cp311", "scipy-cp311"],
                     ("linux-x64", "cp313"): ["llvmlite-cp313", "numba-cp313", "scipy-cp313"],
                     ("windows-x64", "cp311"): ["scipy-cp311"], ("windows-x64", "cp313"): ["scipy-cp313"],
                     ("macos-x64", "cp311"): ["scipy-cp311"]}
    assert all(any("scipy" in n for n in notes[("macos-arm64", t)]) for t in be.PYTHONS)
    assert any("numba" in n for n in notes[("windows-x64", "cp311")])
    assert any("scipy" in n for n in notes[("macos-x64", "cp313")])
    for (platform, _), wheels in chosen.items():
        for w in wheels:
            assert platform in be.wheel_blender_platforms(BEXT, w.name)
    # --without numba: the same zips without numba and llvmlite; one Python asked: only its zips
    lite, _ = be.collect_wheels(BEXT, tmp_path, ["linux-x64"], offline=True, without={"iisignature", "numba"},
                                pythons=["cp313"])
    assert {k: sorted(w.name.split("-")[0] for w in ws) for k, ws in lite.items()} == {
        ("linux-x64", "cp313"): ["scipy"]}


def test_wheel_tags_too_new_are_refused():
    assert be.wheel_tags_acceptable("manylinux_2_17_x86_64.manylinux2014_x86_64", "linux-x64")
    assert be.wheel_tags_acceptable("linux_x86_64", "linux-x64")
    assert not be.wheel_tags_acceptable("manylinux_2_34_x86_64", "linux-x64")  # Blender 4.2 needs only glibc 2.28
    assert be.wheel_tags_acceptable("macosx_11_0_arm64", "macos-arm64")
    assert not be.wheel_tags_acceptable("macosx_14_0_arm64", "macos-arm64")
    assert not be.wheel_tags_acceptable("macosx_12_0_x86_64", "macos-arm64")
    assert not be.wheel_tags_acceptable("win32", "windows-x64")


# ---------------------------------------------------------------------------------------------------------
# The built linux zip


def _cached_linux_wheels():
    cache = be.default_wheel_cache()
    return cache.is_dir() and all(be.find_cached_wheel(BEXT, cache, specs[0], "linux-x64", tag) is not None
                                  for tag, specs in be.REQUIRED_GROUPS["scipy"].items())


def _build(out, *extra):
    args = [sys.executable, str(SCRIPT), "--out", str(out), "--platforms", "linux-x64", "--json", "--offline"]
    proc = subprocess.run(args + list(extra), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert [(z["platform"], z["python"]) for z in summary["zips"]] == [("linux-x64", t) for t in be.PYTHONS]
    return summary


@pytest.fixture(scope="module")
def linux_zips(tmp_path_factory):
    """{python tag: zip summary} of the linux-x64 build (with the cached wheels, else without wheels)."""
    with_wheels = _cached_linux_wheels()
    summary = _build(tmp_path_factory.mktemp("ext"), *([] if with_wheels else ["--no-wheels"]))
    return {z["python"]: z for z in summary["zips"]}, with_wheels


def _zip_manifest(path):
    with zipfile.ZipFile(path) as zf:
        return tomllib.loads(zf.read("blender_manifest.toml").decode())


@pytest.mark.parametrize("pytag", list(be.PYTHONS))
def test_linux_zip_validates_and_holds_the_package(linux_zips, pytag):
    path = Path(linux_zips[0][pytag]["zip"])
    assert path.name == f"blender_shapesig-0.1.0-linux_x64-{pytag}.zip"
    proc = _validate(path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    with zipfile.ZipFile(path) as zf:
        names = set(zf.namelist())
    manifest = _zip_manifest(path)
    source = {p.relative_to(ROOT / "blender_shapesig").as_posix()
              for p in (ROOT / "blender_shapesig").rglob("*.py") if "__pycache__" not in p.parts}
    assert source <= names, sorted(source - names)
    assert not any("__pycache__" in n or n.endswith(".pyc") for n in names)
    assert manifest["build"]["generated"]["platforms"] == ["linux-x64"]
    assert manifest["id"] == "blender_shapesig"
    low, high = be.BLENDER_RANGE[pytag]
    assert (manifest["blender_version_min"], manifest.get("blender_version_max")) == (low, high)


# Blender versions and their Python: each zip must be installable on its own Blenders only.
BLENDERS = {(4, 2, 23): (3, 11, 7), (5, 0, 1): (3, 11, 13), (5, 1, 0): (3, 13, 5), (5, 2, 3): (3, 13, 9)}


def test_blender_takes_each_zip_on_its_own_versions_only(linux_zips):
    """Blender's own install-time check (blender_ext.repository_filter_skip on the zip's manifest, as
    ``install-files`` runs it): the cp311 zip on 4.2 and 5.0 only, the cp313 zip on 5.1 and 5.2 only, and the
    refusal names the version range."""
    for pytag, z in linux_zips[0].items():
        manifest = BEXT.pkg_manifest_from_archive_and_validate(z["zip"], strict=False)
        assert not isinstance(manifest, str), manifest
        for blender, python in BLENDERS.items():
            said = []
            skip = BEXT.repository_filter_skip(manifest._asdict(), filter_blender_version=blender,
                                               filter_platform="linux-x64", filter_python_version=python,
                                               skip_message_fn=said.append, error_fn=lambda ex: said.append(ex))
            fits = f"cp{python[0]}{python[1]}" == pytag
            assert skip != fits, (pytag, blender, said)
            assert fits or (len(said) == 1 and "version" in said[0]), said


def test_linux_zip_wheels(linux_zips):
    zips, with_wheels = linux_zips
    if not with_wheels:
        pytest.skip("no cached linux-x64 wheels (run: python tools/build_extension.py --out build/ext once)")
    per_tag = {}
    for pytag, z in zips.items():
        with zipfile.ZipFile(z["zip"]) as zf:
            wheels = sorted(n for n in zf.namelist() if n.endswith(".whl"))
        manifest = _zip_manifest(z["zip"])
        dists = {Path(w).name.split("-")[0] for w in wheels}
        assert "scipy" in dists and "numpy" not in dists
        assert ("numba" in dists) == ("llvmlite" in dists)
        assert sorted(w.removeprefix("./") for w in manifest["build"]["generated"]["wheels"]) == wheels
        for w in wheels:
            assert "linux-x64" in be.wheel_blender_platforms(BEXT, Path(w).name), w
            assert Path(w).name.split("-")[-3] == pytag, w  # only this Python's wheels
        per_tag[pytag] = dists
        # the zip's own size and what it unpacks to (wheel contents included) are reported
        assert z["bytes"] == Path(z["zip"]).stat().st_size and z["installed_bytes"] > z["bytes"]
        print(f"{Path(z['zip']).name}: {z['bytes'] / 1e6:.1f} MB, unpacked {z['installed_bytes'] / 1e6:.0f} MB")
    assert per_tag["cp311"] == per_tag["cp313"], per_tag  # the same modules for both Pythons


def test_lite_zips_leave_out_numba(tmp_path):
    """``--without numba``: the '-lite' zips, the same package and range without numba and llvmlite."""
    if not _cached_linux_wheels():
        pytest.skip("no cached linux-x64 wheels (run: python tools/build_extension.py --out build/ext once)")
    summary = _build(tmp_path, "--without", "numba")
    for z in summary["zips"]:
        path = Path(z["zip"])
        assert path.name == f"blender_shapesig-0.1.0-linux_x64-{z['python']}-lite.zip"
        assert _validate(path).returncode == 0
        dists = {w.split("-")[0] for w in z["wheels"]}
        assert "scipy" in dists and not dists & {"numba", "llvmlite"}, dists
        assert _zip_manifest(path)["blender_version_min"] == be.BLENDER_RANGE[z["python"]][0]


# ---------------------------------------------------------------------------------------------------------
# Blender's install-time wheel filter, per target platform


# What sysconfig.get_platform() says inside Blender on each platform (Blender 4.2 to 5.2 official builds).
SYSCONFIG_PLATFORM = {"linux-x64": "linux-x86_64", "windows-x64": "win-amd64",
                      "macos-arm64": "macosx-11.2-arm64", "macos-x64": "macosx-11.2-x86_64"}


def test_blender_installs_every_bundled_wheel_on_its_platform(monkeypatch):
    """Blender installs a wheel only if its own filter (bl_pkg, run on the user's machine) accepts it: every
    wheel we pick for a platform and this Python must pass that filter there, and none must pass it on another
    platform."""
    pytest.importorskip("bpy")
    import sysconfig

    ops = pytest.importorskip("bl_pkg.bl_extension_ops")
    cache = be.default_wheel_cache()
    chosen, _ = be.collect_wheels(BEXT, cache, list(be.PLATFORMS), offline=True, without=set()) \
        if cache.is_dir() else ({}, {})
    if not chosen:
        pytest.skip("no cached wheels (run: python tools/build_extension.py --out build/ext once)")
    pytag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    for (platform, tag), wheels in chosen.items():
        if tag != pytag:
            continue
        names = [f"./wheels/{w.name}" for w in wheels]
        mine = names
        assert mine, (platform, names)
        for target, sysconfig_platform in SYSCONFIG_PLATFORM.items():
            monkeypatch.setattr(sysconfig, "get_platform", lambda p=sysconfig_platform: p)
            accepted = ops._extensions_wheel_filter_for_this_system(names)
            if target == platform:
                assert accepted == mine, (platform, sorted(set(mine) ^ set(accepted)))
            else:
                assert accepted == [], (platform, target, accepted)
