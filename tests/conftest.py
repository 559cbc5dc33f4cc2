"""Shared fixtures: the two reference designs of the RoboGrammar/GLSO papers."""

import pytest

from robocompose.evaluation.references import REFERENCE_DESIGNS

FLAT_REFERENCE = REFERENCE_DESIGNS["robogrammar_flat"]
RIDGED_REFERENCE = REFERENCE_DESIGNS["robogrammar_ridged"]


@pytest.fixture(params=[FLAT_REFERENCE, RIDGED_REFERENCE], ids=["flat", "ridged"])
def reference_rules(request) -> str:
    return request.param
