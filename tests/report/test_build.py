import re
from pathlib import Path

import pytest

from robocompose.report.build import to_html


def test_html_renders_tables_and_images():
    html = to_html("# T\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n![g](figures/g.png)\n", "title")
    assert "<table>" in html and "<td>1</td>" in html and 'src="figures/g.png"' in html
    assert html.startswith("<!doctype html>") and "<title>title</title>" in html


# --- the committed report in a real browser ---

REPORT_HTML = Path(__file__).resolve().parents[2] / "reports" / "report.html"
CHECK_PAGE = """new Promise(resolve => {
  const wait = () => Array.from(document.images).every(i => i.complete)
    ? resolve(JSON.stringify({
        images: Array.from(document.images).map(i => [i.getAttribute('src'), i.naturalWidth, i.naturalHeight]),
        tables: Array.from(document.querySelectorAll('table')).map(t => [t.rows.length, t.rows[0].cells.length]),
        markdown_tables: document.body.innerText.split('\\n').filter(l => /^\\s*\\|.*\\|\\s*$/.test(l)).length}))
    : setTimeout(wait, 50);
  wait();
})"""


def _chromium() -> str:
    import os
    import shutil

    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (.ci/run installs it from the distribution's packages)")
        pytest.skip("chromium is not installed (apt-get install chromium)")
    return found


def _cdp(ws_url: str, page_url: str) -> dict:
    """Open `page_url` in the browser tab at `ws_url` (DevTools protocol) and evaluate CHECK_PAGE."""
    import json

    from websockets.sync.client import connect

    events: set[str] = set()
    with connect(ws_url, max_size=None, open_timeout=30) as ws:
        def call(ident: int, method: str, **params) -> dict:
            ws.send(json.dumps({"id": ident, "method": method, "params": params}))
            while True:
                message = json.loads(ws.recv(timeout=60))
                if message.get("id") == ident:
                    assert "error" not in message, message
                    return message["result"]
                events.add(message.get("method", ""))

        call(1, "Page.enable")
        call(2, "Page.navigate", url=page_url)
        while "Page.loadEventFired" not in events:
            events.add(json.loads(ws.recv(timeout=60)).get("method", ""))
        result = call(3, "Runtime.evaluate", expression=CHECK_PAGE, awaitPromise=True, returnByValue=True)
    return json.loads(result["result"]["value"])


def check_in_browser(report: Path, profile: Path) -> dict:
    """What headless Chromium shows of `report`: each image's (src, width, height) and each table's size."""
    import json
    import socket
    import subprocess
    import time
    import urllib.request

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    browser = subprocess.Popen([_chromium(), "--headless=new", "--no-sandbox", "--disable-gpu",
                                f"--remote-debugging-port={port}", "--remote-debugging-address=127.0.0.1",
                                f"--user-data-dir={profile}", "about:blank"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=2) as response:
                    pages = [t for t in json.load(response) if t["type"] == "page"]
                if pages:
                    break
            except OSError:
                pass
            assert time.monotonic() < deadline and browser.poll() is None, "chromium did not start"
            time.sleep(0.2)
        return _cdp(pages[0]["webSocketDebuggerUrl"], report.as_uri())
    finally:
        browser.terminate()
        browser.wait(timeout=30)


def test_the_report_renders_in_a_real_browser_with_every_image_and_table(tmp_path):
    assert REPORT_HTML.is_file(), "reports/report.html is committed by the report stage"
    page = check_in_browser(REPORT_HTML, tmp_path / "profile")
    referenced = set(re.findall(r'<img[^>]*src="([^"]+)"', REPORT_HTML.read_text()))
    assert referenced and {src for src, _, _ in page["images"]} == referenced
    broken = [src for src, width, height in page["images"] if not (width and height)]
    assert not broken, f"images that did not load: {broken}"
    assert page["tables"] and all(rows >= 2 and cells >= 2 for rows, cells in page["tables"]), page["tables"]
    assert page["markdown_tables"] == 0, "a markdown table was left unrendered as text"


def test_the_browser_check_sees_a_missing_image(tmp_path):
    (tmp_path / "figures").mkdir()
    (tmp_path / "report.html").write_text(to_html("| a | b |\n|---|---|\n| 1 | 2 |\n\n![g](figures/none.png)\n", "t"))
    page = check_in_browser(tmp_path / "report.html", tmp_path / "profile")
    assert page["images"] == [["figures/none.png", 0, 0]] and page["tables"] == [[2, 2]]
