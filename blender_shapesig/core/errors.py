"""Exception types of blender_shapesig.

Every error that bad input can cause is one of these, with a one-line message that names the
input and what is wrong with it. Callers (operators, the command line) show ``str(error)``.
"""


class ShapeSigError(ValueError):
    """Base class: invalid input or a computation that cannot proceed."""


class CurveError(ShapeSigError):
    """A curve, time grid or warp has the wrong shape or non-finite values."""


class ParseError(ShapeSigError):
    """A motion file (ASF, AMC, BVH, .blend) could not be read."""

    def __init__(self, message, path=None, line=None):
        where = ""
        if path is not None:
            where = f"{path}"
            if line is not None:
                where += f":{line}"
            where += ": "
        super().__init__(where + message)
        self.path = path
        self.line = line
