#!/usr/bin/env python3
"""Install test: build the linux-x64 extension zips (one per Blender Python) and install them, as a user would,
into a clean Blender.

    .venv/bin/python tools/install_test.py                # bpy 5.2.3 LTS, 5.0.1 and 4.2.23 LTS: full, minimal, lite
    .venv/bin/python tools/install_test.py --bpy 5.0      # one version
    .venv/bin/python tools/install_test.py --zip A.zip --zip B.zip  # test given zips instead of building

For every Blender version the test uses its own throwaway virtualenv on that Blender's Python holding only
``bpy`` and the numpy Blender bundles (and bpy's own dependencies): ``.venv-install-5.2/`` (Python 3.13, numpy
2.3.5), ``.venv-install-5.0/`` and ``.venv-install-4.2/`` (Python 3.11, numpy 1.26.4) at the repository root,
created with pip on first use and reused afterwards (they are checked to contain no scipy, numba, llvmlite,
iisignature or blender_shapesig before every run). ``BLENDER_USER_RESOURCES`` points at a fresh temporary
folder, so nothing of the developer's Blender setup is used or touched. In that environment a child process

1. checks that scipy, numba, iisignature and blender_shapesig are not importable;
2. installs the other Python's zip (the one whose manifest range does not hold this Blender) and checks that
   Blender refuses it with one ERROR line naming the version range, installing nothing;
3. installs this Blender's zip with ``bpy.ops.extensions.package_install_files(repo="user_default",
   enable_on_install=True)`` (Blender extracts the bundled wheels into ``extensions/.local``) and measures what
   it put on disk;
4. checks that the add-on is enabled as ``bl_ext.user_default.blender_shapesig`` and that every bundled module
   (scipy; numba/llvmlite and iisignature when bundled) is imported from the temporary user resources, and that
   the ones not bundled stay unimportable (so the numpy fallbacks are what runs);
5. runs the operators: ``shapesig.import_acclaim`` on tests/data/acclaim/09_02.amc + 09-run.asf,
   ``shapesig.build_index``, ``shapesig.rank`` and ``shapesig.blend_actions``, and checks their results;
6. uninstalls the extension with ``extensions.package_uninstall``.

Three builds are tested: "full" (every wheel we ship for linux-x64: scipy, numba + llvmlite, iisignature) on every
Blender version, "minimal" (``--without numba,iisignature``: scipy only, what the windows and macOS lite zips
and macos-x64 carry; exercises the numba-free kernels and the numpy signatures inside Blender) on the first
version given and "lite" (``--without numba``, the ``-lite`` zip) on the last one.

The build (tools/build_extension.py) needs pip and bpy (any development venv) and Python 3.11 and 3.13 on the
machine, to compile the iisignature wheels. Exit code 0 when every check passed, 1 when one failed, 2 on a usage/setup error.
Operators that the add-on does not register are reported as skipped (with the reason) only with
``--allow-missing-operators``; by default a missing operator is a failure.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# Blender line -> (bpy, its Python, the numpy it bundles); the first is the current LTS.
BPY_VERSIONS = {"5.2": ("5.2.3", "3.13", "2.3.5"), "5.0": ("5.0.1", "3.11", "1.26.4"),
                "4.2": ("4.2.23", "3.11", "1.26.4")}
# Blender line -> the Python tag of its zip.
PYTAGS = {v: "cp" + py.replace(".", "") for v, (_, py, _) in BPY_VERSIONS.items()}
MUST_BE_ABSENT = ("scipy", "numba", "llvmlite", "iisignature", "blender_shapesig")
RESULT_PREFIX = "INSTALL_TEST_RESULT "
EXT_ID = "blender_shapesig"
ADDON_MODULE = f"bl_ext.user_default.{EXT_ID}"
OPERATORS = ("import_acclaim", "build_index", "rank", "blend_actions")


class SetupError(Exception):
    """The test could not be set up (venv, build): exit code 2."""


def log(msg: str) -> None:
    print(f"[install_test] {msg}", file=sys.stderr, flush=True)


# ==========================================================================================================
# Parent side: venvs, build, run the child, report.


def clean_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if k not in {"PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "VIRTUAL_ENV"}
           and not k.startswith(("BLENDER_", "SHAPESIG_"))}
    env["PYTHONNOUSERSITE"] = "1"
    env.update(extra or {})
    return env


def _build_module():
    """tools/build_extension.py as a module (one owner of the wheel pins and of finding a Python X.Y)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_shapesig_build_extension", ROOT / "tools" / "build_extension.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def ensure_venv(venv: Path, version: str) -> Path:
    """A virtualenv on Blender ``version``'s Python with only its bpy and numpy (plus bpy's dependencies).
    Returns its python."""
    bpy_version, python_version, numpy_version = BPY_VERSIONS[version]
    python = venv / "bin" / "python"
    stamp = venv / ".shapesig-install-env"
    want = f"python={python_version} bpy={bpy_version} numpy={numpy_version}"
    if not (stamp.is_file() and stamp.read_text().strip() == want and python.exists()):
        base = _build_module().find_python(python_version)
        if base is None:
            raise SetupError(f"bpy {bpy_version} needs Python {python_version}: install it "
                             f"(or set SHAPESIG_PYTHON_{python_version.replace('.', '_')})")
        log(f"creating {venv} with bpy=={bpy_version} numpy=={numpy_version} on Python {python_version} "
            "(first run downloads bpy, ~1-4 min)")
        t0 = time.monotonic()
        if venv.exists():
            shutil.rmtree(venv)
        for cmd in ([base, "-m", "venv", str(venv)],
                    [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                     f"bpy=={bpy_version}", f"numpy=={numpy_version}"]):
            proc = subprocess.run(cmd, capture_output=True, text=True, env=clean_env())
            if proc.returncode != 0:
                sys.stderr.write(proc.stdout + proc.stderr)
                raise SetupError(f"could not create {venv} ({' '.join(cmd)})")
        stamp.write_text(want + "\n")
        log(f"  venv ready in {time.monotonic() - t0:.0f}s")
    probe = ("import importlib.util, json, sys; "
             f"print(json.dumps([m for m in {list(MUST_BE_ABSENT)!r} if importlib.util.find_spec(m)]))")
    proc = subprocess.run([str(python), "-c", probe], capture_output=True, text=True, env=clean_env(),
                          cwd=tempfile.gettempdir())
    present = json.loads(proc.stdout.strip().splitlines()[-1]) if proc.returncode == 0 else None
    if present is None:
        raise SetupError(f"cannot run {python}: {proc.stderr.strip()}")
    if present:
        raise SetupError(f"{venv} is not clean, it can import {present}; delete it to recreate")
    return python


