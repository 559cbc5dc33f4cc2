"""Graph heuristic search (GHS), as RoboGrammar's examples/graph_learning/heuristic_search_algo_mpc.py.

A graph network V(state) predicts the best reward reachable from a (partial) design graph. Each
iteration e of E (E = the run's budget, so the epsilon schedules span the run):
1. eps = eps_end + (eps_start - eps_end) exp(-e / E / eps_decay), and eps_sample likewise;
2. with probability eps_sample draw 1 design, else `num_samples` (16); each is an epsilon-greedy rollout
   from the start graph: with probability eps a uniformly random applicable rule, else the rule whose
   successor state has the highest V, until complete (at most 40 rules); a rollout that ends incomplete
   or self-penetrates is redrawn (no evaluation spent);
3. the drawn design with the highest predicted V is evaluated (one objective call);
4. every state on its derivation gets V_hat[s] = max(V_hat[s], reward) and joins the state pool; then
   25 Adam steps (lr 1e-4) of MSE between V and V_hat on minibatches of min(32, pool) pooled states.

The network here is smaller than the original's DiffPool stack (3 DenseSAGE layers, two pooling levels,
192 features): three mean-aggregation (GraphSAGE) layers of 64 on the whole graph, their outputs
concatenated (192), a masked mean over nodes, then 192 -> 64 -> 1. Node features describe the node
(its non-terminal label or link shape) and the joints into it (label, type, position, rotation, axis).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from robocompose.glso.designs import MAX_TRIES, self_colliding
from robocompose.glso.mcts import successors
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.grammar.derivation import MAX_DEPTH, graph_to_tree
from robocompose.grammar.rules import (
    NONTERMINAL_EDGE_LABELS,
    NONTERMINAL_NODE_LABELS,
    START_GRAPH,
    EdgeAttrs,
    Graph,
    NodeAttrs,
)

NODE_LABELS = ("", *sorted(NONTERMINAL_NODE_LABELS))  # "" = a terminal link
EDGE_LABELS = ("", *sorted(NONTERMINAL_EDGE_LABELS))
JOINT_KINDS = ("none", "fixed", "hinge")
N_FEATURES = len(NODE_LABELS) + 3 + len(EDGE_LABELS) + len(JOINT_KINDS) + 1 + 4 + 3 + 1  # 26


@dataclass(frozen=True)
class GHSConfig:
    max_depth: int = MAX_DEPTH  # rules per rollout at most
    num_samples: int = 16  # designs drawn in a non-single iteration; the best predicted is evaluated
    eps_start: float = 1.0  # rule-choice epsilon schedule (exp-decay over the budget)
    eps_end: float = 0.1
    eps_decay: float = 0.3
    eps_sample_start: float = 1.0  # probability of drawing one design instead of num_samples
    eps_sample_end: float = 0.1
    eps_sample_decay: float = 0.3
    opt_iter: int = 25  # Adam steps after each evaluation
    batch_size: int = 32  # pooled states per Adam step
    lr: float = 1e-4
    hidden: int = 64  # width of each graph layer


@functools.cache
def _node_features(node: NodeAttrs) -> np.ndarray:
    x = np.zeros(N_FEATURES, dtype=np.float32)
    x[NODE_LABELS.index(node.label)] = 1.0
    x[len(NODE_LABELS): len(NODE_LABELS) + 3] = (node.length, node.radius, node.density)
    return x


@functools.cache
def _joint_features(edge: EdgeAttrs) -> np.ndarray:
    x = np.zeros(N_FEATURES, dtype=np.float32)
    k = len(NODE_LABELS) + 3
    x[k + EDGE_LABELS.index(edge.label)] = 1.0
    k += len(EDGE_LABELS)
    x[k + JOINT_KINDS.index(edge.joint_type)] = 1.0
    k += len(JOINT_KINDS)
    x[k] = edge.joint_pos
    x[k + 1: k + 5] = edge.joint_rot
    x[k + 5: k + 8] = edge.joint_axis
    x[k + 8] = float(edge.mirror)
    return x


def features(graph: Graph) -> np.ndarray:
    """(N, N_FEATURES) node features of a design graph: the node, plus the sum over the joints into it.

    The grammar has few distinct node and joint attributes, so their feature rows are computed once."""
    x = np.stack([_node_features(node) for node in graph.nodes])
    if graph.edges:
        heads = [h for _, h, _ in graph.edges]
        np.add.at(x, heads, np.stack([_joint_features(edge) for _, _, edge in graph.edges]))
    return x


def collate(graphs: list[Graph]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Padded node features (B, N, F), mean-aggregation matrices (B, N, N), node masks (B, N)."""
    n = max(len(g.nodes) for g in graphs)
    x = np.zeros((len(graphs), n, N_FEATURES), dtype=np.float32)
    adj = np.zeros((len(graphs), n, n), dtype=np.float32)
    mask = np.zeros((len(graphs), n), dtype=np.float32)
    for b, g in enumerate(graphs):
        x[b, : len(g.nodes)] = features(g)
        mask[b, : len(g.nodes)] = 1.0
        for t, h, _ in g.edges:  # symmetric, as the original's preprocessor
            adj[b, t, h] = adj[b, h, t] = 1.0
    adj /= np.maximum(adj.sum(2, keepdims=True), 1.0)
    return torch.from_numpy(x), torch.from_numpy(adj), torch.from_numpy(mask)


