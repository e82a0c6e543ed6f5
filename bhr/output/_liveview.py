"""Watch a run step by step in a window (``bhr follow --show``, ``bhr replay --show``).

The window shows what the thesis's script draws while it runs (ch. 7.1,
appendix 1): the path, the current target and the robot (points, links, a
disc of the robot's radius at each module), top view for a planar run and 3D
otherwise (drag to rotate), in a view that follows the robot, beside an
overview of the whole path and a readout of the step's errors. Drawing is
:class:`bhr.output._stepview.StepView`, the same code as the animation. The run plays by itself;
keys (see :data:`KEYS`) pause, step and quit. The window's title names the
step shown, e.g. ``bhr colon: step 12/827 (paused)``.

Needs a display and an interactive matplotlib backend (TkAgg by default;
Debian ``python3-tk``); :func:`check_display` says what is missing before
any work starts. Import this module only to show a window.
"""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from bhr._settings.errors import BhrError

if TYPE_CHECKING:  # pragma: no cover
    from bhr._run.driver import FollowResult

__all__ = ["LiveView", "ViewReport", "check_display", "show", "KEYS", "DEFAULT_INTERVAL_MS"]

#: Keys of the live view and what they do.
KEYS = {
    "space": "pause / resume",
    "n, right": "next frame (pauses)",
    "b, left": "previous frame (pauses)",
    "home, end": "first / last step (pauses)",
    "+, -": "play faster / slower",
    "q, escape": "quit",
}
#: Time between frames while playing (ms).
DEFAULT_INTERVAL_MS = 50
_MIN_INTERVAL_MS, _MAX_INTERVAL_MS = 10, 2000


def keys_help() -> str:
    """One line listing the keys."""
    return "; ".join(f"{k}: {v}" for k, v in KEYS.items())


def _interactive_backends() -> set[str]:
    from matplotlib.backends import BackendFilter, backend_registry

    return {b.lower() for b in backend_registry.list_builtin(BackendFilter.INTERACTIVE)}


def _requested_backend() -> str | None:
    """MPLBACKEND when it names an interactive backend (the user's choice), else None (use TkAgg)."""
    name = os.environ.get("MPLBACKEND", "").strip()
    if not name:
        return None
    if name.lower().startswith("module://"):
        return name
    return name if name.lower() in _interactive_backends() else None


def check_display() -> None:
    """Raise :class:`BhrError` (one line) when no window can be opened here; cheap, before any work."""
    if sys.platform not in ("win32", "darwin") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise BhrError("--show needs a display, and DISPLAY is not set; run it on a desktop (or under xvfb-run), "
                       "or write a file with --animate FILE.gif instead")
    if _requested_backend() is not None:
        return
    try:
        import tkinter
    except ImportError:
        raise BhrError("--show needs Tk for its window (Python's tkinter is missing); install it "
                       "(Debian: apt-get install python3-tk) or set MPLBACKEND to another interactive backend "
                       "(e.g. QtAgg)") from None
    try:
        root = tkinter.Tk()
        root.withdraw()
        root.destroy()
    except tkinter.TclError as exc:
        first = str(exc).splitlines()[0] if str(exc) else "unknown error"
        raise BhrError(f"--show cannot open a window on display {os.environ.get('DISPLAY', '')!r} ({first}); "
                       "check DISPLAY or write a file with --animate FILE.gif instead") from None


@dataclass
class ViewReport:
    """What the viewer saw: frames drawn, the steps shown (0-based, in order), where it stopped."""

    steps: int
    frames_drawn: int = 0
    shown: list[int] = field(default_factory=list)
    last: int = 0
    paused: bool = False

    def line(self) -> str:
        return (f"Live view: showed {self.frames_drawn} frames; closed at step {self.last + 1} of {self.steps}"
                f"{' (paused)' if self.paused else ''}.")


