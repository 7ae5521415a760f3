#!/usr/bin/env python3
"""Build the blender_shapesig extension zips (one per platform and Blender Python) with Blender's own builder.

    python tools/build_extension.py --out DIR [--platforms linux-x64,windows-x64] [--pythons cp311,cp313]
                                    [--without numba] [--no-wheels] [--validate-only]

The top-level ``blender_manifest.toml`` is the one source of truth. Blender embeds CPython 3.11 in 4.2 LTS .. 5.0
and CPython 3.13 in 5.1 and 5.2 LTS; each zip carries the wheels of one of them only and says which Blender
versions it is for (``blender_version_min`` / ``blender_version_max``, exclusive), so Blender refuses the other
one. For each Python tag this script

1. stages the package: copies ``blender_shapesig/`` to a temporary folder, puts the manifest beside
   ``__init__.py`` (with that Python's Blender version range) and adds ``wheels/`` plus the
   ``platforms = [...]`` and ``wheels = [...]`` lists;
2. fetches that Python's platform wheels from PyPI into a cache outside git (``~/.cache/blender_shapesig/wheels``,
   or ``$SHAPESIG_WHEEL_CACHE``, or ``--wheel-cache``) with ``pip download --only-binary=:all: --platform TAG
   --python-version 3.11|3.13 --implementation cp --no-deps``, and builds the iisignature wheel from the sdist
   (it has no binary wheels on PyPI) against numpy 2 when this machine has that Python (linux-x64 only);
3. runs ``blender_ext.py build --split-platforms --valid-tags TAGS`` (Blender's builder and tag list, found
   inside the bpy module), names each zip ``blender_shapesig-VERSION-PLATFORM-PYTAG[-lite].zip``, then runs
   ``blender_ext.py validate`` on every zip and checks each zip's contents.

Wheels per platform and Python: scipy is required (a platform and Python without its scipy wheel gets no zip);
numba + llvmlite are optional and go together (bundled where PyPI has both; the add-on falls back to numpy
otherwise; ``--without numba`` leaves them out on purpose and names the zips ``...-lite.zip``); iisignature is
optional (linux-x64 only; the add-on falls back to its numpy signatures). numpy is never bundled: Blender ships it.

Exit code 0 on success, 1 on a build/validation failure, 2 on a usage error. The last line on stdout is a
JSON summary (``--json`` prints only that).
"""

from __future__ import annotations

import argparse
import glob
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "blender_shapesig"
MANIFEST = ROOT / "blender_manifest.toml"
# Blender's embedded CPython per line: 4.2 LTS .. 5.0 run 3.11, 5.1 and 5.2 LTS run 3.13 (with numpy 2). Python
# tag -> version. Each zip carries one Python's wheels and that Python's Blender range, (blender_version_min,
# blender_version_max or None): Blender's installer refuses the zip outside it ("This Blender version (5.2.3) must
# be less than the maximum version (5.1.0)", "... doesn't meet the minimum supported version (5.1.0)").
PYTHONS = {"cp311": "3.11", "cp313": "3.13"}
BLENDER_RANGE = {"cp311": ("4.2.0", "5.1.0"), "cp313": ("5.1.0", None)}

# Blender platform -> pip --platform tags, most specific first. pip expands macOS versions downwards itself,
# but not manylinux ones, hence the explicit list. Blender 4.2+ on Linux needs glibc >= 2.28, so
# manylinux_2_28 is the newest tag we accept. scipy 1.15.3's arm64 wheels need macOS 12.
PLATFORMS: dict[str, list[str]] = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64",
                  "manylinux2014_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_12_0_arm64"],
    "macos-x64": ["macosx_11_0_x86_64"],
}

# Pinned like tools/setup_env.sh, per Python tag. Each group is bundled whole or not at all. All are numpy-2
# builds (they load with Blender 4.2-5.0's numpy 1.26 and with 5.1+'s numpy 2).
REQUIRED_GROUPS = {"scipy": {"cp311": ["scipy==1.15.3"], "cp313": ["scipy==1.18.1"]}}
OPTIONAL_GROUPS = {"numba": {"cp311": ["numba==0.68.1", "llvmlite==0.50.0"],
                             "cp313": ["numba==0.68.1", "llvmlite==0.50.0"]}}
