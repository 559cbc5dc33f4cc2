from robocompose.glso.designs import MIN_LINKS, rejection
from robocompose.glso.random_search import RandomConfig, RandomSearch
from robocompose.grammar.derivation import derive


def test_random_designs_pass_the_dataset_filters_and_derive_from_their_rules():
    search = RandomSearch(RandomConfig(), seed=0, budget=5)
    for _ in range(5):
        p = search.propose(None)
        assert p.tree.n_links >= MIN_LINKS and len(p.rules) <= 40
        assert rejection(p.tree, dataset_filters=True) == ""
        assert derive(p.rules).tree == p.tree
