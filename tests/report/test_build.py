from robocompose.report.build import to_html


def test_html_renders_tables_and_images():
    html = to_html("# T\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n![g](figures/g.png)\n", "title")
    assert "<table>" in html and "<td>1</td>" in html and 'src="figures/g.png"' in html
    assert html.startswith("<!doctype html>") and "<title>title</title>" in html
