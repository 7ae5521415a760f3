"""A stand-in for an operator instance, to drive its modal path directly (a window is needed to start it for
real): an object with the methods and class constants the operator class and its mixins in the package define,
no timer, and its reports logged in ``reports``."""

import types


def stand_in(op_class):
    """An object borrowing ``op_class``'s own methods (those of its classes in ``blender_shapesig``)."""
    attrs = {"_timer": None, "bl_label": op_class.bl_label}
    for klass in reversed(op_class.__mro__):
        if not klass.__module__.startswith("blender_shapesig"):
            continue
        for name, value in vars(klass).items():
            if name.startswith("__"):
                continue
            if isinstance(value, (types.FunctionType, property)) or (name.isupper() and isinstance(value, str)):
                attrs[name] = getattr(op_class, name) if isinstance(value, types.FunctionType) else value
    obj = type("Stand", (), attrs)()
    obj.reports = []
    obj.report = lambda kind, msg: obj.reports.append((set(kind), msg))
    return obj