IISIGNATURE = "iisignature==0.24"
# iisignature has no wheels on PyPI: it is built from its sdist against this numpy (a numpy-2 build also
# loads with numpy 1.26), in a throwaway build venv per Python, kept in the cache folder.
BUILD_NUMPY = "2.3.5"
NEVER_BUNDLE = {"numpy"}


class BuildError(Exception):
    pass


def log(msg: str) -> None:
    print(f"[build_extension] {msg}", file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------------------------------------
# Blender's builder


def find_blender_ext(explicit: str | None = None) -> tuple[Path, Path]:
    """Return (blender_ext.py, tags.py) from the bpy module (no import of bpy needed)."""
    candidates: list[Path] = []
    if explicit:
        candidates.append(Path(explicit))
    if os.environ.get("SHAPESIG_BLENDER_EXT"):
        candidates.append(Path(os.environ["SHAPESIG_BLENDER_EXT"]))
    spec = importlib.util.find_spec("bpy")
    roots = []
    if spec is not None and spec.submodule_search_locations:
        roots += [Path(p) for p in spec.submodule_search_locations]
    # Fall back to the repository's development environments.
    roots += [Path(p) for p in sorted(glob.glob(str(ROOT / ".venv*/lib/python3*/site-packages/bpy")), reverse=True)]
    for root in roots:
        # Newest Blender first (e.g. bpy/5.0 before bpy/4.2).
        found = sorted(root.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"), reverse=True)
        candidates += found
    for cand in candidates:
        if cand.is_file():
            scripts = cand.parents[3]  # .../scripts
            tags = scripts / "modules" / "_bpy_internal" / "extensions" / "tags.py"
            if not tags.is_file():
                raise BuildError(f"Blender's tag list not found beside the builder: {tags}")
            return cand, tags
    raise BuildError("Blender's extension builder (bl_pkg/cli/blender_ext.py) not found: install bpy "
                     "(bash tools/setup_env.sh) or pass --blender-ext PATH")


def load_blender_ext(path: Path):
    """Import blender_ext.py as a module (it is a standalone script) to reuse its wheel/platform logic."""
    spec = importlib.util.spec_from_file_location("_shapesig_blender_ext", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run_blender_ext(blender_ext: Path, *args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(blender_ext), *args]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    for line in (proc.stdout + proc.stderr).splitlines():
        log(f"  blender_ext: {line}")
    return proc


# ----------------------------------------------------------------------------------------------------------
# Wheels


def default_wheel_cache() -> Path:
    if os.environ.get("SHAPESIG_WHEEL_CACHE"):
        return Path(os.environ["SHAPESIG_WHEEL_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "blender_shapesig" / "wheels"


def wheel_fields(filename: str) -> dict[str, str]:
    parts = filename[:-4].split("-")
    if not filename.endswith(".whl") or not 5 <= len(parts) <= 6:
        raise BuildError(f"not a wheel file name: {filename}")
    return {"name": parts[0].lower().replace("_", "-"), "version": parts[1], "python": parts[-3],
            "abi": parts[-2], "platform": parts[-1]}


def wheel_blender_platforms(bext, filename: str) -> set[str]:
    plat = wheel_fields(filename)["platform"]
    out: set[str] = set()
    for tag in plat.split("."):
        if tag == "any":
            return set(PLATFORMS)
        out.update(bext.blender_platforms_from_wheel_platform(tag))
    return out


def find_cached_wheel(bext, cache: Path, spec: str, platform: str, pytag: str) -> Path | None:
    """The cached wheel of ``spec`` for ``platform`` and CPython ``pytag`` (e.g. "cp313"), or None."""
    name, version = spec.split("==")
    hits = []
    for path in sorted(cache.glob("*.whl")):
        f = wheel_fields(path.name)
        if f["name"] != name.lower() or f["version"] != version:
            continue
        if pytag not in f["python"].split(".") and not f["python"].startswith("py3"):
            continue
        if platform in wheel_blender_platforms(bext, path.name) and wheel_tags_acceptable(f["platform"], platform):
            hits.append(path)
    return hits[0] if hits else None


def wheel_tags_acceptable(wheel_platform: str, platform: str) -> bool:
    """Whether a wheel's platform tag(s) are ones we would download for ``platform``: one of PLATFORMS[platform],
    an older macOS of the same architecture, or ``linux_x86_64`` (the locally built iisignature)."""
    for tag in wheel_platform.split("."):
        if tag in PLATFORMS[platform] or (platform == "linux-x64" and tag == "linux_x86_64"):
            return True
        m = re.fullmatch(r"macosx_(\d+)_(\d+)_(\w+)", tag)
        for want in PLATFORMS[platform]:
            w = re.fullmatch(r"macosx_(\d+)_(\d+)_(\w+)", want)
            if m and w and m.group(3) == w.group(3) and (int(m.group(1)), int(m.group(2))) <= (int(w.group(1)), int(w.group(2))):
                return True
    return False


def pip_download(cache: Path, spec: str, platform: str, pytag: str) -> str:
    """"ok", "unavailable" (PyPI has no such wheel) or "error" (pip or the network failed)."""
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check",
           "--only-binary=:all:", "--python-version", PYTHONS[pytag], "--implementation", "cp",
           "--abi", pytag, "--no-deps", "--dest", str(cache)]
    for tag in PLATFORMS[platform]:
        cmd += ["--platform", tag]
    cmd.append(spec)
    log(f"pip download {spec} for {platform} {pytag}")
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        if "No matching distribution" in proc.stderr or "Could not find a version" in proc.stderr:
            log(f"  not available: {last}")
            return "unavailable"
        log(f"  pip download failed: {last}")
        return "error"
    return "ok"


def ensure_wheel(bext, cache: Path, spec: str, platform: str, pytag: str, offline: bool,
                 refresh: bool = False) -> Path | None:
    """The cached wheel for ``spec`` on ``platform`` / ``pytag``, downloaded first if needed. A failed download
    leaves a marker in the cache so later builds do not ask PyPI again (``--refresh`` asks again)."""
    hit = find_cached_wheel(bext, cache, spec, platform, pytag)
    marker = cache / f".unavailable-{spec.replace('==', '-')}-{platform}-{pytag}"
    if hit is None and not offline and (refresh or not marker.exists()):
        status = pip_download(cache, spec, platform, pytag)
        if status == "ok":
            marker.unlink(missing_ok=True)
        elif status == "unavailable":
            marker.write_text("PyPI has no such wheel; delete this file or pass --refresh to retry\n")
        hit = find_cached_wheel(bext, cache, spec, platform, pytag)
    return hit


def find_python(version: str) -> str | None:
    """An interpreter of CPython ``version`` ("3.13") on this machine: $SHAPESIG_PYTHON_<X_Y>, pythonX.Y on PATH,
    or a pyenv-installed X.Y (newest first); None if there is none."""
    cands = [os.environ.get(f"SHAPESIG_PYTHON_{version.replace('.', '_')}"), shutil.which(f"python{version}")]
    pyenv_root = os.environ.get("PYENV_ROOT") or os.path.expanduser("~/.pyenv")
    for d in sorted(glob.glob(os.path.join(pyenv_root, "versions", f"{version}.*")), reverse=True):
        cands.append(os.path.join(d, "bin", f"python{version}"))
    if sys.version_info[:2] == tuple(map(int, version.split("."))):
        cands.insert(0, sys.executable)
    check = f"import sys; sys.exit(sys.version_info[:2] != {tuple(map(int, version.split('.')))!r})"
    for cand in cands:
        if cand and os.path.exists(cand) and subprocess.run([cand, "-c", check], capture_output=True).returncode == 0:
            return cand
    return None


def host_can_build_iisignature(pytag: str) -> str | None:
    """None if this machine can build the linux-x64 iisignature wheel for ``pytag``, else the reason it cannot."""
    import platform as _platform

    if sys.platform != "linux" or _platform.machine().lower() not in {"x86_64", "amd64"}:
        return f"host is {sys.platform}/{_platform.machine()}, not linux-x64"
    if find_python(PYTHONS[pytag]) is None:
        return f"no Python {PYTHONS[pytag]} on this machine to build the {pytag} wheel"
    return None


def iisignature_dir(cache: Path) -> Path:
    """Where the locally built iisignature wheels live: named after the numpy they were built against, so an
    older build (e.g. against numpy 1.26) is never picked up."""
    return cache / f"built-numpy-{BUILD_NUMPY}"


def ensure_iisignature(bext, cache: Path, pytag: str, offline: bool) -> Path | None:
    built = iisignature_dir(cache)
    built.mkdir(parents=True, exist_ok=True)
    hit = find_cached_wheel(bext, built, IISIGNATURE, "linux-x64", pytag)
    if hit is not None:
        return hit
    reason = host_can_build_iisignature(pytag)
    if reason:
        log(f"iisignature not bundled for {pytag}: {reason}")
        return None
    if offline:
        log(f"iisignature not bundled for {pytag}: not built yet and --offline")
        return None
    # A build venv with numpy 2 + setuptools + wheel (iisignature's sdist imports numpy in setup.py, hence
    # --no-build-isolation); kept beside the wheels and reused.
    venv = built / f"venv-{pytag}"
    python = venv / "bin" / "python"
    log(f"building {IISIGNATURE} from source for linux-x64 {pytag} against numpy {BUILD_NUMPY}")
    steps = []
    if not python.exists():
        steps.append([find_python(PYTHONS[pytag]), "-m", "venv", str(venv)])
    steps.append([str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                  f"numpy=={BUILD_NUMPY}", "setuptools<75", "wheel"])
    steps.append([str(python), "-m", "pip", "wheel", "--quiet", "--disable-pip-version-check",
                  "--no-build-isolation", "--no-deps", "--no-binary", "iisignature", "--wheel-dir", str(built),
                  IISIGNATURE])
    for cmd in steps:
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            log("  iisignature build failed: " + (proc.stderr.strip().splitlines() or ["?"])[-1])
            return None
    return find_cached_wheel(bext, built, IISIGNATURE, "linux-x64", pytag)


def collect_wheels(bext, cache: Path, platforms: list[str], offline: bool, without: set[str], refresh: bool = False,
                   pythons: list[str] | None = None):
    """Return ({(platform, pytag): [wheel paths]}, {(platform, pytag): [notes]}): one entry per zip to build, for
    every platform and Python tag that has its required wheels. A platform and Python without them gets no zip
    (with a note): an add-on without scipy cannot import."""
    cache.mkdir(parents=True, exist_ok=True)
    chosen: dict[tuple[str, str], list[Path]] = {}
    notes: dict[tuple[str, str], list[str]] = {}
    for platform in platforms:
        for pytag in pythons or list(PYTHONS):
            tagged, missing, note = [], None, []
            for group, per_tag in REQUIRED_GROUPS.items():
                found = [ensure_wheel(bext, cache, s, platform, pytag, offline, refresh) for s in per_tag[pytag]]
                if None in found:
                    missing = group
                    break
                tagged += found
            if missing:
                log(f"platform {platform}: no {missing} wheel for {pytag}, so no {pytag} zip")
                notes[(platform, pytag)] = [f"left out: no {missing} wheel for {pytag}"]
                continue
            for group, per_tag in OPTIONAL_GROUPS.items():
                if group in without:
                    note.append(f"no {group} (--without)")
                    continue
                found = []
                for spec in per_tag[pytag]:  # stop at the first missing one: the group is all or nothing
                    found.append(ensure_wheel(bext, cache, spec, platform, pytag, offline, refresh))
                    if found[-1] is None:
                        break
                if None in found:
                    note.append(f"no {group} (numpy fallback)")
                    log(f"platform {platform}: {group} not bundled (no {pytag} wheel), the numpy fallback is used")
                else:
                    tagged += found
            if "iisignature" in without:
                note.append("no iisignature (--without)")
            elif platform != "linux-x64":
                note.append("no iisignature (numpy fallback)")
            elif (iis := ensure_iisignature(bext, cache, pytag, offline)) is not None:
                tagged.append(iis)
            else:
                note.append("no iisignature (numpy fallback)")
            chosen[(platform, pytag)] = tagged
            notes[(platform, pytag)] = note
    return chosen, notes


# ----------------------------------------------------------------------------------------------------------
# Staging


def toml_list(values: list[str]) -> str:
    if not values:
        return "[]"
    return "[\n" + "".join(f"  {json.dumps(v)},\n" for v in values) + "]"


def staged_manifest_text(source: str, platforms: list[str], wheels: list[str],
                         blender_range: tuple[str, str | None] | None = None) -> str:
    """The top-level manifest with ``platforms`` and ``wheels`` inserted before the first table and, with
    ``blender_range`` = (min, max or None), ``blender_version_min`` raised to min (never lowered) and
    ``blender_version_max`` (exclusive) set to max."""
    data = tomllib.loads(source)
    for key in ("platforms", "wheels", "blender_version_max"):
        if key in data:
            raise BuildError(f"blender_manifest.toml must not set '{key}': the build script adds it")
    lines = source.splitlines(keepends=True)
    expect = dict(data, platforms=platforms, **({"wheels": wheels} if wheels else {}))
    if blender_range is not None:
        low, high = blender_range
        if _version(low) > _version(data["blender_version_min"]):
            expect["blender_version_min"] = low
            lines = [f"blender_version_min = {json.dumps(low)}\n" if re.match(r"blender_version_min\s*=", ln)
                     else ln for ln in lines]
        if high is not None:
            expect["blender_version_max"] = high
    first_table = next((i for i, ln in enumerate(lines) if re.match(r"\s*\[", ln)), len(lines))
    extra = ("# Added by tools/build_extension.py.\n"
             f"platforms = {toml_list(platforms)}\n")
    if wheels:
        extra += f"wheels = {toml_list(wheels)}\n"
    if "blender_version_max" in expect:
        extra += f"blender_version_max = {json.dumps(expect['blender_version_max'])}\n"
    text = "".join(lines[:first_table]) + extra + "\n" + "".join(lines[first_table:])
    check = tomllib.loads(text)
    if check != expect:
        raise BuildError("internal error: the staged manifest does not parse back to the source + additions")
    return text


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in text.split("."))


def stage(dest: Path, platforms: list[str], wheels: list[Path], pytag: str | None = None) -> Path:
    """The package staged in ``dest``; with ``pytag``, its manifest carries that Python's Blender range."""
    pkg = dest / PACKAGE
    shutil.copytree(ROOT / PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo",
                                                                       "blender_manifest.toml", "wheels"))
    if wheels:
        (pkg / "wheels").mkdir()
        for w in wheels:
            shutil.copy2(w, pkg / "wheels" / w.name)
    rel = [f"./wheels/{w.name}" for w in sorted(wheels, key=lambda p: p.name)]
    text = staged_manifest_text(MANIFEST.read_text(encoding="utf-8"), platforms, rel,
                                BLENDER_RANGE[pytag] if pytag else None)
    (pkg / "blender_manifest.toml").write_text(text, encoding="utf-8")
    return pkg


# ----------------------------------------------------------------------------------------------------------
# Checks on the built zips


def check_zip(bext, path: Path, platform: str, pytag: str | None, expected_wheels: list[Path]) -> dict:
    """Check a built zip (package at the root, no caches, exactly the expected wheels, all for ``platform`` and
    Python ``pytag``, the generated platform list, ``pytag``'s Blender range) and describe it for the summary."""
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
        unpacked = sum(i.file_size for i in zf.infolist())
        wheel_unpacked = 0
        for n in names:
            if n.endswith(".whl"):
                with zf.open(n) as fh, zipfile.ZipFile(fh) as wheel:
                    wheel_unpacked += sum(i.file_size for i in wheel.infolist())
    if "__init__.py" not in names:
        raise BuildError(f"{path.name}: no __init__.py at the archive root")
    if any("__pycache__" in n or n.endswith(".pyc") for n in names):
        raise BuildError(f"{path.name}: contains Python caches")
    zip_wheels = sorted(n for n in names if n.endswith(".whl"))
    want = sorted(f"wheels/{w.name}" for w in expected_wheels)
    if zip_wheels != want:
        raise BuildError(f"{path.name}: wheels {zip_wheels} != expected {want}")
    for n in zip_wheels:
        fields = wheel_fields(Path(n).name)
        if fields["name"] in NEVER_BUNDLE:
            raise BuildError(f"{path.name}: bundles {n} (Blender ships numpy)")
        if platform not in wheel_blender_platforms(bext, Path(n).name):
            raise BuildError(f"{path.name}: wheel {n} is not for {platform}")
        if pytag and pytag not in fields["python"].split("."):
            raise BuildError(f"{path.name}: wheel {n} is not for {pytag}")
    generated = manifest.get("build", {}).get("generated", {})
    if generated.get("platforms") != [platform]:
        raise BuildError(f"{path.name}: [build.generated] platforms = {generated.get('platforms')}")
    gen_wheels = sorted(w.removeprefix("./") for w in generated.get("wheels", []))
    if gen_wheels != want:
        raise BuildError(f"{path.name}: [build.generated] wheels {gen_wheels} != {want}")
    low, high = manifest["blender_version_min"], manifest.get("blender_version_max")
    if pytag and (_version(low) < _version(BLENDER_RANGE[pytag][0]) or high != BLENDER_RANGE[pytag][1]):
        raise BuildError(f"{path.name}: Blender range {low}..{high} is not {pytag}'s {BLENDER_RANGE[pytag]}")
    # Installed: the zip unpacked into extensions/<repo>/<id>/ (wheel files included) plus the wheels unpacked
    # into extensions/.local/lib/pythonX.Y/site-packages/.
    return {"platform": platform, "python": pytag, "blender_version_min": low, "blender_version_max": high,
            "zip": str(path), "bytes": path.stat().st_size, "installed_bytes": unpacked + wheel_unpacked,
            "wheels": [Path(n).name for n in zip_wheels]}


def zip_name(version: str, platform: str, pytag: str, without: set[str]) -> str:
    """``blender_shapesig-0.1.0-linux_x64-cp313.zip``; ``-lite`` without numba, ``-noiisignature`` without it."""
    suffix = "".join(s for s, w in (("-lite", "numba"), ("-noiisignature", "iisignature")) if w in without)
    return f"{PACKAGE}-{version}-{platform.replace('-', '_')}-{pytag}{suffix}.zip"


def build_python(bext, blender_ext: Path, tags: Path, tmp: Path, out: Path | None, pytag: str,
                 chosen: dict[tuple[str, str], list[Path]], without: set[str]) -> list[dict]:
    """Stage, validate and (with ``out``) build the zips of Python ``pytag``: one per platform that has its
    wheels, renamed to ``zip_name``, validated and checked. Returns their summaries."""
    platforms = [p for (p, t) in chosen if t == pytag]
    if not platforms:
        return []
    wheels = sorted({w for (p, t), ws in chosen.items() if t == pytag for w in ws}, key=lambda w: w.name)
    pkg = stage(tmp / pytag, platforms, wheels, pytag)
    proc = run_blender_ext(blender_ext, "validate", str(pkg), "--valid-tags", str(tags))
    if proc.returncode != 0:
        raise BuildError(f"Blender's validator rejected the staged {pytag} package")
    if out is None:
        return []
    version = tomllib.loads(MANIFEST.read_text(encoding="utf-8"))["version"]
    zips = {p: out / zip_name(version, p, pytag, without) for p in platforms}
    for z in zips.values():  # No stale zip may pass for this build's output.
        z.unlink(missing_ok=True)
    built = Path(tempfile.mkdtemp(prefix=".shapesig-build-", dir=out))  # same file system: renamed, not copied
    try:
        proc = run_blender_ext(blender_ext, "build", "--split-platforms", "--source-dir", str(pkg),
                               "--output-dir", str(built), "--valid-tags", str(tags))
        if proc.returncode != 0:
            raise BuildError(f"Blender's builder failed ({pytag})")
        summaries = []
        for p, z in zips.items():
            made = built / f"{PACKAGE}-{version}-{p.replace('-', '_')}.zip"  # the builder's own name
            if not made.is_file():
                raise BuildError(f"expected zip not built: {made.name} ({pytag})")
            os.replace(made, z)
            proc = run_blender_ext(blender_ext, "validate", str(z), "--valid-tags", str(tags))
            if proc.returncode != 0:
                raise BuildError(f"Blender's validator rejected {z.name}")
            summaries.append(check_zip(bext, z, p, pytag, chosen[(p, pytag)]))
        return summaries
    finally:
        shutil.rmtree(built, ignore_errors=True)


# ----------------------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="output folder for the zips")
    ap.add_argument("--platforms", default=",".join(PLATFORMS),
                    help=f"comma-separated Blender platforms (default: {','.join(PLATFORMS)})")
    ap.add_argument("--pythons", default=",".join(PYTHONS),
                    help=f"comma-separated Python tags, one zip each per platform (default: {','.join(PYTHONS)})")
    ap.add_argument("--wheel-cache", default=None, help="wheel cache folder (default ~/.cache/blender_shapesig/wheels)")
    ap.add_argument("--offline", action="store_true", help="use cached wheels only, never run pip download")
    ap.add_argument("--no-wheels", action="store_true",
                    help="bundle no wheels (the zips then need scipy from elsewhere; for manifest checks)")
    ap.add_argument("--without", default="", metavar="NAMES",
                    help="comma-separated optional wheels to leave out: numba (the '-lite' zips: numpy kernels, "
                         "no JIT), iisignature")
    ap.add_argument("--refresh", action="store_true", help="retry downloads that failed in an earlier build")
    ap.add_argument("--validate-only", action="store_true",
                    help="stage and run Blender's validator on the staged packages, build no zip")
    ap.add_argument("--blender-ext", default=None, help="path to Blender's bl_pkg/cli/blender_ext.py")
    ap.add_argument("--keep-stage", action="store_true", help="keep the staging folder (printed)")
    ap.add_argument("--json", action="store_true", help="print only the JSON summary on stdout")
    args = ap.parse_args(argv)

    t0 = time.monotonic()
    platforms = [p.strip() for p in args.platforms.split(",") if p.strip()]
    pythons = [p.strip() for p in args.pythons.split(",") if p.strip()]
    without = {w.strip() for w in args.without.split(",") if w.strip()}
    unknown = [p for p in platforms if p not in PLATFORMS]
    if unknown or not platforms:
        print(f"unknown platform(s) {unknown}; choose from {', '.join(PLATFORMS)}", file=sys.stderr)
        return 2
    if not pythons or set(pythons) - set(PYTHONS):
        print(f"--pythons takes {', '.join(PYTHONS)}, got {args.pythons!r}", file=sys.stderr)
        return 2
    if without - {"numba", "iisignature"}:
        print(f"--without takes numba and/or iisignature, got {sorted(without)}", file=sys.stderr)
        return 2
    try:
        blender_ext, tags = find_blender_ext(args.blender_ext)
        log(f"builder: {blender_ext}")
        bext = load_blender_ext(blender_ext)
        out = Path(args.out).resolve()
        cache = Path(args.wheel_cache) if args.wheel_cache else default_wheel_cache()

        wanted = [(p, t) for p in platforms for t in pythons]
        if args.no_wheels:
            chosen = {key: [] for key in wanted}
            notes = {key: ["no wheels (--no-wheels)"] for key in wanted}
        else:
            chosen, notes = collect_wheels(bext, cache, platforms, args.offline, without, args.refresh, pythons)
        if not chosen:
            raise BuildError("no platform has its required wheels: nothing to build")
        label = {key: f"{key[0]} {key[1]}" for key in wanted}
        summary = {"platforms": sorted({p for p, _ in chosen}, key=platforms.index), "pythons": pythons,
                   "left_out": {label[k]: notes[k] for k in wanted if k not in chosen},
                   "notes": {label[k]: notes[k] for k in wanted if k in chosen}, "zips": []}
        tmp = Path(tempfile.mkdtemp(prefix="shapesig-stage-"))
        try:
            if not args.validate_only:
                out.mkdir(parents=True, exist_ok=True)
            for pytag in pythons:
                summary["zips"] += build_python(bext, blender_ext, tags, tmp, None if args.validate_only else out,
                                                pytag, chosen, without)
            if args.keep_stage:
                summary["stage"] = str(tmp)
        finally:
            if not args.keep_stage:
                shutil.rmtree(tmp, ignore_errors=True)
    except BuildError as ex:
        print(f"build_extension: error: {ex}", file=sys.stderr)
        return 1
    summary["seconds"] = round(time.monotonic() - t0, 2)
    if not args.json:
        for z in summary["zips"]:
            print(f"{z['zip']}  {z['bytes'] / 1e6:.1f} MB (installed {z['installed_bytes'] / 1e6:.0f} MB)  "
                  f"Blender >= {z['blender_version_min']}{', < ' + z['blender_version_max'] if z['blender_version_max'] else ''}  "
                  f"wheels: {', '.join(z['wheels']) or '-'}")
        for key, why in summary["left_out"].items():
            print(f"{key}: {'; '.join(why)}")
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
