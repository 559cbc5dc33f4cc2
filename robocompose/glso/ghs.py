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

The heuristic V is RoboGrammar's (Net.py, Preprocessor.py, after PyG's DiffPool example). A state is the
robot its graph unfolds into (`grammar.derivation.unfold`: one node per link, the symmetric adjacency of
the link tree). Each link's features: one-hot joint type (none, free, hinge, fixed), joint position,
rotation (w, x, y, z) and axis, one-hot shape (none, capsule, cylinder), length, radius, density,
friction, kp, kd, torque, one-hot control mode (position, velocity), world position, rotation and joint
axis (accumulated from the root: offset parent length x joint position along the parent's x, rotation by
the conjugate of the joint's), and a one-hot label ("" for a terminal link, else its non-terminal label):
34 + labels. The network: a GNN block is 3 DenseSAGE layers (in -> 64 -> 64 -> out, ReLU after each, their
outputs concatenated); pooling blocks add Linear + ReLU. Level 1 pools the links into ceil(0.25 x 40) = 10
clusters (self-loops added at this level), level 2 into ceil(0.25 x 10) = 3, level 3 embeds; a mean over
clusters, Linear 192 -> 64, ReLU, Linear 64 -> 1. DiffPool's link and entropy losses are not trained on
(the original computes and drops them); float32 instead of the original's float64.
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
from robocompose.grammar.derivation import MAX_DEPTH, graph_to_tree, unfold
from robocompose.grammar.rules import IDENTITY, NONTERMINAL_NODE_LABELS, START_GRAPH, Graph

LABELS = ("", *sorted(NONTERMINAL_NODE_LABELS))  # "" = a terminal link
JOINT_KINDS = ("none", "free", "hinge", "fixed")  # RoboGrammar's JointType; the root's joint is free
SHAPES = ("none", "capsule", "cylinder")
N_FEATURES = 34 + len(LABELS)
MAX_NODES = 40  # heuristic_search_algo_mpc.py: Net(max_nodes=40) sets the cluster counts
# The original redraws a sample until it is valid, without limit; late in a run greedy rollouts often reach
# the depth limit (hundreds of redraws), so the cap is 10x the other methods'.
REDRAWS = 10 * MAX_TRIES


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
    hidden: int = 64  # width of each graph layer (the original's 64)


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    conj = q * np.array([1.0, -1.0, -1.0, -1.0])
    return _quat_mul(_quat_mul(q, np.array([0.0, *v])), conj)[1:]


@functools.lru_cache(maxsize=20_000)
def features(graph: Graph) -> tuple[np.ndarray, np.ndarray]:
    """(N, N_FEATURES) link features of the robot a design graph unfolds into, and (N, N) its symmetric
    adjacency. States recur across rollouts and training batches, so they are computed once per graph."""
    links = unfold(graph)
    x = np.zeros((len(links), N_FEATURES), dtype=np.float32)
    adj = np.zeros((len(links), len(links)), dtype=np.float32)
    pos, rot = np.zeros((len(links), 3)), np.zeros((len(links), 4))
    for i, link in enumerate(links):
        joint = link.joint
        kind = "free" if joint is None else joint.joint_type
        joint_rot = np.array(IDENTITY if joint is None else joint.joint_rot)
        axis = np.array((0.0, 0.0, 1.0) if joint is None else joint.joint_axis)
        if link.parent < 0:
            pos[i], rot[i] = 0.0, IDENTITY
        else:
            parent = links[link.parent]
            offset = np.array([parent.node.length * joint.joint_pos, 0.0, 0.0])
            pos[i] = pos[link.parent] + _rotate(rot[link.parent], offset)
            rot[i] = _quat_mul(rot[link.parent], joint_rot * np.array([1.0, -1.0, -1.0, -1.0]))
            adj[i, link.parent] = adj[link.parent, i] = 1.0
        node = link.node
        row = [*(float(kind == k) for k in JOINT_KINDS), 0.0 if joint is None else joint.joint_pos, *joint_rot,
               *axis, *(float(node.shape == s) for s in SHAPES), node.length, node.radius, node.density,
               node.friction, *((0.0, 0.0, 0.0) if joint is None else (joint.kp, joint.kd, joint.torque)),
               1.0, 0.0,  # control mode: every joint of the grammar is position-controlled
               *pos[i], *rot[i], *_rotate(rot[i], axis), *(float(node.label == label) for label in LABELS)]
        x[i] = row
    return x, adj


def collate(graphs: list[Graph]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Zero-padded link features (B, N, F), adjacency (B, N, N) and link masks (B, N)."""
    parts = [features(g) for g in graphs]
    n = max(len(x) for x, _ in parts)
    x = np.zeros((len(graphs), n, N_FEATURES), dtype=np.float32)
    adj = np.zeros((len(graphs), n, n), dtype=np.float32)
    mask = np.zeros((len(graphs), n), dtype=np.float32)
    for b, (xb, ab) in enumerate(parts):
        x[b, : len(xb)], adj[b, : len(xb), : len(xb)], mask[b, : len(xb)] = xb, ab, 1.0
    return torch.from_numpy(x), torch.from_numpy(adj), torch.from_numpy(mask)


class DenseSAGE(nn.Module):
    """PyG's DenseSAGEConv: lin_rel(mean of the neighbours) + lin_root(self), zeroed outside the mask."""

    def __init__(self, n_in: int, n_out: int) -> None:
        super().__init__()
        self.rel, self.root = nn.Linear(n_in, n_out), nn.Linear(n_in, n_out, bias=False)

    def forward(self, x: torch.Tensor, adj: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
        out = (adj @ x) / adj.sum(-1, keepdim=True).clamp(min=1.0)  # (B, N, F)
        out = self.rel(out) + self.root(x)
        return out if mask is None else out * mask[..., None]


class GNNBlock(nn.Module):
    """3 DenseSAGE layers (in -> hidden -> hidden -> out), ReLU after each, outputs concatenated; with
    `lin`, a Linear + ReLU back to `out` (the pooling blocks)."""

    def __init__(self, n_in: int, hidden: int, n_out: int, lin: bool) -> None:
        super().__init__()
        self.convs = nn.ModuleList([DenseSAGE(n_in, hidden), DenseSAGE(hidden, hidden), DenseSAGE(hidden, n_out)])
        self.lin = nn.Linear(2 * hidden + n_out, n_out) if lin else None

    def forward(self, x: torch.Tensor, adj: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
        outs = []
        for conv in self.convs:
            x = torch.relu(conv(x, adj, mask))
            outs.append(x)
        x = torch.cat(outs, dim=-1)  # (B, N, 2 hidden + out)
        return x if self.lin is None else torch.relu(self.lin(x))


def diff_pool(x: torch.Tensor, adj: torch.Tensor, s: torch.Tensor,
              mask: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor]:
    """PyG's dense_diff_pool without its auxiliary losses: soft cluster assignment S, S^T X and S^T A S."""
    s = torch.softmax(s, dim=-1)  # (B, N, C)
    if mask is not None:
        x, s = x * mask[..., None], s * mask[..., None]
    return s.transpose(1, 2) @ x, s.transpose(1, 2) @ adj @ s  # (B, C, F), (B, C, C)


class Heuristic(nn.Module):
    """V(state): RoboGrammar's DiffPool network (module docstring)."""

    def __init__(self, hidden: int, max_nodes: int = MAX_NODES) -> None:
        super().__init__()
        clusters1 = math.ceil(0.25 * max_nodes)
        clusters2 = math.ceil(0.25 * clusters1)
        self.pool1 = GNNBlock(N_FEATURES, hidden, clusters1, lin=True)
        self.embed1 = GNNBlock(N_FEATURES, hidden, hidden, lin=False)
        self.pool2 = GNNBlock(3 * hidden, hidden, clusters2, lin=True)
        self.embed2 = GNNBlock(3 * hidden, hidden, hidden, lin=False)
        self.embed3 = GNNBlock(3 * hidden, hidden, hidden, lin=False)
        self.head = nn.Sequential(nn.Linear(3 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, 1))

    def forward(self, x: torch.Tensor, adj: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        looped = adj + torch.diag_embed(mask)  # level 1 adds self-loops (add_loop=True), on real links only
        s = self.pool1(x, looped, mask)  # (B, N, C1)
        h = self.embed1(x, looped, mask)  # (B, N, 3H)
        h, adj = diff_pool(h, adj, s, mask)  # (B, C1, 3H), (B, C1, C1)
        s = self.pool2(h, adj, None)
        h, adj = diff_pool(self.embed2(h, adj, None), adj, s, None)  # (B, C2, 3H)
        h = self.embed3(h, adj, None).mean(dim=1)  # (B, 3H)
        return self.head(h)[:, 0]  # (B,)


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
            for _ in range(REDRAWS):
                sample = self._rollout(eps, memo)
                if sample is not None:
                    samples.append(sample)
                    break
                rejected += 1
            else:
                raise RuntimeError(f"GHS: no valid rollout in {REDRAWS} tries")
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
