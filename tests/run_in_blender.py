"""Run the Blender tests inside an installed Blender:

    blender --background --factory-startup --python tests/run_in_blender.py [-- PYTEST-ARGS]

Blender's bundled Python needs pytest (and scipy, iisignature if the core tests are included):
    blender --background --python-expr "import ensurepip, subprocess, sys; ensurepip.bootstrap(); \
        subprocess.check_call([sys.executable, '-m', 'pip', 'install', 'pytest', 'scipy', 'hypothesis'])"
Exits Blender with pytest's exit code.
"""

import pathlib
import sys

root = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(root))

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
try:
    import pytest
except ImportError:
    print("pytest is not installed in Blender's Python; see the docstring of tests/run_in_blender.py",
          file=sys.stderr)
    sys.exit(2)

code = pytest.main(["-q", "-p", "no:cacheprovider", str(root / "tests" / "blender")] + args)
sys.exit(int(code))
