"""The report's one way to write a markdown table: a header, rows of values, and how each column is formatted.

    markdown_table(["method", "p"], [("GA", 0.0123)], formats=["{}", "{:.3f}"], align="lr")
    -> ["| method | p |", "|---|---:|", "| GA | 0.012 |"]

A format is a `str.format` template of one value ("{:.2f}", "`{}`", "{:.0%}") or a function of the value; a column
without one shows `str(value)`. `align` gives each column "l" (markdown's default) or "r".
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

Format = str | Callable[[Any], str] | None
_SEPARATORS = {"l": "---", "r": "---:"}


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[Any]], formats: Sequence[Format] = (),
                   align: str = "") -> list[str]:
    """The lines of a markdown table (header, separator, one line per row); see the module docstring."""
    width = len(header)
    if len(formats) > width or len(align) > width or set(align) - set(_SEPARATORS):
        raise ValueError(f"table of {width} columns: {len(formats)} formats and align {align!r} (l or r per column)")
    formats = [*formats, *[None] * (width - len(formats))]
    separators = [_SEPARATORS[a] for a in align.ljust(width, "l")]
    lines = [_line(header), "|" + "|".join(separators) + "|"]
    for row in rows:
        if len(row) != width:
            raise ValueError(f"table of {width} columns ({', '.join(header)}): a row of {len(row)} values {row!r}")
        lines.append(_line([_cell(value, f) for value, f in zip(row, formats, strict=True)]))
    return lines


def _cell(value: Any, format_: Format) -> str:
    if format_ is None:
        return str(value)
    return format_(value) if callable(format_) else format_.format(value)


def _line(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"
