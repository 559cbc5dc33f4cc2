from robocompose.dataset.enumerate import MIN_LINKS
from robocompose.glso.designs import self_colliding
from robocompose.glso.random_search import RandomConfig, RandomSearch
from robocompose.grammar.derivation import derive
from robocompose.sim.contacts import contact_features
from robocompose.sim.physics import connect


def test_random_designs_pass_the_dataset_filters_and_derive_from_their_rules():
    search, client = RandomSearch(RandomConfig(), seed=0, budget=5, env=None), connect()
    for _ in range(5):
        p = search.propose(None)
        assert p.tree.n_links >= MIN_LINKS and len(p.rules) <= 40
        assert contact_features(p.tree, client).valid and not self_colliding(p.tree)
        assert derive(p.rules).tree == p.tree


def test_each_run_seed_draws_its_own_designs():
    a, b = (RandomSearch(RandomConfig(), seed=s, budget=3, env=None) for s in (0, 1))
    assert [a.propose(None).tree.design_id for _ in range(3)] != [b.propose(None).tree.design_id for _ in range(3)]
