"""Shared fixtures: the two reference designs of the RoboGrammar/GLSO papers."""

import pytest

from robocompose.report.dataset import REFERENCE_DESIGNS

FLAT_REFERENCE = REFERENCE_DESIGNS["flat (reference)"]
RIDGED_REFERENCE = REFERENCE_DESIGNS["ridged (reference)"]


@pytest.fixture(params=[FLAT_REFERENCE, RIDGED_REFERENCE], ids=["flat", "ridged"])
def reference_rules(request) -> str:
    return request.param
