"""Every operator's failure is one line (the Blender half of ``core.errors.error_line``). ``guard_operator(cls)``
wraps the ``execute``, ``invoke`` and ``modal`` of an operator class (``operators.register`` guards every class):
any exception becomes ``self.report({'ERROR'}, "<label>: <one line>")`` and CANCELLED, its traceback goes to the
console (stderr), and the operator's ``cleanup(context)``, when it has one, clears what a run leaves set (modal
timers, progress, ``running`` flags). An operator's own handling is unchanged: the guard only sees what escapes."""

import functools
import sys
import traceback

from .core.errors import ShapeSigError, error_line

__all__ = ["guard_operator", "GUARDED", "report_failure"]

GUARDED = "_shapesig_guarded"  # set on a wrapped method
_METHODS = ("execute", "invoke", "modal")


def report_failure(op, context, exc):
    """Report ``exc`` in one line on ``op`` after its ``cleanup``; returns CANCELLED."""
    if not isinstance(exc, ShapeSigError):
        traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
    cleanup = getattr(op, "cleanup", None)
    if cleanup is not None:
        try:
            cleanup(context)
        except Exception:  # noqa: BLE001 - the first failure is the one to report
            traceback.print_exc(file=sys.stderr)
    label = getattr(op, "bl_label", "") or type(op).__name__
    op.report({"ERROR"}, f"{label}: {error_line(exc)}")
    return {"CANCELLED"}


def _guarded(name, method):
    """``method`` wrapped; Blender checks the argument count, so each kind keeps its own signature."""
    if name == "execute":
        def run(self, context):
            try:
                return method(self, context)
            except Exception as exc:  # noqa: BLE001 - every failure: one line, the traceback on the console
                return report_failure(self, context, exc)
    else:
        def run(self, context, event):
            try:
                return method(self, context, event)
            except Exception as exc:  # noqa: BLE001
                return report_failure(self, context, exc)

    functools.update_wrapper(run, method)
    del run.__wrapped__  # Blender reads the signature of the function it is given
    setattr(run, GUARDED, True)
    return run


def guard_operator(cls):
    """Wrap ``cls``'s execute / invoke / modal (each once); returns ``cls``."""
    for name in _METHODS:
        method = cls.__dict__.get(name)
        if method is None:
            inherited = getattr(cls, name, None)
            if inherited is None or getattr(inherited, GUARDED, False):
                continue
            method = inherited
        elif getattr(method, GUARDED, False):
            continue
        setattr(cls, name, _guarded(name, method))
    return cls