class Heuristic(nn.Module):
    """V(graph): three GraphSAGE (mean) layers, concatenated, masked mean over nodes, MLP to one number."""

    def __init__(self, hidden: int) -> None:
        super().__init__()
        sizes = [N_FEATURES, hidden, hidden, hidden]
        self.self_lin = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes, sizes[1:], strict=False))
        self.nbr_lin = nn.ModuleList(nn.Linear(a, b, bias=False) for a, b in zip(sizes, sizes[1:], strict=False))
        self.head = nn.Sequential(nn.Linear(3 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, 1))

    def forward(self, x: torch.Tensor, adj: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        outs = []
        h = x  # (B, N, F)
        for lin_self, lin_nbr in zip(self.self_lin, self.nbr_lin, strict=True):
            h = torch.relu(lin_self(h) + lin_nbr(adj @ h)) * mask[..., None]  # (B, N, H)
            outs.append(h)
        h = torch.cat(outs, dim=2)  # (B, N, 3H)
        pooled = h.sum(1) / mask.sum(1, keepdim=True)  # (B, 3H)
        return self.head(pooled)[:, 0]  # (B,)


def exp_decay(start: float, end: float, decay: float, e: int, total: int) -> float:
    return end + (start - end) * math.exp(-e / total / decay)


class GraphHeuristicSearch:
    def __init__(self, config: GHSConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config = config
        self.budget = budget
        self.rng = np.random.default_rng([seed, 0x474853])  # "GHS"
        with torch.random.fork_rng():  # the network's initialisation follows the run seed only
            torch.manual_seed(seed)
            self.net = Heuristic(config.hidden)
        self.adam = torch.optim.Adam(self.net.parameters(), lr=config.lr)
        self.v_hat: dict[Graph, float] = {}  # best reward seen below each state
        self.pool: list[Graph] = []  # states with a target, in the order they were first seen
        self.iteration = 0

    def predict(self, graphs: list[Graph], memo: dict[Graph, float] | None = None) -> np.ndarray:
        """V of each graph; `memo` keeps values while the network is unchanged (rollouts share states)."""
        memo = {} if memo is None else memo
        new = list(dict.fromkeys(g for g in graphs if g not in memo))
        if new:
            with torch.no_grad():
                memo.update(zip(new, self.net(*collate(new)).numpy().tolist(), strict=True))
        return np.array([memo[g] for g in graphs])

    def _rollout(self, eps: float, memo: dict[Graph, float]) -> tuple[list[Graph], list[int]] | None:
        """One epsilon-greedy derivation: its states (start to end) and rules; None if it is not valid."""
        states, rules = [START_GRAPH], []
        while children := successors(states[-1], len(rules), self.config.max_depth):
            actions = list(children)
            if self.rng.random() < eps:
                action = actions[int(self.rng.integers(len(actions)))]
            else:
                action = actions[int(np.argmax(self.predict([children[a] for a in actions], memo)))]
            rules.append(action)
            states.append(children[action])
        if not states[-1].complete or self_colliding(graph_to_tree(states[-1])):
            return None
        return states, rules

    def propose(self, env: SearchEnv) -> Proposal:
        c, e = self.config, self.iteration
        eps = exp_decay(c.eps_start, c.eps_end, c.eps_decay, e, self.budget)
        eps_sample = exp_decay(c.eps_sample_start, c.eps_sample_end, c.eps_sample_decay, e, self.budget)
        n = 1 if self.rng.random() < eps_sample else c.num_samples
        samples, memo, rejected = [], {}, 0
        for _ in range(n):
            for _ in range(MAX_TRIES):
                sample = self._rollout(eps, memo)
                if sample is not None:
                    samples.append(sample)
                    break
                rejected += 1
            else:
                raise RuntimeError(f"GHS: no valid rollout in {MAX_TRIES} tries")
        best = int(np.argmax(self.predict([states[-1] for states, _ in samples], memo)))
        states, rules = samples[best]
        return Proposal(graph_to_tree(states[-1]), tuple(rules), info=states, rejected=rejected)

    def tell(self, proposal: Proposal, score: float) -> None:
        for state in proposal.info:
            if state not in self.v_hat:
                self.pool.append(state)
            self.v_hat[state] = max(self.v_hat.get(state, -math.inf), score)
        for _ in range(self.config.opt_iter):
            k = min(self.config.batch_size, len(self.pool))
            batch = [self.pool[i] for i in self.rng.choice(len(self.pool), size=k, replace=False)]
            target = torch.tensor([self.v_hat[s] for s in batch], dtype=torch.float32)
            loss = torch.mean((self.net(*collate(batch)) - target) ** 2)
            self.adam.zero_grad()
            loss.backward()
            self.adam.step()
        self.iteration += 1