def build_zips(out: Path, without: str) -> dict[str, Path]:
    """The linux-x64 zips, one per Blender Python: {python tag: zip}, each checked to bundle only its Python's
    wheels (scipy, plus numba + llvmlite and iisignature unless ``without`` leaves them out)."""
    cmd = [sys.executable, str(ROOT / "tools" / "build_extension.py"), "--out", str(out),
           "--platforms", "linux-x64", "--json"]
    if without:
        cmd += ["--without", without]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SetupError(f"building the zips failed ({' '.join(cmd)})")
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    zips = {z["python"]: z for z in summary["zips"]}
    if sorted(zips) != sorted(set(PYTAGS.values())) or len(summary["zips"]) != len(zips):
        raise SetupError(f"expected one linux-x64 zip per Python {sorted(set(PYTAGS.values()))}, got {summary['zips']}")
    left = set(without.split(",")) if without else set()
    want = {"scipy"} | ({"numba", "llvmlite"} - ({"numba", "llvmlite"} if "numba" in left else set())) \
        | ({"iisignature"} - left)
    for tag, z in sorted(zips.items()):
        log(f"built {Path(z['zip']).name} ({z['bytes'] / 1e6:.1f} MB, {z['installed_bytes'] / 1e6:.0f} MB unpacked)"
            f" in {time.monotonic() - t0:.1f}s")
        dists = {w.split("-")[0] for w in z["wheels"]}
        if dists != want:
            raise SetupError(f"{Path(z['zip']).name} bundles {sorted(dists)}, expected {sorted(want)} "
                             f"({summary['notes']}); the machine needs Python 3.11 and 3.13 to build iisignature")
        if {w.split("-")[-3] for w in z["wheels"]} != {tag}:
            raise SetupError(f"{Path(z['zip']).name} has wheels {z['wheels']}, expected only {tag} ones")
    return {tag: Path(z["zip"]) for tag, z in zips.items()}


