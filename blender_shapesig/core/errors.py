"""Exception types of blender_shapesig.

Every error that bad input can cause is one of these, with a one-line message that names the
input and what is wrong with it. Callers (operators, the command line) show ``str(error)``.
"""

import math


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


class UnreadableFileError(ParseError):
    """A file the readers do not open (``core.io.files``): not a regular file (a FIFO, a device, a socket, a dangling
    or looping link), unreadable, or over a size cap. Libraries skip such files and report them once."""


class Cancelled(ShapeSigError):
    """The caller cancelled a computation through its ``progress`` callback (``core.progress``)."""

    def __init__(self, message="cancelled"):
        super().__init__(message)


def error_line(exc) -> str:
    """Any exception as one line for a user (the operators' reports, the command line's stderr): a ShapeSigError's
    message, an OSError's file and reason, "out of memory", a removed Blender data-block said so, else "internal error" and the message (no
    Python type name); whitespace collapsed (the traceback goes to the console or ``--debug``)."""
    if isinstance(exc, ShapeSigError):
        text = str(exc)
    elif isinstance(exc, OSError):
        text = f"{exc.filename or ''}: {exc.strerror or exc}".lstrip(": ")
    elif isinstance(exc, MemoryError):
        text = f"out of memory{': ' + str(exc) if str(exc) else ''}"
    elif isinstance(exc, ReferenceError):
        text = f"data it was using was removed meanwhile ({exc})"
    else:
        text = f"internal error ({exc}); the console has the details" if str(exc).strip() else \
            "internal error; the console has the details"
    return " ".join(text.split()) or "internal error"


def check_integer(value, name, minimum=1, allow_none=False, maximum=None):
    """``value`` as an int >= minimum (and <= maximum when given; an integral float is fine); ShapeSigError
    naming ``name`` otherwise."""
    if value is None and allow_none:
        return None
    span = f">= {minimum}" if maximum is None else f"in {minimum}..{maximum}"
    expected = f"an integer {span}" + (" or None" if allow_none else "")
    try:
        n = int(value)
    except (TypeError, ValueError, OverflowError):
        raise ShapeSigError(f"{name}: expected {expected}, got {value!r}") from None
    if n != value or n < minimum or (maximum is not None and n > maximum):
        raise ShapeSigError(f"{name}: expected {expected}, got {value!r}")
    return n


def check_number(value, name, low=0.0, high=float("inf")):
    """``value`` as a finite float in [low, high]; ShapeSigError naming ``name`` otherwise."""
    span = f"in [{low:g}, {high:g}]" if math.isfinite(high) else f">= {low:g}"
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ShapeSigError(f"{name}: expected a finite number {span}, got {value!r}") from None
    if not math.isfinite(x) or x < low or x > high:  # rounded: a 32-bit -0.2 reads -0.20000000298023224
        raise ShapeSigError(f"{name}: expected a finite number {span}, got {x:.6g}")
    return x


# ------------------------------------------------------------------ the value checks of every front end
# Operators, scene properties and the command line refuse the same values with the same one-line messages
# a script's weight=5 or in-betweens=500 is an error, never silently clamped.

MAX_INBETWEENS = 99  # the most blends one Blend Actions call writes


def check_weight(value, name="weight"):
    """A blend weight: a finite number in [0, 1] (0 gives A, 1 gives B)."""
    return check_number(value, name, 0.0, 1.0)


def check_weights(weights, count=None, name="weights"):
    """Weights of several clips: finite numbers in [0, 1] summing to 1 (within 1e-6), one per clip when ``count``
    is given. Returns a tuple of floats."""
    try:
        ws = tuple(weights)
    except TypeError:
        raise ShapeSigError(f"{name}: expected a list of numbers, got {weights!r}") from None
    if count is not None and len(ws) != count:
        raise ShapeSigError(f"{name}: {len(ws)} weight(s) for {count} clips; give one weight per clip")
    ws = tuple(check_weight(w, name) for w in ws)
    if len(ws) < 2 or abs(sum(ws) - 1.0) > 1e-6:
        raise ShapeSigError(f"{name}: expected one weight per clip summing to 1, got "
                            f"{', '.join(f'{w:g}' for w in ws)} (sum {sum(ws):g})")
    return ws


def check_inbetweens(value, name="in-betweens"):
    """A count of in-betweens: an integer in [1, MAX_INBETWEENS]."""
    return check_integer(value, name, minimum=1, maximum=MAX_INBETWEENS)


def check_frame_range(start, end, first=None, last=None, what="the clip", *, frames=2, clamp=False):
    """The one frame-range rule: ``(start, end)`` as ints, frames start..end (inclusive) of ``what``, whose frames
    are first..last (None: no bound; a None start or end is that bound). A range reaching outside those frames is
    refused (frames outside a clip would compare held poses, not motion) unless ``clamp`` — asked for on purpose
    where one crop applies to clips of any length (the command line's --start/--end, a library's crop start) —
    cuts it to them (a range missing them entirely is still refused); a range of fewer than ``frames`` frames is
    refused. ShapeSigError, one line naming the range."""
    lo, hi = (None if v is None else int(round(v)) for v in (first, last))
    s = lo if start is None else check_integer(start, "frame start", minimum=-(2 ** 31))
    e = hi if end is None else check_integer(end, "frame end", minimum=-(2 ** 31))
    if s is None or e is None:
        raise ShapeSigError(f"the frame range of {what} needs a start and an end")
    short = (f"must end {'after' if frames > 1 else 'at or after'} it starts "
             f"(at least {frames} frame{'s' * (frames > 1)})")
    if start is not None and end is not None and e - s + 1 < frames:
        raise ShapeSigError(f"the frame range {s}..{e} of {what} {short}")
    outside = any((lo is not None and x < lo) or (hi is not None and x > hi) for x in (s, e))
    if outside and clamp and (hi is None or s <= hi) and (lo is None or e >= lo):
        s, e, outside = max(s, lo) if lo is not None else s, min(e, hi) if hi is not None else e, False
    if outside:
        raise ShapeSigError(f"the frame range {s}..{e} is outside {what}'s frames {lo}..{hi}")
    if e - s + 1 < frames:  # what clamping left
        raise ShapeSigError(f"the frame range {s}..{e} of {what} {short}")
    return s, e
