#!/usr/bin/env bash
# The main job, headless on the bpy module: import the sample CMU clips, rank them against one query,
# make one time-aligned blend, save out/demo.blend and print a short report (also out/demo_report.md).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash tools/setup_env.sh
exec "$root/.venv/bin/python" tools/demo.py --data tests/data --out out "$@"
