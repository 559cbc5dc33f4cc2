import numpy as np
import pytest
import torch

from robocompose.glso.graph_ga import MAX_NEIGHBOURS, GAConfig, GraphGA, ValueNet, mutate
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


def _evaluate_generation(ga: GraphGA, scores) -> None:
    for score in scores:
        ga.tell(ga.propose(None), score)


def test_pruning_fills_the_free_slots_from_more_children_and_counts_the_others():
    ga = GraphGA(GAConfig(population=4, cull_fraction=0.5, candidates=3), seed=0, budget=12, env=None)
    _evaluate_generation(ga, [1.0, 4.0, 2.0, 3.0])
    child = ga.propose(None)  # generation 1: 2 slots, 6 buildable children made, 4 pruned
    assert ga.generation == 1 and len(ga.queue) == 1 and child.rejected >= 4


def test_pruning_keeps_the_children_the_network_values(monkeypatch):
    """With V = 100 x links the Gumbel noise (tau 0.1) cannot reorder: the largest children fill the slots."""
    ga = GraphGA(GAConfig(population=6, cull_fraction=0.5, candidates=4), seed=1, budget=30, env=None)
    _evaluate_generation(ga, [1.0, 4.0, 2.0, 3.0, 5.0, 0.5])
    made = []
    real_prune = ga._prune

    def watched(children, slots):
        made.extend(children)
        return real_prune(children, slots)

    monkeypatch.setattr(ga, "_prune", watched)
    monkeypatch.setattr(ga, "_train_value", lambda: None)
    monkeypatch.setattr(ga.value, "forward", lambda trees, mask=None: torch.tensor(
        [100.0 * t.n_links for t in trees]))
    kept = [ga.propose(None).tree for _ in range(3)]
    sizes = sorted((t.n_links for t in made), reverse=True)
    assert len(made) == 12 and sorted(t.n_links for t in kept) == sorted(sizes[:3])


def _near_root_wheels(tree) -> float:
    """Share of the links within 2 joints of the root whose link type is odd: what a root readout after a
    few propagation steps of mean messages can see (a count of all links it cannot)."""
    depth = [0] * tree.n_links
    for i in range(1, tree.n_links):
        depth[i] = depth[tree.parents[i]] + 1
    near = [split_token(t)[0] % 2 for t, d in zip(tree.tokens, depth, strict=True) if d <= 2]
    return float(np.mean(near))


def test_the_value_network_learns_to_rank_designs():
    """NGE's gated graph network, trained on a score of the designs' structure near the root, ranks unseen
    designs by it."""
    from scipy.stats import spearmanr

    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    designs, tree = [], TREE
    for _ in range(160):
        tree = mutate(tree, rng, GAConfig(max_nodes=30))
        designs.append(tree)
    train, test = designs[:120], designs[120:]
    net = ValueNet(32)
    adam = torch.optim.Adam(net.parameters(), lr=3e-3)
    target = torch.tensor([_near_root_wheels(t) for t in train])
    target = (target - target.mean()) / target.std()
    for _ in range(150):
        loss = torch.mean((net(train) - target) ** 2)
        adam.zero_grad()
        loss.backward()
        adam.step()
    with torch.no_grad():
        predicted = net(test).numpy()
    assert spearmanr(predicted, [_near_root_wheels(t) for t in test]).statistic > 0.7  # 0.84 measured
