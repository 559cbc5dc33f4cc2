import math

import numpy as np

from robocompose.glso.mcts import MCTSConfig, TreeSearch, successors
from robocompose.grammar.derivation import derive
from robocompose.grammar.rules import START_GRAPH
from tests.conftest import FLAT_REFERENCE


def _run(search: TreeSearch, n: int, score=lambda p: 4.0 + 0.01 * p.tree.n_links) -> list:
    out = []
    for _ in range(n):
        proposal = search.propose(None)
        search.tell(proposal, score(proposal))
        out.append(proposal)
    return out


def test_successors_follow_the_grammar_and_stop_at_the_depth_limit():
    rules = tuple(int(r) for r in FLAT_REFERENCE.split(","))
    graph = derive(rules[:3], require_complete=False).graph
    nxt = successors(graph, 3, 40)
    assert rules[3] in nxt and nxt[rules[3]] == derive(rules[:4], require_complete=False).graph
    assert successors(graph, 40, 40) == {}


def test_every_root_action_is_tried_once_before_any_is_repeated_and_one_node_is_added_per_iteration():
    search = TreeSearch(MCTSConfig(), seed=0, budget=10, env=None)
    n_root = len(successors(START_GRAPH, 0, 40))
    proposals = _run(search, n_root)
    assert sorted(p.rules[0] for p in proposals) == sorted(successors(START_GRAPH, 0, 40))
    assert len(search.nodes) == 1 + n_root  # the root, then exactly one expanded node per iteration


def test_backpropagation_keeps_visit_counts_maxima_and_amaf():
    search = TreeSearch(MCTSConfig(), seed=1, budget=10, env=None)
    proposals = _run(search, 6, score=lambda p: float(len(p.rules)))
    root = search.nodes[START_GRAPH]
    assert root.visits == 6 and root.action_visits.sum() == 6
    first = proposals[0].rules[0]
    assert root.action_max[first] == max(len(p.rules) for p in proposals if p.rules[0] == first)
    assert (root.amaf_visits >= root.action_visits).all()  # a taken action also counts for AMAF


def test_selection_blends_max_and_amaf_with_the_amaf_weight():
    search = TreeSearch(MCTSConfig(amaf_threshold=10.0), seed=0, budget=10, env=None)
    _run(search, 12)
    node = search.nodes[START_GRAPH]
    children = successors(START_GRAPH, 0, 40)
    w = math.sqrt(10 / (3 * node.visits + 10))
    scores = {a: (1 - w) * node.action_max[a] + w * node.amaf_max[a]
              + math.sqrt(2 * math.log(node.visits) / node.action_visits[a]) for a in children}
    assert search._select_action(START_GRAPH, 0)[0] == max(scores, key=scores.get)


def test_mcts_is_reproducible_per_seed():
    a = [p.tree.design_id for p in _run(TreeSearch(MCTSConfig(), 3, 5, None), 5)]
    b = [p.tree.design_id for p in _run(TreeSearch(MCTSConfig(), 3, 5, None), 5)]
    assert a == b and np.unique(a).size > 1


def test_a_new_nodes_simulation_starts_with_its_first_untried_rule():
    search = TreeSearch(MCTSConfig(), seed=0, budget=10, env=None)
    first = search.propose(None)  # the start graph's rule, then the expanded node's lowest applicable rule
    expanded = successors(START_GRAPH, 0, 40)[first.rules[0]]
    assert expanded in search.nodes and first.rules[1] == min(successors(expanded, 1, 40))