def zip_fits(zip_path: Path, bpy_version: str) -> bool:
    """Whether the zip's manifest range (blender_version_min <= version < blender_version_max) holds this Blender."""
    manifest = _zip_manifest(zip_path)
    v = tuple(int(x) for x in bpy_version.split("."))
    low = tuple(int(x) for x in manifest["blender_version_min"].split("."))
    high = manifest.get("blender_version_max")
    return low <= v and (high is None or v < tuple(int(x) for x in high.split(".")))


def run_child(python: Path, zip_path: Path, label: str, allow_missing: bool, keep: bool,
              wrong_zip: Path | None = None) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix=f"shapesig-install-{label}-"))
    try:
        user = tmp / "user"
        user.mkdir()
        work = tmp / "work"
        shutil.copytree(ROOT / "tests" / "data", work / "data")
        cmd = [str(python), str(Path(__file__).resolve()), "--child", "--zip", str(zip_path),
               "--work", str(work)]
        if allow_missing:
            cmd.append("--allow-missing-operators")
        if wrong_zip is not None:
            cmd += ["--wrong-zip", str(wrong_zip)]
        t0 = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=str(work),
                              env=clean_env({"BLENDER_USER_RESOURCES": str(user)}), timeout=1800)
        seconds = time.monotonic() - t0
        result = None
        for line in proc.stdout.splitlines():
            if line.startswith(RESULT_PREFIX):
                result = json.loads(line[len(RESULT_PREFIX):])
        if result is None:
            result = {"ok": False, "checks": [], "error": "the child printed no result"}
        if not result["ok"] or proc.returncode != 0:
            result["ok"] = False
            sys.stderr.write(proc.stdout[-6000:])
            sys.stderr.write(proc.stderr[-6000:])
            sys.stderr.write(f"[install_test] the child exited with {proc.returncode}\n")
        result["seconds"] = round(seconds, 1)
        result["label"] = label
        result.setdefault("installed_bytes", None)
        return result
    finally:
        if keep:
            log(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--work", help=argparse.SUPPRESS)
    ap.add_argument("--bpy", default=",".join(BPY_VERSIONS),
                    help=f"Blender versions, comma-separated: {', '.join(BPY_VERSIONS)} (default all)")
    ap.add_argument("--bpy-venv", default=None,
                    help="use this venv (must hold only bpy + numpy) instead of .venv-install-X.Y; one --bpy only")
    ap.add_argument("--zip", action="append", default=[],
                    help="install this zip instead of building the full ones (repeat it: each Blender version takes "
                         "the zip whose manifest range holds it, another one is checked to be refused)")
    ap.add_argument("--wrong-zip", help=argparse.SUPPRESS)
    ap.add_argument("--no-minimal", action="store_true", help="skip the numba-free zips (lite and scipy-only)")
    ap.add_argument("--out", default=str(ROOT / "build" / "install-test"), help="where to build the zips")
    ap.add_argument("--allow-missing-operators", action="store_true",
                    help="report operators the add-on does not register as skipped instead of failing")
    ap.add_argument("--keep", action="store_true", help="keep the temporary user resources folders")
    args = ap.parse_args(argv)
    if args.child:
        code = child_main(Path(args.zip[0]), Path(args.work), args.allow_missing_operators,
                          Path(args.wrong_zip) if args.wrong_zip else None)
        # The verdict is printed; leave without the interpreter's teardown: the bpy module of Blender 4.2 can crash
        # there (segfault after the checks, seen once an add-on with property groups was loaded), which would hide
        # a passing run. A crash during the checks still shows as a missing result or a non-zero exit.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)

    t_start = time.monotonic()
    versions = [v.strip() for v in args.bpy.split(",") if v.strip()]
    if not versions or any(v not in BPY_VERSIONS for v in versions):
        print(f"--bpy takes {', '.join(BPY_VERSIONS)}", file=sys.stderr)
        return 2
    if missing := [z for z in args.zip if not Path(z).is_file()]:
        print(f"--zip {missing[0]}: no such file", file=sys.stderr)
        return 2
    if args.bpy_venv and len(versions) != 1:
        print("--bpy-venv needs exactly one --bpy version", file=sys.stderr)
        return 2
    try:
        return _run(args, versions, t_start)
    except SetupError as ex:
        print(f"install_test: setup error: {ex}", file=sys.stderr)
        return 2


def _run(args, versions: list[str], t_start: float) -> int:
    out = Path(args.out)
    given = [Path(z).resolve() for z in args.zip]
    full = given or list(build_zips(out / "full", "").values())
    extra = []  # (label, zips): the numba-free zips, on one Blender each (the first and the last version given)
    if not (args.no_minimal or given):
        extra = [("lite", build_zips(out / "lite", "numba")), ("minimal", build_zips(out / "minimal",
                                                                                    "numba,iisignature"))]
    results = []
    for i, v in enumerate(versions):
        bpy_version = BPY_VERSIONS[v][0]
        venv = Path(args.bpy_venv) if args.bpy_venv else ROOT / f".venv-install-{v}"
        fitting = [z for z in full if zip_fits(z, bpy_version)]
        wrong = next((z for z in full if not zip_fits(z, bpy_version)), None)
        if len(fitting) != 1:
            raise SetupError(f"Blender {bpy_version} needs exactly one zip whose range holds it, got "
                             f"{[z.name for z in fitting]} of {[z.name for z in full]}")
        python = ensure_venv(venv, v)
        runs = [("full", fitting[0], wrong)]
        if i == 0 and extra:
            runs.append(("minimal", extra[1][1][PYTAGS[v]], None))
        if i == len(versions) - 1 and extra:
            runs.append(("lite", extra[0][1][PYTAGS[v]], None))
        for label, zip_path, wrong_zip in runs:
            log(f"bpy {bpy_version}: installing {zip_path.name} ({label})"
                + (f", after {wrong_zip.name} (must be refused)" if wrong_zip else ""))
            r = run_child(python, zip_path, f"{v}-{label}", args.allow_missing_operators, args.keep, wrong_zip)
            r["bpy"] = bpy_version
            r["zip"] = zip_path.name
            results.append(r)
            for c in r["checks"]:
                mark = {"pass": "ok  ", "fail": "FAIL", "skip": "skip"}[c["status"]]
                log(f"  {mark} {c['name']}: {c.get('detail', '')}")
            if r.get("error"):
                log(f"  FAIL {r['error']}")
            log(f"  {'passed' if r['ok'] else 'FAILED'} in {r['seconds']}s")
    total = time.monotonic() - t_start
    ok = all(r["ok"] for r in results)
    skipped = sorted({c["name"] for r in results for c in r["checks"] if c["status"] == "skip"})
    print(json.dumps({"ok": ok, "seconds": round(total, 1), "skipped": skipped,
                      "runs": [{k: r.get(k) for k in ("label", "bpy", "zip", "ok", "seconds", "installed_bytes")}
                               for r in results]}))
    log(f"{'PASSED' if ok else 'FAILED'}: {len(results)} install run(s) in {total:.0f}s"
        + (f"; skipped: {', '.join(skipped)}" if skipped else ""))
    return 0 if ok else 1


# ==========================================================================================================
# Child side: runs inside the clean bpy venv with BLENDER_USER_RESOURCES set. Imports nothing from the repo.


class Checks:
    def __init__(self):
        self.items: list[dict] = []
        self.timings: dict[str, float] = {}
        self.installed: int | None = None  # bytes on disk after the install: the extension + its wheels

    def add(self, name: str, ok: bool, detail: str = "") -> bool:
        self.items.append({"name": name, "status": "pass" if ok else "fail", "detail": detail})
        return ok

    def skip(self, name: str, reason: str) -> None:
        self.items.append({"name": name, "status": "skip", "detail": reason})


def _under(path: str | None, root: Path) -> bool:
    if not path:
        return False
    try:
        Path(path).resolve().relative_to(root.resolve())
        return True
    except ValueError:
        return False


def _zip_manifest(zip_path: Path) -> dict:
    import tomllib
    import zipfile

    with zipfile.ZipFile(zip_path) as zf:
        return tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))


