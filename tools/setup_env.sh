#!/usr/bin/env bash
# Create (or reuse) a virtualenv with the pinned Blender-as-a-module and the numerical stack.
# Usage: tools/setup_env.sh [VENV_DIR] [BPY_VERSION]
#   VENV_DIR     default: .venv at the repository root
#   BPY_VERSION  default: 5.0.1 (Blender 5.0); 4.2.x / 4.5.x for the LTS test environments
# Idempotent: a stamp file records what was installed; nothing is reinstalled when it matches.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${1:-$root/.venv}"
bpy_version="${2:-5.0.1}"
py="${SHAPESIG_PYTHON:-python3.11}"
command -v "$py" >/dev/null 2>&1 || py=python3
stamp="$venv/.shapesig-env"
want="bpy=$bpy_version numpy=1.26.4 scipy=1.15.3 iisignature=0.24 numba=0.68.1 req=$(sha1sum "$root/tools/requirements-dev.txt" | cut -c1-12)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  exit 0
fi
echo "[setup] creating environment in $venv (bpy $bpy_version); this downloads ~400 MB the first time" >&2
"$py" -m venv "$venv"
pip="$venv/bin/python -m pip"
$pip install --quiet --upgrade pip >&2
# numpy first, pinned to what Blender bundles; setuptools and wheel so iisignature can build without isolation.
$pip install --quiet "numpy==1.26.4" "setuptools<75" wheel >&2
$pip install --quiet --no-build-isolation "iisignature==0.24" >&2
$pip install --quiet "bpy==$bpy_version" "scipy==1.15.3" "numba==0.68.1" -r "$root/tools/requirements-dev.txt" >&2
# bpy must not drag numpy past 2; fail loudly if something did.
"$venv/bin/python" - <<'PY'
import numpy, sys
assert numpy.__version__.startswith("1.26"), numpy.__version__
PY
echo "$want" > "$stamp"
