import dataclasses

import pytest

from robocompose.grammar import rules, vocabulary
from robocompose.grammar.rules import axis_angle
from robocompose.grammar.tree import token_of


def test_vocabulary_of_robogrammars_rules():
    v = vocabulary.vocabulary()
    assert v.root == token_of(1, 0) and (v.mount, v.mount_twin) == (29, 30)
    assert set(v.next_body) == {token_of(1, j) for j in (1, 3, 4, 5)}  # fixed, roll, swing, lift
    assert v.limb_links == {2: 8, 0: 9} and sorted(v.limb_joints.values()) == list(range(14, 20))
    assert v.mount_links == 2 and v.mirror(token_of(2, 6)) == token_of(2, 7)  # a left roll mirrors to a right roll


def test_a_changed_rule_changes_the_vocabulary(monkeypatch):
    """Re-angle the acute lift (rule 17) to the obtuse angle: the decoder's limb tokens follow the rules."""
    changed = list(rules.RULES)
    edge = next(e for e in changed[17].edges if e.side == "R")
    changed[17] = dataclasses.replace(changed[17], edges=tuple(
        dataclasses.replace(e, attrs={**e.attrs, "joint_rot": axis_angle(0, 0, 1, 60)}) if e is edge else e
        for e in changed[17].edges))
    monkeypatch.setattr(vocabulary, "RULES", tuple(changed))
    vocabulary.vocabulary.cache_clear()
    try:
        v = vocabulary.vocabulary()
        assert 8 not in v.limb_joints and v.limb_joints[10] in (17, 18)  # acute lift (joint type 8) is gone
    finally:
        vocabulary.vocabulary.cache_clear()


def test_a_rule_set_of_another_shape_fails_naming_the_rule(monkeypatch):
    monkeypatch.setattr(vocabulary, "RULES", tuple(r for r in rules.RULES if r.name != "end_head"))
    vocabulary.vocabulary.cache_clear()
    try:
        with pytest.raises(ValueError, match="removes the head"):
            vocabulary.vocabulary()
    finally:
        vocabulary.vocabulary.cache_clear()
