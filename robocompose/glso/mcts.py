"""MCTS over the grammar's derivation tree, as RoboGrammar's `TreeSearch` (examples/design_search/mcts.py).

A state is a (possibly incomplete) design graph; its actions are the rules applicable at their first
match while the derivation is shorter than the depth limit (40). Tree nodes are keyed by the graph
itself (a transposition table: rule orders that reach one graph share its statistics).

One iteration = one evaluated design:
1. Selection: from the start graph, while the state has a tree node, take the action with the highest
       (1 - w) * max_a + w * amaf_max_a + sqrt(2 ln N / n_a),   w = sqrt(k / (3 N + k)), k = 10,
   unvisited actions first (+inf; the first maximum, i.e. the lowest rule index, wins ties), skipping
   actions into blocked nodes. Only maxima of results are used, never means (the original stores sums
   but scores with maxes).
2. Expansion: the first state without a node gets one (exactly one node per iteration).
3. Simulation: the same action choice to a terminal state: the tree policy at states with a node (so the
   new node's first untried rule, and transpositions), uniformly random elsewhere; redrawn (up to 1000
   times) until the design is complete and does not self-penetrate; if none is, the expanded node is
   blocked and the iteration restarts.
4. Backpropagation of the result (`tell`): every state on the path that has a node updates N, n_a, max_a,
   and its AMAF statistics once for each distinct action taken from it onwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from robocompose.glso.designs import MAX_TRIES, self_colliding
from robocompose.glso.method import Proposal, SearchEnv
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
    def __init__(self, config: MCTSConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config = config
        self.rng = np.random.default_rng([seed, 0x4D435453])  # "MCTS"
        self.nodes: dict[Graph, Node] = {}

    def _uct(self, node: Node, action: int) -> float:
        n = node.action_visits[action]
        if n == 0:
            return math.inf  # each action is tried once first
        k = self.config.amaf_threshold
        w = math.sqrt(k / (3 * node.visits + k))  # AMAF and maxima weigh the same at N = k
        return (1 - w) * node.action_max[action] + w * node.amaf_max[action] + math.sqrt(2 * math.log(node.visits) / n)

    def _select_action(self, graph: Graph, n_rules: int) -> tuple[int, Graph] | None:
        """The original's select_action: among actions not leading into a blocked node, the tree policy at a
        state with a node (the first maximum, so the lowest untried rule first), else uniformly random."""
        children = successors(graph, n_rules, self.config.max_depth)
        actions = [a for a, child in children.items() if not (child in self.nodes and self.nodes[child].blocked)]
        if not actions:
            return None
        node = self.nodes.get(graph)
        if node is None:
            action = actions[int(self.rng.integers(len(actions)))]
        else:
            action = max(actions, key=lambda a: self._uct(node, a))
        return action, children[action]

    def propose(self, env: SearchEnv) -> Proposal:
        rejected = 0  # simulations that ended incomplete or self-penetrating
        while True:
            states, rules = [START_GRAPH], []
            self.nodes.setdefault(START_GRAPH, Node())
            step = self._select_action(START_GRAPH, 0)
            while step is not None and states[-1] in self.nodes:  # selection
                rules.append(step[0])
                states.append(step[1])
                step = self._select_action(states[-1], len(rules))
            expanded = self.nodes.setdefault(states[-1], Node())  # expansion: at most one new node
            for _ in range(MAX_TRIES):  # simulation, redrawn until the result is valid
                path, path_rules = list(states), list(rules)
                while (step := self._select_action(path[-1], len(path_rules))) is not None:
                    path_rules.append(step[0])
                    path.append(step[1])
                if path[-1].complete:
                    tree = graph_to_tree(path[-1])
                    if not self_colliding(tree):
                        return Proposal(tree, tuple(path_rules), info=path[:-1], rejected=rejected)
                rejected += 1
            expanded.blocked = True  # no valid simulation below it: the next iteration avoids it

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
