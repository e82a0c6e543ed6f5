"""The report page in a real browser: headless Chromium loads it without console errors.

Chromium (Debian's ``chromium``, installed by tests/run) is started headless with a fresh
profile and its DevTools protocol on 127.0.0.1; a small websocket client (websocket-client)
collects console messages, uncaught exceptions and browser log entries (failed resource loads)
while the page loads, checks the page in the DOM (summary table first, every figure loaded),
and takes a screenshot. Without chromium the tests skip, and fail when CI is set.
"""
from __future__ import annotations

import base64
import http.server
import io
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CHAPTER7 = REPO / "docs" / "examples" / "chapter7.toml"


def need_chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    msg = "chromium is not installed (tests/run installs Debian's chromium package)"
    if os.environ.get("CI"):
        pytest.fail(msg)
    pytest.skip(msg)


class Browser:
    """Headless Chromium driven over the DevTools protocol on loopback."""

    def __init__(self, exe: str, width: int = 1280, height: int = 1600) -> None:
        import websocket  # websocket-client, a test dependency

        self.profile = tempfile.mkdtemp(prefix="bhr-chromium-")
        self.width, self.height = width, height
        args = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--disable-default-apps", "--disable-extensions", "--no-default-browser-check", "--mute-audio",
                "--hide-scrollbars", f"--user-data-dir={self.profile}", "--remote-debugging-address=127.0.0.1",
                "--remote-debugging-port=0", f"--window-size={width},{height}", "about:blank"]
        self.proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            port = self._wait_port()
            targets = []
            for _ in range(100):
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as resp:
                    targets = [t for t in json.load(resp) if t.get("type") == "page"]
                if targets:
                    break
                time.sleep(0.1)
            assert targets, "chromium opened no page target"
            self.ws = websocket.create_connection(targets[0]["webSocketDebuggerUrl"], timeout=30,
                                                  suppress_origin=True)
        except BaseException:
            self.close()
            raise
        self.next_id = 0
        self.events: list[dict] = []

    def _wait_port(self) -> int:
        marker = Path(self.profile) / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                err = self.proc.stderr.read().decode(errors="replace") if self.proc.stderr else ""
                raise AssertionError(f"chromium exited with {self.proc.returncode}: {err[-2000:]}")
            if marker.exists():
                lines = marker.read_text().split()
                if lines and lines[0].isdigit():
                    return int(lines[0])
            time.sleep(0.05)
        raise AssertionError("chromium did not open its DevTools port within 60 s")

    def call(self, method: str, **params):
        self.next_id += 1
        my_id = self.next_id
        self.ws.send(json.dumps({"id": my_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == my_id:
                if "error" in msg:
                    raise AssertionError(f"{method} failed: {msg['error']}")
                return msg.get("result", {})
            if "method" in msg:
                self.events.append(msg)

    def pump(self, seconds: float) -> None:
        """Collect events for ``seconds``."""
        import websocket

        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.ws.settimeout(max(0.05, deadline - time.monotonic()))
            try:
                msg = json.loads(self.ws.recv())
            except websocket.WebSocketTimeoutException:
                break
            if "method" in msg:
                self.events.append(msg)
        self.ws.settimeout(30)

    def load(self, url: str, settle: float = 1.0, timeout: float = 60) -> None:
        """Navigate to ``url``; return once the load event fired and ``settle`` seconds passed."""
        for domain in ("Page", "Runtime", "Log"):
            self.call(f"{domain}.enable")
        self.call("Emulation.setDeviceMetricsOverride", width=self.width, height=self.height, deviceScaleFactor=1,
                  mobile=False)
        self.events.clear()
        self.call("Page.navigate", url=url)
        deadline = time.monotonic() + timeout
        while not any(e["method"] == "Page.loadEventFired" for e in self.events):
            assert time.monotonic() < deadline, f"{url} did not finish loading within {timeout} s"
            self.pump(0.2)
        self.pump(settle)

    def console_errors(self) -> list[str]:
        """Console errors, uncaught exceptions and error log entries since the last load."""
        out = []
        for e in self.events:
            p = e.get("params", {})
            if e["method"] == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                out.append("exception: " + str(d.get("exception", {}).get("description") or d.get("text")))
            elif e["method"] == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                out.append("console.error: " + " ".join(str(a.get("value", a.get("description"))) for a in p["args"]))
            elif e["method"] == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                entry = p["entry"]
                out.append(f"log ({entry.get('source')}): {entry.get('text')} {entry.get('url', '')}".strip())
        return out

    def evaluate(self, expression: str):
        res = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in res:
            raise AssertionError(f"page script failed: {res['exceptionDetails']}")
        return res["result"].get("value")

    def screenshot(self, path: Path) -> bytes:
        data = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        path.write_bytes(data)
        return data

    def close(self) -> None:
        ws = getattr(self, "ws", None)
        if ws is not None:
            ws.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=15)
        if self.proc.stderr:
            self.proc.stderr.close()
        shutil.rmtree(self.profile, ignore_errors=True)


@pytest.fixture
def browser():
    b = Browser(need_chromium())
    try:
        yield b
    finally:
        b.close()


@pytest.fixture(scope="module")
def chapter7_report(tmp_path_factory):
    """The chapter 7 example batch, written by the real `bhr report` command."""
    from tests.conftest import bhr_exe

    out = tmp_path_factory.mktemp("report") / "chapter7"
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run(bhr_exe() + ["report", "--file", str(CHAPTER7), "--out", str(out), "--jobs", "2"],
                          capture_output=True, text=True, timeout=900, env=env, cwd=out.parent)
    assert proc.returncode == 0, proc.stderr
    return out


class LoopbackServer:
    """http.server on 127.0.0.1 serving one folder, in a thread."""

    def __init__(self, folder: Path) -> None:
        handler = lambda *a, **kw: http.server.SimpleHTTPRequestHandler(*a, directory=str(folder), **kw)  # noqa: E731
        http.server.SimpleHTTPRequestHandler.log_message = lambda *a, **kw: None
        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/"

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(timeout=10)


def png_info(data: bytes):
    from PIL import Image

    img = Image.open(io.BytesIO(data))
    img.load()
    return img


FITS = ("[document.documentElement.scrollWidth, window.innerWidth, Array.from(document.querySelectorAll('main *'))"
        ".filter(e => !e.closest('.scroll') && e.getBoundingClientRect().right > window.innerWidth + 1)"
        ".map(e => e.tagName)]")


def check_fits(browser: Browser) -> None:
    """Nothing but a scrolling table runs past the right edge of the 1280 px window."""
    width, window, wide = browser.evaluate(FITS)
    assert window == 1280 and width <= window and wide == [], (width, wide)


def check_page(browser: Browser, shot: Path) -> None:
    assert browser.console_errors() == []
    check_fits(browser)
    # the summary table is the first thing after the title and description
    first = browser.evaluate("Array.from(document.querySelector('main').children)"
                             ".filter(e => !['H1','P'].includes(e.tagName))[0].querySelector('table').id")
    assert first == "summary"
    names = browser.evaluate("Array.from(document.querySelectorAll('#summary tbody tr td:first-child'))"
                             ".map(td => td.textContent)")
    assert names == ["line", "curve 90", "curve 360", "spiral", "colon"]
    statuses = browser.evaluate("Array.from(document.querySelectorAll('#summary tbody tr td:nth-child(2)'))"
                                ".map(td => td.textContent)")
    assert statuses == ["ran to the end"] * 5  # the column says how each run finished; the verdict has its own
    # each run shows the thesis's four figures, and every image decoded
    per_run = browser.evaluate("Array.from(document.querySelectorAll('section')).map(s => "
                               "Array.from(s.querySelectorAll('img'))"
                               ".map(i => i.getAttribute('src').split('/').pop()))")
    thesis = ["path.png", "position_errors.png", "orientation_errors.png", "global_errors.png"]
    assert per_run == [thesis] * 4 + [thesis + ["clearance.png"]]  # the colon has a lumen
    loaded = browser.evaluate("Promise.all(Array.from(document.images).map(i => i.decode().then(() => "
                              "[i.naturalWidth, i.naturalHeight], () => [0, 0])))")
    assert len(loaded) == 21 and all(w > 300 and h > 300 for w, h in loaded), loaded
    # each figure is a link to its PNG, which opens at full size (the page shows it shrunk to its column)
    links = browser.evaluate("Array.from(document.images).map(i => [i.getAttribute('src'), "
                             "i.closest('a') ? i.closest('a').getAttribute('href') : null, "
                             "i.naturalWidth, i.getBoundingClientRect().width])")
    assert all(src == href for src, href, _, _ in links), links
    assert sum(nat > shown * 1.3 for _, _, nat, shown in links) >= 15
    table_bottom = browser.evaluate("document.getElementById('summary').getBoundingClientRect().bottom")
    first_img_top = browser.evaluate("document.images[0].getBoundingClientRect().top")
    assert table_bottom < first_img_top
    data = browser.screenshot(shot)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    img = png_info(data)
    assert img.size == (1280, 1600)
    colours = img.convert("RGB").getcolors(maxcolors=1 << 20)
    assert colours is not None and len(colours) > 50  # text, table shading and figures, not a blank page


def test_report_page_loads_without_console_errors_over_file(browser, chapter7_report, tmp_path):
    browser.load((chapter7_report / "index.html").as_uri())
    check_page(browser, tmp_path / "report-file.png")


def test_report_page_loads_without_console_errors_over_http(browser, chapter7_report, tmp_path):
    server = LoopbackServer(chapter7_report)
    try:
        browser.load(server.url + "index.html")
        check_page(browser, tmp_path / "report-http.png")
    finally:
        server.close()


def test_inline_report_is_one_file(browser, tmp_path):
    """--inline-images: the page alone (moved away from its figures) still shows every figure."""
    from tests.conftest import bhr_exe

    batch = tmp_path / "b.toml"
    batch.write_text('[[run]]\nname = "curve <90> & co"\ntraj = "curve"\nangle = 90\n')
    out = tmp_path / "out"
    proc = subprocess.run(bhr_exe() + ["report", "--file", str(batch), "--out", str(out), "--inline-images"],
                          capture_output=True, text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))
    assert proc.returncode == 0, proc.stderr
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(out / "index.html", alone / "index.html")
    browser.load((alone / "index.html").as_uri())
    assert browser.console_errors() == []
    assert browser.evaluate("document.querySelector('h2').textContent") == "curve <90> & co"
    sizes = browser.evaluate("Promise.all(Array.from(document.images).map(i => i.decode().then(() => "
                             "i.naturalWidth, () => 0)))")
    assert len(sizes) == 4 and min(sizes) > 300
    # the full-size links point at the run's PNG files beside the report (the page alone embeds them)
    hrefs = browser.evaluate("Array.from(document.images).map(i => i.closest('a').getAttribute('href'))")
    assert len(hrefs) == 4 and all((out / h).is_file() and h.endswith(".png") for h in hrefs), hrefs
    assert png_info(browser.screenshot(tmp_path / "inline.png")).size == (1280, 1600)


def test_harness_sees_console_errors(browser, tmp_path):
    """The check can fail: a broken image, console.error and an exception are all reported."""
    page = tmp_path / "bad.html"
    page.write_text("<!DOCTYPE html><html><head><link rel=\"icon\" href=\"data:,\"></head><body>"
                    "<img src=\"missing.png\"><script>console.error('boom'); undefinedFunction();</script>"
                    "</body></html>")
    browser.load(page.as_uri())
    errors = browser.console_errors()
    assert any("boom" in e for e in errors), errors
    assert any("undefinedFunction" in e for e in errors), errors
    assert any("missing.png" in e for e in errors), errors


def test_sweep_page_loads_without_console_errors(browser, tmp_path):
    from tests.conftest import bhr_exe

    proc = subprocess.run(bhr_exe() + ["sweep", "--grid", "modules=4:6", "--grid", "alpha=9,11", "--jobs", "1",
                                       "--title", "<sweep> & test", "--out", str(tmp_path / "s")],
                          capture_output=True, text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))
    assert proc.returncode == 0, proc.stderr
    browser.load((tmp_path / "s" / "index.html").as_uri())
    assert browser.console_errors() == []
    assert browser.evaluate("document.querySelector('h1').textContent") == "<sweep> & test"
    size = browser.evaluate("document.images[0].decode().then(() => [document.images[0].naturalWidth, "
                            "document.images[0].naturalHeight])")
    assert size[0] > 300 and size[1] > 300
    assert browser.evaluate("document.querySelectorAll('#designs tbody tr').length") == 6
    heads = browser.evaluate("Array.from(document.querySelectorAll('th')).map(t => t.textContent)")
    assert "alpha (deg)" in heads and "worst point error (mm)" in heads and not [h for h in heads if "_" in h]
    # the ranking column (worst point error) shows without scrolling sideways, in both tables
    right = browser.evaluate("Array.from(document.querySelectorAll('th.rank')).map(t => "
                             "t.getBoundingClientRect().right)")
    assert len(right) == 2 and max(right) <= 1280, right
    assert browser.evaluate("document.images[0].closest('a').getAttribute('href')") == "heatmap.png"
    check_fits(browser)
    assert png_info(browser.screenshot(tmp_path / "sweep.png")).size == (1280, 1600)
