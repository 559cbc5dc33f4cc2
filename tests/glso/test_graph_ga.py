import numpy as np
import pytest

from robocompose.glso.graph_ga import MAX_NEIGHBOURS, GAConfig, GraphGA, mutate
from robocompose.grammar.derivation import derive
from robocompose.grammar.tree import split_token
from tests.conftest import FLAT_REFERENCE

TREE = derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).tree


def test_mutations_give_valid_trees_in_the_nge_ratios():
    rng, config = np.random.default_rng(0), GAConfig()
    sizes = []
    for _ in range(300):
        child = mutate(TREE, rng, config)  # DesignTree checks parents/tokens/root itself
        assert all(len(child.children(i)) + (i > 0) <= MAX_NEIGHBOURS for i in range(child.n_links))
        assert split_token(child.tokens[0]) == split_token(TREE.tokens[0])
        sizes.append(np.sign(child.n_links - TREE.n_links))
    grew, shrank, same = (np.mean(np.array(sizes) == s) for s in (1, -1, 0))
    assert 0.12 < grew < 0.28 and 0.12 < shrank < 0.28 and 0.5 < same < 0.7


def test_remove_never_leaves_the_root_alone_and_add_respects_max_nodes():
    rng = np.random.default_rng(1)
    two = derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).tree
    for _ in range(100):
        two = mutate(two, rng, GAConfig(add_probability=0.0, remove_probability=1.0))
        assert two.n_links >= 2
    capped = GAConfig(add_probability=1.0, remove_probability=0.0, max_nodes=TREE.n_links)
    assert mutate(TREE, rng, capped).n_links == TREE.n_links


def test_generations_cull_the_worst_and_refill_from_survivors():
    ga = GraphGA(GAConfig(population=4, cull_fraction=0.5), seed=0, budget=8, env=None)
    scores = iter([1.0, 4.0, 2.0, 3.0, 0.5, 0.6])
    initial = []
    for _ in range(4):
        p = ga.propose(None)
        initial.append(p)
        ga.tell(p, next(scores))
    child = ga.propose(None)
    assert ga.generation == 1 and [s for _, s in ga.population] == [4.0, 3.0]
    assert child.rules is None and len(ga.queue) == 1


@pytest.mark.parametrize("bad", [{"population": 1}, {"cull_fraction": 1.0}])
def test_bad_ga_settings_fail(bad):
    with pytest.raises(ValueError):
        GAConfig(**bad)
