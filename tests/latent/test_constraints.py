import numpy as np
import pytest

from robocompose.grammar.derivation import derive
from robocompose.grammar.tree import DesignTree
from robocompose.latent.constraints import (
    MOUNT,
    MOUNT_TWIN,
    Walk,
    grammar_rules,
    is_derivable,
    mirror_token,
    replay,
    stop_predictions,
)


def test_rule_sequences_derive_the_same_designs(trees):
    for tree in trees:
        assert derive(grammar_rules(tree)).tree.design_id == tree.design_id


def test_replay_walks_every_grammar_tree_and_rebuilds_it(trees):
    for tree in trees:
        r = replay(tree, "grammar", 50)
        assert len(r.stop_free) == 2 * tree.n_links - 1 == len(stop_predictions(r.children))
        assert r.label_masks[np.arange(tree.n_links), r.tokens].all()  # each target label allowed
        walk = Walk("grammar", 50)
        for step, token in _actions(r):
            walk.push(token) if step == "push" else walk.pop()
        assert walk.tree().design_id == tree.design_id


def _actions(r):
    out = [("push", r.tokens[0])]

    def visit(x):
        for c in r.children[x]:
            out.append(("push", r.tokens[c]))
            visit(c)
        out.append(("pop", None))

    visit(0)
    return out


def test_mirrored_side_is_forced(trees):
    tree = next(t for t in trees if MOUNT in t.tokens)
    r = replay(tree, "grammar", 50)
    twin = r.tokens.index(MOUNT_TWIN)
    # From the twin mount down, every label mask holds exactly one token, the mirror of the other side.
    mount = r.tokens.index(MOUNT)
    assert r.label_masks[twin].sum() == 1
    assert mirror_token(r.tokens[r.children[mount][0]]) == r.tokens[r.children[twin][0]]
    assert r.label_masks[r.children[twin][0]].sum() == 1


def test_non_grammar_trees_are_rejected_with_reason(nogram_trees):
    assert not any(is_derivable(t) for t in nogram_trees)
    bad = DesignTree((-1, 0), (14, 29))  # a lone mount without its twin
    with pytest.raises(ValueError, match="do not allow"):
        grammar_rules(bad)
    for t in nogram_trees:
        replay(t, "tree", 50)  # the free constraints take any tree with <= 4 neighbours


def test_random_walks_always_finish_within_budget():
    rng = np.random.default_rng(1)
    for kind, budget in [("grammar", 12), ("grammar", 50), ("tree", 9)]:
        for _ in range(60):
            walk = Walk(kind, budget)
            walk.push(int(rng.choice(np.flatnonzero(walk.root_labels()))))
            while not walk.done:
                may_stop, may_expand, labels = walk.options()
                if may_expand and (not may_stop or rng.random() < 0.7):
                    walk.push(int(rng.choice(np.flatnonzero(labels))))
                else:
                    walk.pop()
            tree = walk.tree()
            assert tree.n_links <= budget
            if kind == "grammar":
                assert derive(grammar_rules(tree)).tree.design_id == tree.design_id


def test_walk_refuses_disallowed_steps():
    walk = Walk("grammar", 50)
    with pytest.raises(ValueError, match="not allowed"):
        walk.push(15)  # the root must be the root body
    walk.push(14)
    walk.push(MOUNT)
    with pytest.raises(ValueError, match="may not stop"):
        walk.pop()  # a mount needs its limb
    with pytest.raises(ValueError, match="constraints must be"):
        Walk("free", 5)
