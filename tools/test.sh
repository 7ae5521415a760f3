#!/usr/bin/env bash
# The whole test suite: core tests (no bpy) and headless Blender tests (the bpy module).
#   bash tools/test.sh                    # Blender 5.2 LTS (bpy 5.2.3, Python 3.13, numpy 2) in .venv/, every test
#   SHAPESIG_BPY=5.1 bash tools/test.sh   # the Blender tests on 5.1 (Python 3.13), in .venv-bpy-5.1/
#   SHAPESIG_BPY=5.0 bash tools/test.sh   # Blender 5.0 (Python 3.11, numpy 1.26), every test, in .venv-bpy-5.0/
#   SHAPESIG_BPY=4.2 bash tools/test.sh   # the Blender tests on 4.2 LTS, in .venv-bpy-4.2/
#   SHAPESIG_BPY=4.4 bash tools/test.sh   # the Blender tests on 4.4 (first slotted actions), in .venv-bpy-4.4/
#   SHAPESIG_BPY=4.5 bash tools/test.sh   # the Blender tests on 4.5 LTS, in .venv-bpy-4.5/
# Each version has its own environment, Python and numerical stack (see tools/setup_env.sh).
# Extra arguments go to pytest (e.g. -k signature, -x).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
case "${SHAPESIG_BPY:-}" in
  ""|5.2) venv="$root/.venv"; bpy=5.2.3; targets=(tests) ;;
  5.1)    venv="$root/.venv-bpy-5.1"; bpy=5.1.2; targets=(tests/blender) ;;
  5.0)    venv="$root/.venv-bpy-5.0"; bpy=5.0.1; targets=(tests) ;;
  4.2)    venv="$root/.venv-bpy-4.2"; bpy=4.2.23; targets=(tests/blender) ;;
  4.4)    venv="$root/.venv-bpy-4.4"; bpy=4.4.0; targets=(tests/blender) ;;
  4.5)    venv="$root/.venv-bpy-4.5"; bpy=4.5.4; targets=(tests/blender) ;;
  *) echo "SHAPESIG_BPY must be 4.2, 4.4, 4.5, 5.0, 5.1 or 5.2 (got '${SHAPESIG_BPY}')" >&2; exit 2 ;;
esac
bash tools/setup_env.sh "$venv" "$bpy"
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then targets=(); fi
exec "$venv/bin/python" -m pytest -q "${targets[@]}" "$@"
