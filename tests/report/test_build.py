import re
from pathlib import Path

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


def test_the_report_renders_in_a_real_browser_with_every_image_and_table(in_browser):
    assert REPORT_HTML.is_file(), "reports/report.html is committed by the report stage"
    page = in_browser(REPORT_HTML, CHECK_PAGE)
    referenced = set(re.findall(r'<img[^>]*src="([^"]+)"', REPORT_HTML.read_text()))
    assert referenced and {src for src, _, _ in page["images"]} == referenced
    broken = [src for src, width, height in page["images"] if not (width and height)]
    assert not broken, f"images that did not load: {broken}"
    assert page["tables"] and all(rows >= 2 and cells >= 2 for rows, cells in page["tables"]), page["tables"]
    assert page["markdown_tables"] == 0, "a markdown table was left unrendered as text"


def test_the_browser_check_sees_a_missing_image(tmp_path, in_browser):
    (tmp_path / "figures").mkdir()
    (tmp_path / "report.html").write_text(to_html("| a | b |\n|---|---|\n| 1 | 2 |\n\n![g](figures/none.png)\n", "t"))
    page = in_browser(tmp_path / "report.html", CHECK_PAGE)
    assert page["images"] == [["figures/none.png", 0, 0]] and page["tables"] == [[2, 2]]