def _operator_registered(bpy, name: str) -> bool:
    try:
        getattr(bpy.ops.shapesig, name).get_rna_type()
        return True
    except KeyError:
        return False


def child_main(zip_path: Path, work: Path, allow_missing: bool, wrong_zip: Path | None = None) -> int:
    # The script's folder (tools/) must not shadow anything; the repository must not be importable.
    sys.path[:] = [p for p in sys.path if p and Path(p).resolve() != Path(__file__).resolve().parent]
    import importlib.util

    ck = Checks()
    error = None
    try:
        present = [m for m in MUST_BE_ABSENT if importlib.util.find_spec(m) is not None]
        ck.add("clean environment", not present, f"importable before install: {present}" if present else
               "scipy, numba, llvmlite, iisignature, blender_shapesig not importable")
        if present:
            raise RuntimeError("environment not clean")
        user = Path(os.environ["BLENDER_USER_RESOURCES"])
        t0 = time.monotonic()
        import bpy

        ck.timings["import_bpy"] = time.monotonic() - t0
        ck.add("bpy", True, f"Blender {bpy.app.version_string}")
        ext_dir = Path(bpy.utils.user_resource("EXTENSIONS"))
        ck.add("user resources", _under(str(ext_dir), user), str(ext_dir))
        if wrong_zip is not None:
            run_refused(bpy, ck, wrong_zip, ext_dir)
        run_install(bpy, ck, zip_path, user)
        run_operators(bpy, ck, work, allow_missing)
        run_uninstall(bpy, ck, ext_dir)
    except Exception as ex:  # report, never hide
        import traceback

        traceback.print_exc()
        error = f"{type(ex).__name__}: {ex}"
    ok = error is None and all(c["status"] != "fail" for c in ck.items)
    print(RESULT_PREFIX + json.dumps({"ok": ok, "error": error, "checks": ck.items, "installed_bytes": ck.installed,
                                      "timings": {k: round(v, 2) for k, v in ck.timings.items()}}), flush=True)
    return 0 if ok else 1


