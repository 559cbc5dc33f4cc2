import numpy as np

from robocompose.dataset.nogram import MAX_NODES, MIN_NODES, NogramConfig, enumerate_nogram, random_graph
from robocompose.grammar.tree import N_JOINT_TYPES, N_TOKENS


def _sample(n: int) -> list:
    rng = np.random.default_rng(0)
    return [random_graph(rng) for _ in range(n)]


def test_sizes_are_uniform_on_two_to_twenty_four():
    sizes = np.array([t.n_links for t in _sample(4000)])
    assert sizes.min() == MIN_NODES == 2 and sizes.max() == MAX_NODES == 24
    counts = np.bincount(sizes, minlength=25)[2:]
    assert counts.min() > 0.6 * counts.mean()  # 23 sizes, ~174 each


def test_any_token_anywhere_root_included():
    trees = _sample(600)
    roots = {t.tokens[0] for t in trees}
    assert len(roots) == N_TOKENS  # the root takes every token, not only the root joint type
    off_root = [tok for t in trees for tok in t.tokens[1:]]
    assert any(tok % N_JOINT_TYPES == 0 for tok in off_root)  # and the root joint type appears off the root
    assert set(off_root) == set(range(N_TOKENS))


def test_child_budget_three_or_four_at_the_root():
    trees = _sample(2000)
    assert max(len(t.children(0)) for t in trees) == 4
    assert max(len(t.children(i)) for t in trees for i in range(1, t.n_links)) == 3


def test_parents_precede_children_and_are_drawn_among_all_earlier_nodes():
    trees = [t for t in _sample(2000) if t.n_links >= 6]
    assert all(p < i for t in trees for i, p in enumerate(t.parents) if i)
    # Node 5's parent is uniform over nodes 0..4 (redrawn only if full): every one of them occurs.
    assert {t.parents[5] for t in trees} == {0, 1, 2, 3, 4}


def test_designs_carry_no_contacts_and_no_rules():
    designs, stats = enumerate_nogram(NogramConfig(n=20, seed=0), progress=None)
    assert stats.kept == 20 and designs["design_id"].is_unique
    assert all(len(r) == 0 for r in designs["rules"])
    assert all(np.isnan(c).all() for c in designs["contacts"])