class LiveView:
    """A window that plays ``result`` frame by frame; ``stride`` steps make one frame.

    Keys are handled through matplotlib's own event system (``key_press_event``),
    so they work in every interactive backend; matplotlib's default key bindings
    (save, pan, zoom, ...) are switched off in this window so that they do not
    compete with the viewer's.
    """

    def __init__(self, result: "FollowResult", stride: int = 1, interval_ms: int = DEFAULT_INTERVAL_MS,
                 paused: bool = False) -> None:
        if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
            raise BhrError(f"stride must be a whole number of steps, 1 or more, got {stride!r}")
        self.result = result
        self.stride = stride
        self.interval = int(min(max(interval_ms, _MIN_INTERVAL_MS), _MAX_INTERVAL_MS))
        self.playing = not paused
        self.report = ViewReport(result.steps, paused=paused)
        self.view: Any = None
        self.timer: Any = None
        self.i = 0

    # -- state ---------------------------------------------------------------------------------
    def _status(self) -> str:
        if self.playing:
            return "playing"
        return "end, paused" if self.i == self.result.steps - 1 else "paused"

    def window_title(self) -> str:
        return f"bhr {self.result.trajectory.name}: step {self.i + 1}/{self.result.steps} ({self._status()})"

    def _refresh_title(self) -> None:
        self.view.fig.canvas.manager.set_window_title(self.window_title())

    def goto(self, i: int) -> None:
        """Draw step ``i`` (clamped to the run)."""
        i = min(max(i, 0), self.result.steps - 1)
        self.i = i
        self.view.draw(i)
        self.report.frames_drawn += 1
        self.report.shown.append(i)
        self.report.last = i
        self._refresh_title()
        self.view.fig.canvas.draw_idle()

    def _pause(self) -> None:
        self.playing = False
        self.report.paused = True

    def _tick(self) -> None:
        if not self.playing:
            return
        if self.i >= self.result.steps - 1:
            self._pause()
            self._refresh_title()
            return
        self.goto(self.i + self.stride)

    def on_key(self, event: Any) -> None:
        key = (event.key or "").lower()
        last = self.result.steps - 1
        if key in (" ", "space"):
            if self.playing:
                self._pause()
                self._refresh_title()
            else:
                self.playing = True
                self.report.paused = False
                if self.i >= last:  # at the end: play again from the start
                    self.goto(0)
                else:
                    self._refresh_title()
        elif key in ("n", "right"):
            self._pause()
            self.goto(self.i + self.stride if self.i < last else last)
        elif key in ("b", "left"):
            self._pause()
            self.goto(self.i - self.stride)
        elif key == "home":
            self._pause()
            self.goto(0)
        elif key == "end":
            self._pause()
            self.goto(last)
        elif key in ("+", "="):
            self._set_interval(self.interval // 2)
        elif key == "-":
            self._set_interval(self.interval * 2)
        elif key in ("q", "escape"):
            self.close()

    def _set_interval(self, ms: int) -> None:
        self.interval = int(min(max(ms, _MIN_INTERVAL_MS), _MAX_INTERVAL_MS))
        if self.timer is not None:
            self.timer.interval = self.interval

    def close(self) -> None:
        import matplotlib.pyplot as plt

        if self.timer is not None:
            self.timer.stop()
        plt.close(self.view.fig)

    # -- window --------------------------------------------------------------------------------
    def run(self) -> ViewReport:
        """Open the window and block until it is closed (key q or the window's close button)."""
        import matplotlib.pyplot as plt

        from bhr.output._scene import FRAME_INCHES
        from bhr.output._stepview import StepView

        backend = _requested_backend() or "TkAgg"
        try:
            if plt.get_backend().lower() != backend.lower():
                plt.switch_backend(backend)
        except (ImportError, RuntimeError) as exc:
            first = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
            raise BhrError(f"--show cannot start the {backend} window ({first}); check DISPLAY and tkinter, "
                           "or write a file with --animate FILE.gif instead") from None
        self.view = StepView(self.result, fig=plt.figure(figsize=FRAME_INCHES))  # a window: pyplot's figure manager
        fig = self.view.fig
        manager = fig.canvas.manager
        handler = getattr(manager, "key_press_handler_id", None)
        if handler is not None:
            fig.canvas.mpl_disconnect(handler)
        fig.canvas.mpl_connect("key_press_event", self.on_key)
        _forward_early_keys(fig.canvas)
        self.goto(0)
        self.timer = fig.canvas.new_timer(interval=self.interval)
        self.timer.add_callback(self._tick)
        self.timer.start()
        plt.show(block=True)
        if self.timer is not None:
            self.timer.stop()
        return self.report


def _forward_early_keys(canvas: Any) -> None:
    """In a Tk window, pass keys that reach the window itself on to the figure.

    When a Tk window gets the keyboard focus, Tk first gives it to the window
    and only a moment later to the widget inside that asked for it (the
    figure's canvas); matplotlib listens on the canvas alone, so a key pressed
    in between would be lost. Other backends need nothing.
    """
    window = getattr(getattr(canvas, "manager", None), "window", None)
    key_press = getattr(canvas, "key_press", None)
    if window is None or key_press is None or not hasattr(window, "bind") or not hasattr(canvas, "get_tk_widget"):
        return

    def on_window_key(event: Any) -> None:
        if str(event.widget) == str(window):  # keys on the canvas itself reach matplotlib already
            key_press(event)

    window.bind("<KeyPress>", on_window_key, add="+")


def show(result: "FollowResult", stride: int = 1, interval_ms: int = DEFAULT_INTERVAL_MS,
         paused: bool = False) -> ViewReport:
    """Open the live view of ``result`` and block until the user quits; see :class:`LiveView`."""
    return LiveView(result, stride=stride, interval_ms=interval_ms, paused=paused).run()