def _disk_bytes(root: Path) -> int:
    return sum(p.stat().st_size for p in root.rglob("*") if p.is_file() and not p.is_symlink()) if root.is_dir() else 0


def run_refused(bpy, ck: Checks, zip_path: Path, ext_dir: Path) -> None:
    """The other Python's zip: Blender refuses it with one ERROR line (its version range or Python) and installs
    nothing."""
    import contextlib
    import io

    before = _disk_bytes(ext_dir / ".local")  # the wheels' folder (Blender also writes its own caches)
    said = io.StringIO()
    with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):  # bl_pkg prints its reports
        try:
            result = bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default",
                                                              enable_on_install=True)
        except RuntimeError as ex:  # an ERROR report raised by bpy.ops
            result = {"CANCELLED"}
            print(str(ex).strip())
    errors = [ln.strip() for ln in said.getvalue().splitlines() if ln.lstrip().startswith("ERROR")]
    reasons = ("must be less than the maximum version", "doesn't meet the minimum supported version",
               "isn't compatible with")
    installed = ADDON_MODULE in [a.module for a in bpy.context.preferences.addons] or any(
        (Path(r.directory) / EXT_ID).exists() for r in bpy.context.preferences.extensions.repos if r.directory)
    ck.add(f"refuses {zip_path.name}", len(errors) == 1 and any(r in errors[0] for r in reasons)
           and not installed and _disk_bytes(ext_dir / ".local") == before,
           f"{result}, Blender said {errors!r}; {'INSTALLED' if installed else 'nothing installed'}")


