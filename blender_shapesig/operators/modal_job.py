"""One owner of the long clicks (Build Index, Find Similar): ``ModalJob``, a mixin for an operator that does its
work in small steps. In the UI it runs modal from a timer with Blender's progress cursor, the panel's running flag
and progress bar, and Esc cancels; headless (no window, background) it runs every step at once. A failure ends the
timer and the cursor, clears the running flag and is reported in one line; ``cleanup`` does the same for anything
that escapes (``errors_ui``). The operator says what a step is and what the end, a failure and Esc report."""

import bpy

from ..core.errors import ShapeSigError, error_line

__all__ = ["ModalJob", "tag_redraw", "run_again_confirmed"]

PROGRESS_STEPS = 1000  # the progress cursor's resolution


def tag_redraw(context):
    """Redraw the editors that show the panel or the actions."""
    screen = getattr(context, "screen", None)
    for area in getattr(screen, "areas", ()):
        if area.type in ("VIEW_3D", "DOPESHEET_EDITOR", "NLA_EDITOR"):
            area.tag_redraw()


def has_window(context):
    """True where a modal run and dialogs are possible (a window, not background)."""
    return context.window is not None and not bpy.app.background


def run_again_confirmed(op, context, name, **props):
    """A confirmation dialog's OK calls ``execute``: in the UI, start ``bpy.ops.shapesig.<name>`` again with its
    progress bar (modal), confirmed; True when it did."""
    if not op.confirmed or not has_window(context):
        return False
    getattr(bpy.ops.shapesig, name)("INVOKE_DEFAULT", confirmed=True, **props)
    return True


class ModalJob:
    """Mixin for a ``bpy.types.Operator`` with a ``confirmed`` property. The operator gives:

    - ``OP_NAME``: its name in ``bpy.ops.shapesig``;
    - ``RUNNING``, ``PROGRESS``: names of the flag and the 0..1 fraction on ``_panel(context)`` the panel draws;
    - ``_start(context)``: set up the job (``ShapeSigError``: refused in one line);
    - ``_work()``: one timer tick's work; ``_fraction()``, ``_finished()``;
    - ``_done(context)`` -> FINISHED and ``_cancel(context)`` (Esc) -> CANCELLED, each clearing the running flag;
    - optionally ``_ask(context, event)``: None, or a dialog to show first (``invoke``'s return value), and
      ``_again()``: the properties to start the operator again with after the dialog's OK."""

    OP_NAME = RUNNING = PROGRESS = ""
    _timer = None

    def _panel(self, context):
        raise NotImplementedError

    def _ask(self, context, event):
        return None

    def _again(self):
        return {}

    def _set_running(self, context, running):
        setattr(self._panel(context), self.RUNNING, running)

    def _fail(self, context, exc):
        """A failure in one line ("<label>: <what>", ``error_line``: no Python type name; an unexpected one's
        traceback on the console), the running flag off; CANCELLED."""
        if not isinstance(exc, ShapeSigError):
            import sys
            import traceback

            traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
        self._set_running(context, False)
        self.report({"ERROR"}, f"{self.bl_label}: {error_line(exc)}")
        return {"CANCELLED"}

    def _begin_modal(self, context):
        wm = context.window_manager
        wm.progress_begin(0, PROGRESS_STEPS)
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end_modal(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()

    def cleanup(self, context):
        """After any failure (``errors_ui``): the timer and the progress cursor ended, the running flag off."""
        if self._timer is not None:
            self._end_modal(context)
        self._set_running(context, False)

    def execute(self, context):
        if run_again_confirmed(self, context, self.OP_NAME, **self._again()):
            return {"FINISHED"}
        try:
            self._start(context)
            while not self._finished():
                self._work()
        except ShapeSigError as exc:
            return self._fail(context, exc)
        return self._done(context)

    def invoke(self, context, event):
        asked = self._ask(context, event)
        if asked is not None:
            return asked
        if not has_window(context):
            return self.execute(context)
        try:
            self._start(context)
        except ShapeSigError as exc:
            return self._fail(context, exc)
        panel = self._panel(context)
        setattr(panel, self.RUNNING, True)
        setattr(panel, self.PROGRESS, 0.0)
        return self._begin_modal(context)

    def modal(self, context, event):
        if event.type == "ESC":
            self._end_modal(context)
            return self._cancel(context)
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            self._work()
        except Exception as exc:  # noqa: BLE001 - never leave a modal operator running after an error
            self._end_modal(context)
            return self._fail(context, exc)
        fraction = self._fraction()
        setattr(self._panel(context), self.PROGRESS, fraction)
        context.window_manager.progress_update(int(PROGRESS_STEPS * fraction))
        tag_redraw(context)
        if self._finished():
            self._end_modal(context)
            return self._done(context)
        return {"RUNNING_MODAL"}
