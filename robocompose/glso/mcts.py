"""MCTS over the grammar's derivation tree, as RoboGrammar's `TreeSearch` (examples/design_search/mcts.py).

A state is a (possibly incomplete) design graph; its actions are the rules applicable at their first
match while the derivation is shorter than the depth limit (40). Tree nodes are keyed by the graph
itself (a transposition table: rule orders that reach one graph share its statistics).

One iteration = one evaluated design:
1. Selection: from the start graph, while the state has a tree node, take the action with the highest
       (1 - w) * max_a + w * amaf_max_a + sqrt(2 ln N / n_a),   w = sqrt(k / (3 N + k)), k = 10,
   unvisited actions first (+inf; the lowest rule index breaks ties), skipping actions into blocked nodes.
   Only maxima of results are used, never means (the original stores sums but scores with maxes).
2. Expansion: the first state without a node gets one (exactly one node per iteration).
3. Rollout: uniformly random actions to a terminal state, redrawn (up to 1000 times) until the design is
   complete and does not self-penetrate; if none is, the expanded node is blocked and the iteration restarts.
4. Backpropagation of the result (`tell`): every state on the path that has a node updates N, n_a, max_a,
   and its AMAF statistics once for each distinct action taken from it onwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robocompose.glso.designs import MAX_TRIES, Proposal, self_colliding
from robocompose.grammar.derivation import MAX_DEPTH, graph_to_tree
from robocompose.grammar.rules import RULES, START_GRAPH, Graph, apply_rule, first_match

N_RULES = len(RULES)


@dataclass(frozen=True)
class MCTSConfig:
    max_depth: int = MAX_DEPTH  # rule-sequence length limit (RoboGrammar's -d 40)
    amaf_threshold: float = 10.0  # k in the AMAF weight sqrt(k / (3N + k))


@dataclass
class Node:
    """Statistics of one state: visits, and per action (rule) visits, max result and AMAF visits/max."""

    visits: int = 0
    action_visits: np.ndarray = field(default_factory=lambda: np.zeros(N_RULES, dtype=np.int64))
    action_max: np.ndarray = field(default_factory=lambda: np.full(N_RULES, -np.inf))
    amaf_visits: np.ndarray = field(default_factory=lambda: np.zeros(N_RULES, dtype=np.int64))
    amaf_max: np.ndarray = field(default_factory=lambda: np.full(N_RULES, -np.inf))
    blocked: bool = False


def successors(graph: Graph, n_rules: int, max_depth: int) -> dict[int, Graph]:
    """Action (rule) -> next state, for every rule applicable at its first match (none at the depth limit)."""
    if graph.complete or n_rules >= max_depth:
        return {}
    out, matches = {}, {}
    for r, rule in enumerate(RULES):
        if rule.match_key not in matches:  # rules with one left side share their first match
            matches[rule.match_key] = first_match(rule, graph)
        if matches[rule.match_key] is not None:
            out[r] = apply_rule(rule, graph, matches[rule.match_key])
    return out


class TreeSearch:
    def __init__(self, config: MCTSConfig, seed: int, budget: int) -> None:
        self.config = config
        self.rng = np.random.default_rng([seed, 0x4D435453])  # "MCTS"
        self.nodes: dict[Graph, Node] = {}

    def _select(self, graph: Graph, children: dict[int, Graph]) -> int:
        node = self.nodes[graph]
        actions = [a for a, child in children.items() if not (child in self.nodes and self.nodes[child].blocked)]
        if not actions:
            raise RuntimeError("MCTS: every action of a state is blocked (no valid design below it)")
        k = self.config.amaf_threshold
        w = math.sqrt(k / (3 * node.visits + k))
        best, best_score = actions[0], -math.inf
        for a in actions:
            n = node.action_visits[a]
            if n == 0:
                return a  # each child is tried once first (+inf), lowest rule index first
            score = ((1 - w) * node.action_max[a] + w * node.amaf_max[a]
                     + math.sqrt(2 * math.log(node.visits) / n))
            if score > best_score:
                best, best_score = a, score
        return best

    def propose(self, env) -> Proposal:
        depth = self.config.max_depth
        while True:
            graph, rules, states = START_GRAPH, [], []
            if graph not in self.nodes:
                self.nodes[graph] = Node()
            while graph in self.nodes:  # selection
                children = successors(graph, len(rules), depth)
                if not children:
                    break
                action = self._select(graph, children)
                states.append(graph)
                rules.append(action)
                graph = children[action]
            self.nodes.setdefault(graph, Node())  # expansion: one new node
            expanded, prefix = graph, list(rules)
            for _ in range(MAX_TRIES):  # rollout, redrawn until valid
                graph, rules, path = expanded, list(prefix), list(states)
                while children := successors(graph, len(rules), depth):
                    action = list(children)[int(self.rng.integers(len(children)))]
                    path.append(graph)
                    rules.append(action)
                    graph = children[action]
                if graph.complete:
                    tree = graph_to_tree(graph)
                    if not self_colliding(tree):
                        return Proposal(tree, tuple(rules), info=path)
            self.nodes[expanded].blocked = True

    def tell(self, proposal: Proposal, score: float) -> None:
        path, rules = proposal.info, proposal.rules
        for i, (graph, action) in enumerate(zip(path, rules, strict=True)):
            node = self.nodes.get(graph)
            if node is None:
                continue
            node.visits += 1
            node.action_visits[action] += 1
            node.action_max[action] = max(node.action_max[action], score)
            for later in set(rules[i:]):
                node.amaf_visits[later] += 1
                node.amaf_max[later] = max(node.amaf_max[later], score)