def run_install(bpy, ck: Checks, zip_path: Path, user: Path) -> None:
    repos = {r.module: r for r in bpy.context.preferences.extensions.repos}
    if not ck.add("repository user_default", "user_default" in repos, f"repos: {sorted(repos)}"):
        raise RuntimeError("no user_default repository")
    manifest = _zip_manifest(zip_path)
    wheels = [Path(w).name for w in manifest.get("build", {}).get("generated", {}).get("wheels", [])]
    t0 = time.monotonic()
    result = bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo="user_default",
                                                      enable_on_install=True)
    ck.timings["install"] = time.monotonic() - t0
    ck.add("package_install_files", result == {"FINISHED"}, f"{result} in {ck.timings['install']:.1f}s")
    addons = [a.module for a in bpy.context.preferences.addons]
    ck.add("add-on enabled", ADDON_MODULE in addons, ADDON_MODULE)
    ext_root = Path(bpy.utils.user_resource("EXTENSIONS"))
    ck.installed = _disk_bytes(ext_root / "user_default" / EXT_ID) + _disk_bytes(ext_root / ".local")
    ck.add("installed size", ck.installed > 0, f"{ck.installed / 1e6:.0f} MB (the extension's folder + "
           "extensions/.local)")
    mod = sys.modules.get(ADDON_MODULE)
    pkg_dir = Path(repos["user_default"].directory) / EXT_ID
    ck.add("add-on files", mod is not None and _under(getattr(mod, "__file__", None), pkg_dir),
           str(getattr(mod, "__file__", None)))

    # Blender installs only the wheels of its own Python (cp311 on 4.2-5.0, cp313 on 5.1+).
    pytag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    bundled = {w.split("-")[0].lower() for w in wheels if pytag in w.split("-")[-3].split(".")}
    ck.add(f"wheels in zip for {pytag}", "scipy" in bundled and "numpy" not in bundled, ", ".join(sorted(wheels)))
    local = user  # Blender extracts wheels into <user resources>/extensions/.local/lib/pythonX.Y/site-packages
    for name in ("scipy", "numba", "llvmlite", "iisignature"):
        if name in bundled:
            try:
                m = __import__(name)
                where = getattr(m, "__file__", None)
                ck.add(f"{name} from the extension's wheel", _under(where, local) and ".local" in Path(where).parts,
                       f"{name} {getattr(m, '__version__', '?')} at {where}")
            except Exception as ex:
                ck.add(f"{name} from the extension's wheel", False, f"import failed: {type(ex).__name__}: {ex}")
        else:
            spec = importlib_find(name)
            ck.add(f"{name} not bundled", spec is None, "not importable: the numpy fallback runs" if spec is None
                   else f"importable from {spec}")
    import numpy

    ck.add("numpy is Blender's", not _under(numpy.__file__, user), f"numpy {numpy.__version__} at {numpy.__file__}")
    # The add-on sees exactly the optional modules that were bundled (else it uses its numpy fallbacks).
    import importlib

    for module, flag, dist in (("core.signatures.signatures", "HAVE_IISIGNATURE", "iisignature"),
                               ("core.elastic._dp_kernels", "HAVE_NUMBA", "numba")):
        try:
            have = getattr(importlib.import_module(f"{ADDON_MODULE}.{module}"), flag)
        except Exception as ex:
            ck.add(f"{flag}", False, f"{ADDON_MODULE}.{module}.{flag}: {type(ex).__name__}: {ex}")
            continue
        ck.add(f"{flag}", have == (dist in bundled),
               f"{have} ({dist} {'bundled' if dist in bundled else 'not bundled: numpy fallback'})")


def importlib_find(name: str):
    import importlib.util

    spec = importlib.util.find_spec(name)
    return None if spec is None else (spec.origin or str(spec.submodule_search_locations))


def _new_armatures(bpy, before):
    return [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]


def _frames(action) -> int:
    start, end = action.frame_range
    return int(round(end - start)) + 1


def _amc_frames(path: Path) -> int:
    return sum(1 for ln in path.read_text().splitlines() if ln.strip().isdigit())


