"""``python -m blender_shapesig``: the headless command line."""

import os
import sys

# One BLAS thread unless the user chose otherwise (before numpy is imported): the command line's matrix products are
# small (a clip's signature) or already spread over worker threads (the distance matrices); OpenBLAS's own threads
# made indexing ~5x slower on a busy 2-core machine (benchmarks/bench_cli.py, docs/search.md).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from .cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
