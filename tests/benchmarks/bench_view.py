"""How fast view.html opens in headless Chromium, against a blank plotly 3-D page loaded in the same browser.

    python3 tests/benchmarks/bench_view.py                 # the 300-module anatomy run of docs/physics.md
    python3 tests/benchmarks/bench_view.py --repeat 7 --view some/view.html

(not collected by pytest: files here are named bench_*.py). Each page is opened ``--repeat`` times,
interleaved with the blank page, in one Chromium (the browser machinery of tests/integration/test_report_browser.py);
a load is timed from navigation until the plot's canvas exists and two animation frames have been drawn
after the load event; the view is also timed on the page's own clock from navigation to its first plot
painted (tests/integration/test_view_browser.py's ``time_to_drawn``, which the test holds to 3 s). Printed per page: the median wall time (and range), the median main-thread task time
that Chromium reports (``Performance.getMetrics`` TaskDuration: the page's own work, steadier than wall time
on a shared machine) and the file's size; then the view's medians minus the blank page's. The blank page is
plotly.js and one 3-D scatter of two points, so the difference is what the view itself costs.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

DRAWN = ("new Promise(done => { const wait = () => { const gd = document.querySelector('.js-plotly-plot');"
         " if (gd && gd._fullLayout && gd.querySelector('canvas')) requestAnimationFrame(() =>"
         " requestAnimationFrame(() => done(true))); else setTimeout(wait, 10); }; wait(); })")


def time_load(browser, page: Path) -> tuple[float, float]:
    """(wall seconds until drawn, main-thread task seconds of the load) of one load of ``page``."""
    browser.call("Performance.enable")
    t0 = time.monotonic()
    browser.load(page.as_uri(), settle=0.0)
    browser.evaluate(DRAWN)
    wall = time.monotonic() - t0
    metrics = {m["name"]: m["value"] for m in browser.call("Performance.getMetrics")["metrics"]}
    browser.call("Performance.disable")
    return wall, float(metrics.get("TaskDuration", float("nan")))


def blank_page(folder: Path) -> Path:
    import plotly.graph_objects as go

    path = folder / "blank.html"
    go.Figure(go.Scatter3d(x=[0, 1], y=[0, 1], z=[0, 1])).write_html(path, include_plotlyjs=True)
    return path


def anatomy_view(folder: Path) -> Path:
    """view.html of the 300-module thesis run on anatomical colon 7 (bhr follow --traj anatomy --seed 7
    --body-modules 300), as tests/integration/test_view_browser.py opens it."""
    import warnings

    import bhr
    from bhr.model._generators import load_trajectory
    from bhr.output._view import save_view

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = bhr.follow(load_trajectory("anatomy", seed=7), solver="thesis", body_modules=300)
    return save_view(run, folder)


def measure(view: Path, repeat: int) -> dict[str, dict[str, float]]:
    from tests.integration.test_report_browser import Browser, need_chromium
    from tests.integration.test_view_browser import time_to_drawn

    with tempfile.TemporaryDirectory() as tmp:
        blank = blank_page(Path(tmp))
        b = Browser(need_chromium(), 1200, 900)
        try:
            time_load(b, blank)  # a first load warms the browser's caches
            got: dict[str, list[tuple[float, float]]] = {"blank": [], "view": []}
            for _ in range(repeat):
                got["blank"].append(time_load(b, blank))
                got["view"].append(time_load(b, view))
            errors = b.console_errors()
            drawn = [time_to_drawn(b, view) for _ in range(repeat)]
            errors += b.console_errors()
        finally:
            b.close()
        sizes = {"blank": blank.stat().st_size, "view": view.stat().st_size}
    out: dict[str, dict[str, float]] = {}
    for name, rows in got.items():
        a = np.array(rows)
        out[name] = {"wall_s": float(np.median(a[:, 0])), "wall_min_s": float(a[:, 0].min()),
                     "wall_max_s": float(a[:, 0].max()), "task_s": float(np.median(a[:, 1])),
                     "mb": sizes[name] / 1e6}
    out["view"]["drawn_s"] = float(np.median(drawn))
    out["view"]["drawn_max_s"] = float(np.max(drawn))
    out["difference"] = {"wall_s": out["view"]["wall_s"] - out["blank"]["wall_s"],
                         "task_s": out["view"]["task_s"] - out["blank"]["task_s"],
                         "console_errors": float(len(errors))}
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--view", type=Path, default=None, help="a view.html (default: the 300-module anatomy run's)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    import os

    with tempfile.TemporaryDirectory() as tmp:
        view = args.view or anatomy_view(Path(tmp))
        res = measure(view, args.repeat)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; medians of {args.repeat} loads")
    for name in ("blank", "view"):
        r = res[name]
        print(f"{name:6s} {r['mb']:6.2f} MB  wall {r['wall_s']:.2f} s ({r['wall_min_s']:.2f}-{r['wall_max_s']:.2f})"
              f"  main-thread tasks {r['task_s']:.2f} s")
    v = res["view"]
    print(f"view   from navigation to the first plot painted (the page's clock): median {v['drawn_s']:.2f} s,"
          f" at most {v['drawn_max_s']:.2f} s")
    d = res["difference"]
    print(f"view - blank: wall {d['wall_s']:+.2f} s, main-thread tasks {d['task_s']:+.2f} s; "
          f"console errors {int(d['console_errors'])}")


if __name__ == "__main__":
    main()