def run_operators(bpy, ck: Checks, work: Path, allow_missing: bool) -> None:
    missing = [op for op in OPERATORS if not _operator_registered(bpy, op)]
    for op in missing:
        reason = f"operator shapesig.{op} is not registered by the installed add-on (not implemented yet)"
        if allow_missing:
            ck.skip(f"shapesig.{op}", reason)
        else:
            ck.add(f"shapesig.{op}", False, reason)
    if "import_acclaim" in missing:
        for op in OPERATORS[1:]:
            if op not in missing:
                ck.add(f"shapesig.{op}", False, "not run: it needs shapesig.import_acclaim")
        return
    acclaim = work / "data" / "acclaim"
    amc, amc2, asf = acclaim / "09_02.amc", acclaim / "09_03.amc", acclaim / "09-run.asf"

    # 1. The documented call: one .amc with its skeleton.
    bpy.ops.wm.read_homefile(use_empty=True)  # keeps the preferences (enabled add-ons)
    before = set(bpy.data.objects)
    t0 = time.monotonic()
    result = bpy.ops.shapesig.import_acclaim(filepath=str(amc), asf_path=str(asf))
    ck.timings["import_acclaim"] = time.monotonic() - t0
    arm = _new_armatures(bpy, before)
    action = arm[0].animation_data.action if arm and arm[0].animation_data else None
    frames = _frames(action) if action is not None else None
    ck.add("shapesig.import_acclaim", result == {"FINISHED"} and len(arm) == 1 and action is not None
           and len(arm[0].data.bones) > 20 and frames == _amc_frames(amc),
           f"{result}, armature {[o.name for o in arm]}, {len(arm[0].data.bones) if arm else 0} bones, "
           f"action {action.name if action else None} with {frames} frames (AMC: {_amc_frames(amc)}) "
           f"in {ck.timings['import_acclaim']:.1f}s")

    # 2. Two motions on one armature (the Import dialog's multi-selection), then blend them.
    bpy.ops.wm.read_homefile(use_empty=True)  # keeps the preferences (enabled add-ons)
    before, acts_before = set(bpy.data.objects), set(bpy.data.actions)
    result = bpy.ops.shapesig.import_acclaim(filepath=str(amc), directory=str(acclaim), asf_path=str(asf),
                                             files=[{"name": amc.name}, {"name": amc2.name}])
    arm = _new_armatures(bpy, before)
    acts = sorted((a for a in bpy.data.actions if a not in acts_before), key=lambda a: a.name)
    ck.add("import two motions", result == {"FINISHED"} and len(arm) == 1 and len(acts) == 2,
           f"{result}, {len(arm)} armature(s), actions {[a.name for a in acts]}")
    search_ops(bpy, ck, work, missing)
    blend_file_clips(bpy, ck, work)
    if "blend_actions" in missing or len(arm) != 1 or len(acts) != 2:
        if "blend_actions" not in missing:
            ck.add("shapesig.blend_actions", False, "not run: the two-motion import failed")
        return
    obj = arm[0]
    bpy.context.view_layer.objects.active = obj
    a, b = acts
    fa, fb = _frames(a), _frames(b)
    acts_before = set(bpy.data.actions)
    t0 = time.monotonic()
    result = bpy.ops.shapesig.blend_actions(action_a=a.name, action_b=b.name, weight=0.5, align=True)
    ck.timings["blend_actions"] = time.monotonic() - t0
    new = [x for x in bpy.data.actions if x not in acts_before]
    fn = _frames(new[0]) if len(new) == 1 else None
    current = obj.animation_data.action if obj.animation_data else None
    # the blend is keyed at the scene's rate: its length lies between the sources' durations in scene frames
    scene_fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    span = [(f - 1) / float(x.get("shapesig_fps", scene_fps)) * scene_fps + 1 for f, x in ((fa, a), (fb, b))]
    ck.add("shapesig.blend_actions", result == {"FINISHED"} and len(new) == 1 and fn is not None
           and min(span) - 1 <= fn <= max(span) + 1 and current == new[0]
           and _frames(a) == fa and _frames(b) == fb,
           f"{result}, new {[x.name for x in new]} with {fn} frames at {scene_fps:g} fps (A {fa}, B {fb} at their "
           f"rates: {span[0]:.1f} and {span[1]:.1f} scene frames), assigned {current.name if current else None}, "
           f"in {ck.timings['blend_actions']:.1f}s")


