import pytest

from robocompose.report.tables import markdown_table


def test_a_table_formats_each_column_and_aligns_the_separator():
    lines = markdown_table(["method", "design", "p", "share", "n"],
                           [("GA", "lwblwb", 0.01234, 0.5, 3), ("MCTS", "wwwwww", 1.0, 0.25, 10)],
                           formats=[None, "`{}`", "{:.3f}", lambda v: f"{v:.0%}"], align="llllr")
    assert lines == ["| method | design | p | share | n |", "|---|---|---|---|---:|",
                     "| GA | `lwblwb` | 0.012 | 50% | 3 |", "| MCTS | `wwwwww` | 1.000 | 25% | 10 |"]


def test_a_table_without_rows_is_its_header():
    assert markdown_table(["a", "b"], []) == ["| a | b |", "|---|---|"]


@pytest.mark.parametrize(("rows", "formats", "align", "match"), [
    ([("x",)], (), "", "a row of 1 values"),
    ([], ["{}"] * 3, "", "3 formats"),
    ([], (), "lc", "l or r per column"),
])
def test_a_mismatched_row_or_spec_is_an_error(rows, formats, align, match):
    with pytest.raises(ValueError, match=match):
        markdown_table(["a", "b"], rows, formats, align)
