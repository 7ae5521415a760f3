"""A stand-in for Blender's UI layout that records every call (``FakeLayout``; sub-layouts share the log), and
``draw_search_panel`` (the 3D View search panel drawn into one)."""

from types import SimpleNamespace


class FakeLayout:
    """Records every UI call; sub-layouts share the log."""

    def __init__(self, log=None):
        self.log = [] if log is None else log

    def __getattr__(self, name):
        def call(*args, **kwargs):
            self.log.append((name, args, kwargs))
            if name == "operator":
                props = SimpleNamespace()
                self.log.append(("props", props))
                return props
            return FakeLayout(self.log)

        return call

    def labels(self):
        return " | ".join(e[2].get("text", "") for e in self.log if e[0] == "label")

    def operators(self):
        return [e[1][0] for e in self.log if e[0] == "operator"]


def draw_search_panel():
    import bpy

    from blender_shapesig.panels.search import SHAPESIG_PT_search_view3d

    layout = FakeLayout()
    SHAPESIG_PT_search_view3d.draw(SimpleNamespace(layout=layout), bpy.context)
    return layout
