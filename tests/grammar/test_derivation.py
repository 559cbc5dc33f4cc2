import re

import numpy as np
import pytest

from robocompose.grammar.derivation import (
    MAX_RULES,
    DerivationError,
    applicable_rules,
    derive,
    parse_rules,
    random_derivation,
)
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.grammar.rules import START_GRAPH


def test_reference_designs_derive_to_complete_designs(reference_rules):
    derivation = derive(parse_rules(reference_rules))
    assert derivation.graph.complete
    tree = derivation.tree
    assert tree.n_links >= 11 and tree.n_joints > 0


def test_reference_designs_have_expected_structure():
    flat = derive(parse_rules(REFERENCE_DESIGNS["robogrammar_flat"])).tree
    ridged = derive(parse_rules(REFERENCE_DESIGNS["robogrammar_ridged"])).tree
    # flat: 8 chained bodies + 2 leg pairs of (mount + 2 links); ridged: 3 bodies with 3 leg pairs.
    assert (flat.n_links, flat.n_joints) == (18, 11)
    assert (ridged.n_links, ridged.n_joints) == (17, 12)


@pytest.mark.parametrize(("rules", "message"), [
    ("0,7,25", "step 2: rule 25 does not exist"),
    ("0,7,7", "step 2: rule 7 (end_head) is not applicable"),
    ("5", "step 0: rule 5 (end_limb) is not applicable"),
    ("0,7,1", "after 3 steps the design is incomplete"),
    ("0,x,1", "item 1 is 'x'"),
    ("-1", "step 0: rule -1 does not exist"),
])
def test_bad_sequences_name_the_step_and_rule(rules, message):
    with pytest.raises(DerivationError, match=re.escape(message)):
        derive(parse_rules(rules))


def test_truncated_reference_is_incomplete(reference_rules):
    with pytest.raises(DerivationError, match="incomplete"):
        derive(parse_rules(reference_rules)[:-1])


def test_random_derivation_is_seeded_and_complete():
    a = random_derivation(np.random.default_rng(7))
    b = random_derivation(np.random.default_rng(7))
    assert a is not None and a.rules == b.rules and a.graph.complete
    assert derive(a.rules).tree.design_id == a.tree.design_id  # a random derivation replays


def test_random_derivation_respects_depth_limit():
    results = [random_derivation(np.random.default_rng(k), max_depth=5) for k in range(20)]
    assert all(r is None or len(r.rules) <= 5 for r in results)
    assert any(r is None for r in results)


def test_only_make_robot_applies_to_the_start_graph():
    assert applicable_rules(START_GRAPH) == [0]


def test_a_rule_sequence_longer_than_the_limit_is_refused_before_it_is_parsed():
    assert parse_rules(",".join(["0"] * MAX_RULES)) == (0,) * MAX_RULES
    with pytest.raises(DerivationError, match=f"--rules: rule sequence of {MAX_RULES + 1} rules, expected at most "
                                              f"{MAX_RULES}"):
        parse_rules(",".join(["x"] * (MAX_RULES + 1)), "--rules")  # refused on its length, not on item 0
