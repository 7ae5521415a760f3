#!/usr/bin/env python
"""Run a script or module with the local search's action part on (issue 41: ``local.DEFAULT.action_weight`` = 2,
the option ``core/search/local/action.py`` measures), so the command line's numbers can be taken with it:

  .venv/bin/python experiments/local_search/with_action.py experiments/rank_rigs.py --data ../shared/data/rigs
  .venv/bin/python experiments/local_search/with_action.py -m blender_shapesig evaluate --index ... --metrics local

Every call that uses the default settings object then uses the option (stored entries apart: its settings key
differs). ``--weight W`` (first) sets another weight.
"""

import os
import runpy
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)

from blender_shapesig.core.search.local import features as local  # noqa: E402


def main():
    args = sys.argv[1:]
    weight = 2.0
    if args[:1] == ["--weight"]:
        weight, args = float(args[1]), args[2:]
    local.DEFAULT.action_weight = weight
    if args[:1] == ["-m"]:
        sys.argv = [args[1]] + args[2:]
        runpy.run_module(args[1], run_name="__main__", alter_sys=True)
    else:
        sys.argv = args
        sys.path.insert(0, os.path.dirname(os.path.abspath(args[0])))
        runpy.run_path(args[0], run_name="__main__")


if __name__ == "__main__":
    main()
