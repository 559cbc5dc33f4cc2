import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.tree import N_TOKENS, DesignTree, split_token


def test_forty_two_tokens():
    assert N_TOKENS == 42


def test_design_id_ignores_sibling_order():
    a = DesignTree((-1, 0, 0, 1), (14, 29, 30, 32))
    b = DesignTree((-1, 0, 0, 2), (14, 30, 29, 32))  # same tree, children of the root swapped
    assert a.design_id == b.design_id
    c = DesignTree((-1, 0, 0, 1), (14, 29, 30, 33))
    assert c.design_id != a.design_id


def test_mirrored_legs_are_twins(reference_rules):
    tree = derive(parse_rules(reference_rules)).tree
    mounts = [i for i, t in enumerate(tree.tokens) if split_token(t)[1] in (1, 2) and split_token(t)[0] == 2]
    plain = [i for i in mounts if split_token(tree.tokens[i])[1] == 1]
    mirrored = [i for i in mounts if split_token(tree.tokens[i])[1] == 2]
    assert len(plain) == len(mirrored) > 0  # every leg has a mirrored twin


def test_body_mass_is_normalised(reference_rules):
    links = derive(parse_rules(reference_rules)).tree.links()
    assert sum(lk.mass for lk in links if lk.radius == 0.045) == pytest.approx(0.45)


@pytest.mark.parametrize(("parents", "tokens", "message"), [
    ((0,), (14,), "root first"),
    ((-1, 1), (14, 15), "parent before"),
    ((-1,), (42,), "0..41"),
    ((-1, 0), (14,), "one parent and one token"),
])
def test_invalid_trees_are_rejected(parents, tokens, message):
    with pytest.raises(ValueError, match=message):
        DesignTree(parents, tokens)


def test_tokens_off_their_grammar_place_build_as_glso_builds_them():
    """No-grammar designs put any token anywhere: the root's joint type is ignored (it is the free base),
    and the root joint type off the root is GLSO's joint type 0, a rigid mount at the parent's middle."""
    grammar = DesignTree((-1, 0), (14, 29)).links()  # a body with a limb mount (fixed, middle, turned)
    anywhere = DesignTree((-1, 0), (15, 28)).links()  # root with a fixed joint type; child with the root's
    assert anywhere[0].joint_kind == "none" and DesignTree((-1, 0), (17, 31)).n_joints == 1
    assert (anywhere[1].joint_kind, anywhere[1].joint_pos, anywhere[1].joint_rot) == (
        "fixed", 0.5, grammar[1].joint_rot)


def test_canonical_order_is_the_same_for_every_sibling_order(reorder):
    from robocompose.grammar.derivation import derive, parse_rules
    from robocompose.grammar.references import REFERENCE_DESIGNS

    tree = derive(parse_rules(REFERENCE_DESIGNS["robogrammar_ridged"])).tree
    other = reorder(tree)
    assert other.tokens != tree.tokens and other.design_id == tree.design_id
    assert other.canonical_order() == tree.canonical_order()
    assert tree.canonical_order().canonical_order() == tree.canonical_order()
    assert tree.canonical_order().design_id == tree.design_id
