#!/usr/bin/env bash
# Create (or reuse) a virtualenv with the pinned Blender-as-a-module and the numerical stack.
# Usage: tools/setup_env.sh [VENV_DIR] [BPY_VERSION]
#   VENV_DIR     default: .venv at the repository root
#   BPY_VERSION  default: 5.2.3 (Blender 5.2 LTS); 5.1.x, 5.0.1, 4.5.x, 4.4.x, 4.2.x for the other test environments
# Each Blender line has its own Python and numerical stack, the ones Blender itself bundles:
#   Blender 5.1, 5.2 LTS        Python 3.13, numpy 2.3.5,  scipy 1.18.1, numba 0.68.1, iisignature 0.24
#   Blender 4.2 LTS .. 5.0      Python 3.11, numpy 1.26.4, scipy 1.15.3, numba 0.68.1, iisignature 0.24
# iisignature has only an sdist: it is built here against the pinned numpy (--no-build-isolation).
# The Python is found as $SHAPESIG_PYTHON, else pythonX.Y on PATH, else a pyenv-installed X.Y.
# Idempotent: a stamp file records what was installed; nothing is reinstalled when it matches, and a venv made
# for another Python or stack is rebuilt from scratch.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${1:-$root/.venv}"
bpy_version="${2:-5.2.3}"
case "$bpy_version" in
  5.1.*|5.2.*) pyver=3.13; numpy=2.3.5;  scipy=1.18.1; numba=0.68.1; iisig=0.24 ;;
  4.2.*|4.4.*|4.5.*|5.0.*) pyver=3.11; numpy=1.26.4; scipy=1.15.3; numba=0.68.1; iisig=0.24 ;;
  *) echo "[setup] no pinned stack for bpy $bpy_version (known: 4.2, 4.4, 4.5, 5.0, 5.1, 5.2)" >&2; exit 2 ;;
esac

# The interpreter: the right X.Y or nothing (a venv on the wrong Python cannot install bpy).
is_py() { "$@" -c "import sys; sys.exit(sys.version_info[:2] != tuple(map(int, '$pyver'.split('.'))))" >/dev/null 2>&1; }
py=()
if [ -n "${SHAPESIG_PYTHON:-}" ] && is_py "$SHAPESIG_PYTHON"; then py=("$SHAPESIG_PYTHON")
elif is_py "python$pyver"; then py=("python$pyver")
elif command -v pyenv >/dev/null 2>&1; then
  for v in $(pyenv versions --bare 2>/dev/null | grep -E "^$pyver(\.[0-9]+)?$" | sort -rV); do
    cand="$(pyenv root)/versions/$v/bin/python$pyver"
    if is_py "$cand"; then py=("$cand"); break; fi
  done
fi
if [ ${#py[@]} -eq 0 ]; then
  echo "[setup] bpy $bpy_version needs Python $pyver: install it (or set SHAPESIG_PYTHON to its interpreter)" >&2
  exit 2
fi

stamp="$venv/.shapesig-env"
want="python=$pyver bpy=$bpy_version numpy=$numpy scipy=$scipy iisignature=${iisig:-none} numba=$numba req=$(sha1sum "$root/tools/requirements-dev.txt" | cut -c1-12)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  exit 0
fi
if [ -e "$venv" ] && ! is_py "$venv/bin/python"; then
  if [ -L "$venv" ]; then
    echo "[setup] $venv is a symlink to an environment on another Python; not touching it (use another VENV_DIR)" >&2
    exit 2
  fi
  echo "[setup] $venv holds another Python; recreating it" >&2
  rm -rf "$venv"
fi
echo "[setup] creating environment in $venv (bpy $bpy_version, Python $pyver); this downloads ~400 MB the first time" >&2
"${py[@]}" -m venv "$venv"
pip="$venv/bin/python -m pip"
$pip install --quiet --upgrade pip >&2
# numpy first, pinned to what Blender bundles; setuptools and wheel so iisignature can build without isolation.
$pip install --quiet "numpy==$numpy" "setuptools<75" wheel >&2
if [ -n "$iisig" ]; then
  $pip install --quiet --no-build-isolation "iisignature==$iisig" >&2
fi
$pip install --quiet "bpy==$bpy_version" "numpy==$numpy" "scipy==$scipy" "numba==$numba" \
  -r "$root/tools/requirements-dev.txt" >&2
# Nothing may have moved numpy off Blender's version; fail loudly if something did.
"$venv/bin/python" - "$numpy" <<'PY'
import numpy, sys
assert numpy.__version__ == sys.argv[1], (numpy.__version__, sys.argv[1])
PY
echo "$want" > "$stamp"
