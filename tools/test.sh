#!/usr/bin/env bash
# The whole test suite: core tests (no bpy) and headless Blender tests (the bpy module).
#   bash tools/test.sh                    # Blender 5.0 (bpy 5.0.1) in .venv/, every test
#   SHAPESIG_BPY=4.2 bash tools/test.sh   # the Blender tests on 4.2 LTS, in .venv-bpy-4.2/
#   SHAPESIG_BPY=4.4 bash tools/test.sh   # the Blender tests on 4.4 (first slotted actions), in .venv-bpy-4.4/
#   SHAPESIG_BPY=4.5 bash tools/test.sh   # the Blender tests on 4.5 LTS, in .venv-bpy-4.5/
# Extra arguments go to pytest (e.g. -k signature, -x).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
case "${SHAPESIG_BPY:-}" in
  ""|5.0) venv="$root/.venv"; bpy=5.0.1; targets=(tests) ;;
  4.2)    venv="$root/.venv-bpy-4.2"; bpy=4.2.23; targets=(tests/blender) ;;
  4.4)    venv="$root/.venv-bpy-4.4"; bpy=4.4.0; targets=(tests/blender) ;;
  4.5)    venv="$root/.venv-bpy-4.5"; bpy=4.5.4; targets=(tests/blender) ;;
  *) echo "SHAPESIG_BPY must be 4.2, 4.4, 4.5 or 5.0 (got '${SHAPESIG_BPY}')" >&2; exit 2 ;;
esac
bash tools/setup_env.sh "$venv" "$bpy"
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then targets=(); fi
exec "$venv/bin/python" -m pytest -q "${targets[@]}" "$@"
