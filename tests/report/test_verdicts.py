"""The report's verdict lines: one form, found again in the rendered report, listed what-does-not-hold first."""

import pytest

from robocompose.report.verdicts import OUTCOMES, find, held, summary, verdict


def test_a_verdict_is_found_again_with_its_section_claim_outcome_and_detail():
    text = "\n".join(["## GLSO", "",
                      "- flat, under held-out scoring: GLSO best of Fig. 8.1: " + "**not shown** (Random p = 0.2).",
                      "## Teams", "",
                      verdict("Goal (EG-GAN >= 95%; held-out seeds)", held(False), "EG-GAN reaches 97%."),
                      "A sentence that says something **holds** in passing is no verdict."])
    found = find(text)
    assert [(f.section, f.claim, f.outcome, f.detail) for f in found] == [
        ("GLSO", "flat, under held-out scoring: GLSO best of Fig. 8.1", "not shown", "(Random p = 0.2)."),
        ("Teams", "Goal (EG-GAN >= 95%; held-out seeds)", "does NOT hold", "EG-GAN reaches 97%.")]


def test_the_summary_lists_what_does_not_hold_first_and_is_not_itself_a_verdict():
    text = "\n".join(["## A", verdict("a holds", "holds"), verdict("a fails", held(False)),
                      "## B", verdict("b unclear", "not shown"), verdict("b fails", "does NOT hold", "(2 vs 3).")])
    lead = summary(text)
    bullets = [line for line in lead.splitlines() if line.startswith("- ")]
    assert bullets == ["- **does NOT hold**: a fails (A)", "- **does NOT hold**: b fails (B) (2 vs 3).",
                       "- **not shown**: b unclear (B)", "- **holds**: a holds (A)"]
    assert find(lead) == []  # the summary's lines are not found again as verdicts
    assert "no stage has run" in summary("## A\nno claims here")


@pytest.mark.parametrize(("claim", "outcome"), [("fine", "maybe"), ("with *stars*", "holds"), ("", "holds"),
                                                ("two\nlines", "holds")])
def test_a_verdict_refuses_an_unknown_outcome_or_a_claim_it_could_not_be_found_by(claim, outcome):
    with pytest.raises(ValueError):
        verdict(claim, outcome)
    assert set(OUTCOMES) == {"does NOT hold", "not shown", "holds"}