def search_ops(bpy, ck: Checks, work: Path, missing: list[str]) -> None:
    """build_index then rank, on the active armature (query: its action 09_02), with a library of the file's
    other action (09_03) and two folders of .amc clips (07: two walks; 09: the run 09_03 again)."""
    if "build_index" in missing and "rank" in missing:
        return
    acclaim = work / "data" / "acclaim"
    lib = work / "library"
    for sub, files in (("07", ("07-walk.asf", "07_01.amc", "07_02.amc")), ("09", ("09-run.asf", "09_03.amc"))):
        (lib / sub).mkdir(parents=True, exist_ok=True)
        for f in files:
            shutil.copy2(acclaim / f, lib / sub / f)
    obj = bpy.context.view_layer.objects.active
    s = bpy.context.scene.shapesig
    s.query_action = "09_02"
    s.use_file_actions = True
    s.use_folders = True
    s.folders = f"{lib / '07'};{lib / '09'}"
    user = Path(os.environ["BLENDER_USER_RESOURCES"])
    # the index folder is the command line's per-user default (shared by panel and CLI); keep it inside the
    # throwaway user folder through $SHAPESIG_CACHE_DIR, as a user moving it would
    os.environ["SHAPESIG_CACHE_DIR"] = str(user / "shapesig-cache")
    expected = 5  # the query + 09_03 (action) + 07_01, 07_02, 09_03 (files)
    if "build_index" not in missing:
        t0 = time.monotonic()
        result = bpy.ops.shapesig.build_index()
        ck.timings["build_index"] = time.monotonic() - t0
        # the cache writes only in its own subfolder: per clip a signature entry and a local-search entry
        cache = Path(os.environ["SHAPESIG_CACHE_DIR"]) / "blender_shapesig-cache"
        files = sorted(cache.glob("*.npz")) if cache.is_dir() else []
        ck.add("shapesig.build_index", result == {"FINISHED"} and f"{expected} computed" in bpy.context.window_manager.shapesig_results.message
               and len(files) == 2 * expected and _under(str(cache), user),
               f"{result}, {bpy.context.window_manager.shapesig_results.message!r}, {len(files)} index files in {cache}, "
               f"in {ck.timings['build_index']:.1f}s")
    if "rank" in missing:
        return
    t0 = time.monotonic()
    result = bpy.ops.shapesig.rank()
    ck.timings["rank"] = time.monotonic() - t0
    rows = [(r.name, r.distance, r.is_action) for r in bpy.context.window_manager.shapesig_results.results]
    dist = [d for _, d, _ in rows]
    # rows follow one sort column: d_S* where re-ranked, else sim^n
    order = [r.elastic if r.has_elastic else r.distance for r in bpy.context.window_manager.shapesig_results.results]
    names = [n for n, _, _ in rows]
    runs = [d for n, d, _ in rows if n.startswith("09_03")]
    walks = [d for n, d, _ in rows if n.startswith("07_")]
    ok = (result == {"FINISHED"} and len(rows) == expected - 1 and order == sorted(order)
          and all(d == d and d >= 0 for d in dist) and set(names[:2]) == {"09_03"} and len(runs) == 2
          and max(runs) < min(walks) and bpy.context.window_manager.shapesig_results.query_name == "09_02")
    if "build_index" not in missing:
        ok = ok and "0 newly indexed" in bpy.context.window_manager.shapesig_results.message
    ck.add("shapesig.rank", ok, f"{result}, {[(n, round(d, 4), 'action' if a else 'file') for n, d, a in rows]}, "
           f"{bpy.context.window_manager.shapesig_results.message!r}, in {ck.timings['rank']:.1f}s")
    bpy.context.view_layer.objects.active = obj


def blend_file_clips(bpy, ck: Checks, work: Path) -> None:
    """core.io.sources.read on a saved .blend: read in a child process (the installed package imported there by its
    folder, with the extension's wheels), the clips back here."""
    import importlib

    path = work / "library.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True, compress=False)
    t0 = time.monotonic()
    try:
        got = importlib.import_module(f"{ADDON_MODULE}.core.io.sources").read(str(path))
        names = sorted(c.name for c in got)
        ok = len(got) >= 2 and all(c.rotations.shape[1] > 0 for c in got)
        detail = f"{names}"
    except Exception as exc:  # noqa: BLE001 - reported as a failed check
        ok, detail = False, f"{type(exc).__name__}: {exc}"
    ck.timings["load_blend"] = time.monotonic() - t0
    ck.add("sources.read(.blend) in a child process", ok, f"{detail}, in {ck.timings['load_blend']:.1f}s")


def run_uninstall(bpy, ck: Checks, ext_dir: Path) -> None:
    repos = list(bpy.context.preferences.extensions.repos)
    index = next(i for i, r in enumerate(repos) if r.module == "user_default")
    result = bpy.ops.extensions.package_uninstall(repo_index=index, pkg_id=EXT_ID)
    pkg_dir = Path(repos[index].directory) / EXT_ID
    addons = [a.module for a in bpy.context.preferences.addons]
    ck.add("package_uninstall", result == {"FINISHED"} and not pkg_dir.exists() and ADDON_MODULE not in addons,
           f"{result}, folder {'still there' if pkg_dir.exists() else 'removed'}")


if __name__ == "__main__":
    sys.exit(main())
