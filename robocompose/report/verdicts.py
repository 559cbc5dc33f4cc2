"""One form for every claim the report tests, and the summary that leads the report with them.

A section states a claim it tested (the thesis's, or a goal of ours) with `verdict`: one line
`{claim}: **{outcome}** {detail}`, the outcome one of `OUTCOMES`. `summary` finds those lines in the rendered
sections (`find`), each under its nearest `## ` heading, and lists them what-does-not-hold first, so the report opens
with what does not hold (the house rule) without a second copy of any section's logic.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

OUTCOMES = ("does NOT hold", "not shown", "holds")  # the summary's order: what does not hold leads
_LINE = re.compile(r"^(?:- )?(?P<claim>[^*\n]+?): \*\*(?P<outcome>does NOT hold|not shown|holds)\*\*(?P<detail>.*)$")
TITLE = "## Verdicts: what does not hold first"


def verdict(claim: str, outcome: str, detail: str = "") -> str:
    """The line stating `claim`'s `outcome` (one of `OUTCOMES`), then `detail` (the numbers it rests on)."""
    if outcome not in OUTCOMES:
        raise ValueError(f"outcome: expected one of {list(OUTCOMES)}, found {outcome!r}")
    if "*" in claim or "\n" in claim or not claim.strip():
        raise ValueError(f"claim: expected one line of text without '*', found {claim!r}")
    return f"{claim}: **{outcome}**" + (f" {detail}" if detail else "")


def held(holds: bool) -> str:
    """The outcome of a claim that was tested and either held or did not."""
    return "holds" if holds else "does NOT hold"


@dataclass(frozen=True)
class Found:
    """A verdict line found in the report: the `## ` section it stands in, its claim, outcome and detail."""

    section: str
    claim: str
    outcome: str
    detail: str


def find(markdown: str) -> list[Found]:
    """Every verdict line of `markdown`, in order, with the `## ` heading above it ('' before any)."""
    section, found = "", []
    for line in markdown.splitlines():
        if line.startswith("## "):
            section = line[3:].strip()
        elif match := _LINE.match(line):
            found.append(Found(section, match["claim"].strip(), match["outcome"], match["detail"].strip()))
    return found


def summary(markdown: str) -> str:
    """The report's opening list: every verdict of `markdown`, what does not hold first, then what was not shown,
    then what holds (report order within each); each with its section and its numbers."""
    found = sorted(find(markdown), key=lambda f: OUTCOMES.index(f.outcome))
    if not found:
        return f"{TITLE}\n\nNo section states a tested claim yet (no stage has run).\n"
    lines = [TITLE, "", "Every claim a section below tests, with the numbers it rests on; each section says the "
             "settings and the evaluator.", ""]
    lines += [f"- **{f.outcome}**: {f.claim} ({f.section})" + (f" {f.detail}" if f.detail else "") for f in found]
    return "\n".join(lines) + "\n"
