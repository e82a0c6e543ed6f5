"""The live view (--show) in a real window: Xvfb, TkAgg, keys sent as X events with xdotool.

Each test starts its own Xvfb on a free display (``-displayfd``), runs the
real ``bhr`` command with DISPLAY set, waits for its window, presses keys,
reads back the window's title (which names the step shown) and a screenshot
of the window, and quits with a key. Xvfb and xdotool are installed by
tests/run; without them the tests skip, and fail under CI.
"""
from __future__ import annotations

import os
import re
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from bhr.model._generators import load_trajectory
from bhr.output._atomic import write_json
from bhr._run.driver import follow, load_run
from tests.cli.test_animate import check_frame, need_tool
from tests.conftest import bhr_exe, snapshot

WAIT = 120.0  # seconds: solving the colon and opening the window, on a loaded 2-core machine


@pytest.fixture
def display():
    """A fresh Xvfb at 96 dpi (so the window's canvas has the figure's own pixel size); yields ':N'."""
    xvfb = need_tool("Xvfb")
    need_tool("xdotool")
    r, w = os.pipe()
    proc = subprocess.Popen([xvfb, "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-dpi", "96",
                             "-nolisten", "tcp"], pass_fds=(w,), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(w)
    try:
        with os.fdopen(r) as f:
            number = f.readline().strip()
        assert number.isdigit(), "Xvfb did not report its display number"
        yield f":{number}"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


class Window:
    """A bhr live view running in a subprocess on ``display``, driven with xdotool."""

    def __init__(self, display: str, args: list[str], cwd: Path, name: str) -> None:
        self.display = display
        env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
        env["DISPLAY"] = display
        self.env = env
        self.proc = subprocess.Popen(bhr_exe() + args, cwd=cwd, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        self.wid = self._find(name)

    def xdo(self, *args: str, timeout: float = 30) -> str:
        out = subprocess.run(["xdotool", *args], env=self.env, capture_output=True, text=True, timeout=timeout)
        return out.stdout.strip()

    def _find(self, name: str) -> str:
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                out, err = self.proc.communicate()
                pytest.fail(f"bhr exited ({self.proc.returncode}) before its window opened: {err[-2000:]}")
            wid = self.xdo("search", "--onlyvisible", "--name", f"^{name}")
            if wid:
                return wid.split()[0]
            time.sleep(0.2)
        pytest.fail(f"no window named {name!r} within {WAIT} s")

    def title(self) -> str:
        return self.xdo("getwindowname", self.wid)

    def key(self, *keys: str) -> None:
        self.xdo("windowfocus", "--sync", self.wid)
        self.xdo("key", "--delay", "60", *keys)

    def wait_title(self, pattern: str, timeout: float = 20) -> re.Match:
        deadline = time.monotonic() + timeout
        title = ""
        while time.monotonic() < deadline:
            title = self.title()
            m = re.search(pattern, title)
            if m:
                return m
            time.sleep(0.05)
        pytest.fail(f"window title {title!r} never matched {pattern!r}")

    def press(self, key: str, pattern: str) -> re.Match:
        """Press ``key`` and wait until the title shows ``pattern``."""
        self.key(key)
        return self.wait_title(pattern)

    def screenshot(self) -> np.ndarray:
        from PIL import ImageGrab

        geo = dict(line.split("=", 1) for line in self.xdo("getwindowgeometry", "--shell", self.wid).split())
        x, y, w, h = (int(geo[k]) for k in ("X", "Y", "WIDTH", "HEIGHT"))
        img = ImageGrab.grab(bbox=(x, y, x + w, y + h), xdisplay=self.display)
        return np.asarray(img.convert("RGB"))

    def wait_exit(self, timeout: float = 30) -> tuple[int, str, str]:
        out, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, out, err

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()


def screen_view(result):
    """The live view's frame drawn off-screen (same StepView, same figure size at 100 dpi)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from bhr.output._scene import FRAME_INCHES
    from bhr.output._stepview import StepView

    fig = Figure(figsize=FRAME_INCHES, dpi=100)
    FigureCanvasAgg(fig)
    return StepView(result, fig=fig)


def assert_window_shows(win: Window, result, step: int, timeout: float = 10) -> None:
    """The window's canvas shows the robot and target of ``step`` (0-based), as the GIF test checks frames."""
    view = screen_view(result)
    deadline = time.monotonic() + timeout
    while True:
        img = win.screenshot()[:700, :1000]
        try:
            check_frame(img, result, view, step)
            return
        except AssertionError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def test_follow_show_steps_through_frames_and_quits(display, tmp_path):
    win = Window(display, ["follow", "--traj", "colon", "--no-plots", "--out", "run", "--show"], tmp_path,
                 "bhr colon")
    try:
        win.wait_title(r"step \d+/827 \(playing\)")
        win.press("space", r"step (\d+)/827 \(paused\)")
        win.press("Home", r"step 1/827 \(paused\)")
        for k in (2, 3, 4):
            win.press("n", rf"step {k}/827 \(paused\)")
        win.press("Left", r"step 3/827 \(paused\)")
        for k in (4, 5, 6):
            win.press("Right", rf"step {k}/827 \(paused\)")
        result = load_run(tmp_path / "run" / "run.json")  # written before the window opened
        assert_window_shows(win, result, 5)
        win.press("End", r"step 827/827 \(end, paused\)")
        assert_window_shows(win, result, 826)
        win.press("b", r"step 826/827 \(paused\)")
        win.key("q")
        code, out, err = win.wait_exit()
    finally:
        win.kill()
    assert code == 0, err
    assert "Traceback" not in err
    m = re.search(r"Live view: showed (\d+) frames; closed at step 826 of 827 \(paused\)\.", err)
    assert m, err
    assert int(m.group(1)) >= 12  # the first frame, those it played, and the 11 the keys asked for
    assert "space: pause / resume" in err  # the keys were listed
    assert "Wrote run/codes.csv, run/run.json" in out


def test_replay_show_with_stride_and_escape(display, tmp_path):
    run = follow(load_trajectory("curve"))
    write_json(tmp_path / "run.json", run.to_dict())
    win = Window(display, ["replay", "run.json", "--show", "--stride", "10"], tmp_path, "bhr curve")
    try:
        # 85 steps in frames of 10 steps play to the end and stop there
        win.wait_title(r"step 85/85 \(end, paused\)")
        win.press("Home", r"step 1/85 \(paused\)")
        win.press("n", r"step 11/85 \(paused\)")
        win.press("n", r"step 21/85 \(paused\)")
        win.press("b", r"step 11/85 \(paused\)")
        assert_window_shows(win, run, 10)
        win.key("minus", "minus", "minus", "plus")  # 50 ms a frame -> 400 ms -> 200 ms
        win.press("space", r"step (11|21)/85 \(playing\)")  # plays on from step 11...
        t0 = time.monotonic()
        win.wait_title(r"step 85/85 \(end, paused\)")  # ...to the end
        assert time.monotonic() - t0 > 0.8  # 7 frames at 200 ms (at 50 ms they would take 0.35 s)
        win.press("space", r"step \d+/85 \(playing\)")  # at the end, space plays again from the start
        win.key("Escape")
        code, out, err = win.wait_exit()
    finally:
        win.kill()
    assert code == 0, err
    assert re.search(r"Live view: showed \d+ frames; closed at step \d+ of 85\.", err), err
    assert out == ""  # --show alone writes no figures


@pytest.mark.parametrize("display_value, message", [
    (None, "--show needs a display, and DISPLAY is not set"),
    (":4093", "--show cannot open a window on display ':4093'"),
])
def test_show_without_a_display_is_refused_before_any_work(tmp_path, display_value, message):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MPLBACKEND")}
    if display_value is not None:
        env["DISPLAY"] = display_value
    before = snapshot(tmp_path)
    res = subprocess.run(bhr_exe() + ["follow", "--traj", "colon", "--out", "out", "--show"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=120)
    assert res.returncode != 0
    assert message in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert snapshot(tmp_path) == before
