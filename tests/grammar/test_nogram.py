import numpy as np

from robocompose.grammar.nogram import NogramConfig, enumerate_nogram, random_tree
from robocompose.grammar.tree import N_JOINT_TYPES


def test_random_trees_respect_the_neighbour_limit_and_root_token():
    for k in range(50):
        tree = random_tree(np.random.default_rng(k), 15)
        assert tree.tokens[0] % N_JOINT_TYPES == 0  # the root has no joint
        assert all(t % N_JOINT_TYPES != 0 for t in tree.tokens[1:])
        degree = [len(tree.children(i)) + (i > 0) for i in range(tree.n_links)]
        assert max(degree) <= 4


def test_nogram_sizes_follow_the_given_distribution_and_rows_are_empty_of_rules():
    designs, stats = enumerate_nogram(NogramConfig(n=10, seed=0), [11, 13], workers=1, progress=None)
    assert set(designs["n_links"]) <= {11, 13}
    assert all(len(r) == 0 for r in designs["rules"])
    assert stats.kept == 10
