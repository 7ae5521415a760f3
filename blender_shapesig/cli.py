"""Command line (issue 8)."""

import sys


def main(argv=None):
    print("blender_shapesig: the command line is not implemented yet", file=sys.stderr)
    return 2
