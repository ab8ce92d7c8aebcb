"""Long work in steps: a job is a generator that yields (fraction done, message) between chunks (a
clip, a fit) and None while a module call runs in a worker thread (the module releases the GIL).

Invoked from the UI, an operator runs its job on a timer as a modal operator: the UI stays live,
the status bar shows the progress, Esc cancels (the running module call finishes in its thread and
its result is dropped; what the job changed is undone by its own `finally`). Run with
EXEC_DEFAULT (scripts, background Blender, the tests) the same job runs to its end at once.
"""

import threading
import time

from .character import Failure, active_armature
from .module import load

_TICK_SECONDS = 0.05  # the timer, and the longest the modal step keeps the UI per tick
_running = {"operator": None}


def in_thread(function, *args, **kwargs):
    """Generator: runs function(*args, **kwargs) in a thread, yielding None until it returns; returns
    its value (`value = yield from in_thread(...)`) or raises its exception."""
    box = {}

    def target():
        try:
            box["value"] = function(*args, **kwargs)
        except BaseException as error:  # handed to the job's thread below
            box["error"] = error

    thread = threading.Thread(target=target, name="skinspheres", daemon=True)
    thread.start()
    while thread.is_alive():
        yield None
    if "error" in box:
        raise box["error"]
    return box["value"]


def busy():
    return _running["operator"] is not None


def module_or_fail():
    ss, error = load()
    if ss is None:
        raise Failure(error)
    return ss


class LongOperator:
    """Mixin for operators whose work is a job: subclasses define job(context) -> generator."""

    @classmethod
    def poll(cls, context):
        return not busy() and active_armature(context) is not None

    def execute(self, context):
        state = context.scene.skinspheres
        try:
            for step in self.job(context):
                if step is None:
                    time.sleep(0.005)
                else:
                    state.progress, state.status = step
        except Failure as failure:
            return self._fail(state, str(failure))
        except Exception as error:  # the module's errors (skinspheres.Error) and Blender's
            return self._fail(state, f"{type(error).__name__}: {error}")
        state.progress = 1.0
        self.report({"INFO"}, state.status)
        return {"FINISHED"}

    def invoke(self, context, _event):
        self._job = self.job(context)
        self._timer = context.window_manager.event_timer_add(_TICK_SECONDS, window=context.window)
        context.window_manager.modal_handler_add(self)
        context.window_manager.progress_begin(0, 1000)
        _running["operator"] = self
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        state = context.scene.skinspheres
        if event.type == "ESC":
            self._job.close()  # its finally blocks undo what it started
            self._end(context, f"{self.bl_label}: cancelled")
            self.report({"WARNING"}, state.status)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        deadline = time.monotonic() + _TICK_SECONDS
        try:
            while time.monotonic() < deadline:
                step = next(self._job)
                if step is None:
                    break  # a module call is running: look again on the next tick
                state.progress, state.status = step
                context.window_manager.progress_update(int(1000 * state.progress))
                context.workspace.status_text_set(f"skinspheres: {state.status} (Esc cancels)")
        except StopIteration:
            self._end(context, state.status)
            self.report({"INFO"}, state.status)
            return {"FINISHED"}
        except Exception as error:
            self._end(context, None)
            message = str(error) if isinstance(error, Failure) else f"{type(error).__name__}: {error}"
            return self._fail(state, message)
        self._redraw(context)
        return {"RUNNING_MODAL"}

    def _end(self, context, status):
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        context.workspace.status_text_set(None)
        _running["operator"] = None
        if status is not None:
            context.scene.skinspheres.status = status
        self._redraw(context)

    def _fail(self, state, message):
        state.status = f"{self.bl_label} failed: {message}"
        self.report({"ERROR"}, message)
        return {"CANCELLED"}

    @staticmethod
    def _redraw(context):
        for area in context.screen.areas if context.screen else []:
            if area.type in {"VIEW_3D", "DOPESHEET_EDITOR", "TIMELINE"}:
                area.tag_redraw()
