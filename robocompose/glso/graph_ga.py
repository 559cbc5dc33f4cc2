"""GA with graph mutation, NGE-style (Wang et al., ICLR 2019), on design trees outside the grammar.

Population 50. Generation 0 is random grammar designs (the dataset's filters). Each later generation:
rank by score, cull the worst `cull_fraction` (NGE's elimination rate), refill to the population size
by mutating uniformly chosen survivors (no crossover, as NGE). One mutation per child:
- add leaf (p 0.2): every node with room for a neighbour (at most 4) is picked with p 0.1, repeated until
  at least one is; each picked node gets a new leaf child with a uniformly random non-root token;
- remove subtree (p 0.2): a uniformly random node that has children loses one random child's subtree;
- relabel (p 0.6): every non-root node is picked with p 0.1 (at least one); each gets a new uniformly
  random non-root token (link type x joint type: NGE's attribute perturbation on our discrete nodes).
At `max_nodes` links "add" becomes "relabel"; at 2 links "remove" does. A child that self-penetrates at
rest cannot be built and is rejected before evaluation (a new child is drawn). Children are evaluated
one objective call each, in the order they were made.

Graph mutation with uncertainty (NGE's GM-UC, its pruning agent; on when `pruning`): each generation makes
`candidates` x as many buildable children as it has free slots, and a value network picks which are
evaluated. The network is NGE's: a gated graph network on the design tree (token one-hot in, hidden 64, 4
propagation steps, one message MLP per edge direction, mean aggregation, GRU update) read out at the root
by an MLP (64, 64 -> 1) whose hidden layer gets one random 50% dropout mask per generation (NGE's Bayesian
pruning: a Thompson-sample-like draw of V). Candidates are ranked by V / tau + Gumbel noise (tau 0.1:
sampling without replacement from softmax(V / tau)) and the top ones fill the slots. Before each
generation the network takes one Adam step (lr 3e-4) on min(64, n) evaluated designs drawn with
replacement, target = each design's score standardised over all evaluated designs. Every child the
generation discards (unbuildable or pruned) is counted in its first child's `rejected`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from robocompose.glso.designs import MAX_TRIES, random_grammar_design, run_stream, self_colliding
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.grammar.derivation import MAX_DEPTH
from robocompose.grammar.tree import N_TOKENS, DesignTree, split_token
from robocompose.io.errors import check_field

NON_ROOT_TOKENS = tuple(t for t in range(N_TOKENS) if split_token(t)[1] != 0)
MAX_NEIGHBOURS = 4  # the VAE's limit: a node's parent and children together


@dataclass(frozen=True)
class GAConfig:
    population: int = 50  # designs per generation (thesis)
    cull_fraction: float = 0.3  # worst share removed each generation (NGE's README runs: 0.3)
    add_probability: float = 0.2  # NGE's mutation ratios: add / remove / perturb = 0.2 / 0.2 / 0.6
    remove_probability: float = 0.2
    node_probability: float = 0.1  # NGE's node_mutate_ratio
    max_nodes: int = 50  # links a design may have (the VAE's max_nodes)
    max_depth: int = MAX_DEPTH  # derivation depth of the random first generation
    pruning: bool = True  # graph mutation with uncertainty (NGE's GM-UC; the thesis's GA)
    candidates: int = 2  # children made per free slot for the pruning to choose from (NGE: 30-64 of 32-64)
    temperature: float = 0.1  # NGE's gumble_temperature
    lr: float = 3e-4  # NGE's --lr, one Adam step per generation
    hidden: int = 64  # the value network's width

    def __post_init__(self) -> None:
        check_field(self.population >= 2, "population", "at least 2 designs", self.population)
        check_field(0 < self.cull_fraction < 1, "cull_fraction", "a fraction in (0, 1)", self.cull_fraction)
        check_field(self.candidates >= 1, "candidates", "at least 1 child per slot", self.candidates)


def rebuild(children: dict[int, list[int]], tokens: dict[int, int]) -> DesignTree:
    """A tree in breadth-first order from node -> children and node -> token (node 0 is the root)."""
    order, parents, queue = [], [], [(0, -1)]
    while queue:
        node, parent = queue.pop(0)
        parents.append(parent)
        order.append(node)
        queue.extend((kid, len(order) - 1) for kid in children.get(node, []))
    return DesignTree(tuple(parents), tuple(tokens[i] for i in order))


def _pick_nodes(rng: np.random.Generator, candidates: list[int], p: float) -> list[int]:
    """Each candidate with probability p, redrawn until at least one is picked (NGE)."""
    while True:
        picked = [n for n in candidates if rng.random() < p]
        if picked:
            return picked


def mutate(tree: DesignTree, rng: np.random.Generator, config: GAConfig) -> DesignTree:
    children = {i: tree.children(i) for i in range(tree.n_links)}
    tokens = dict(enumerate(tree.tokens))
    roll = rng.random()
    op = "add" if roll < config.add_probability else (
        "remove" if roll < config.add_probability + config.remove_probability else "relabel")
    if op == "add" and tree.n_links >= config.max_nodes:
        op = "relabel"
    if op == "remove" and tree.n_links <= 2:
        op = "relabel"
    if op == "add":
        room = [i for i in range(tree.n_links) if len(children[i]) + (i > 0) < MAX_NEIGHBOURS]
        for node in _pick_nodes(rng, room, config.node_probability):
            new = len(tokens)
            tokens[new] = NON_ROOT_TOKENS[int(rng.integers(len(NON_ROOT_TOKENS)))]
            children[node] = [*children[node], new]
    elif op == "remove":
        # not the root's only child: that would leave the root alone (NGE undoes such a removal)
        with_children = [i for i in range(tree.n_links) if children[i] and (i or len(children[0]) > 1)]
        parent = with_children[int(rng.integers(len(with_children)))]
        drop = int(rng.integers(len(children[parent])))
        children[parent] = children[parent][:drop] + children[parent][drop + 1:]
    else:
        for node in _pick_nodes(rng, list(range(1, tree.n_links)), config.node_probability):
            tokens[node] = NON_ROOT_TOKENS[int(rng.integers(len(NON_ROOT_TOKENS)))]
    return rebuild(children, tokens)


class ValueNet(nn.Module):
    """NGE's pruning network: a gated graph network on a design tree, read out at the root (module docstring)."""

    def __init__(self, hidden: int, steps: int = 4) -> None:
        super().__init__()
        self.embed = nn.Linear(N_TOKENS, hidden)
        self.down = nn.Sequential(nn.Linear(hidden, hidden), nn.Tanh())  # messages parent -> child
        self.up = nn.Sequential(nn.Linear(hidden, hidden), nn.Tanh())  # messages child -> parent
        self.gru = nn.GRUCell(hidden, hidden)
        self.hidden_layer, self.out = nn.Linear(hidden, hidden), nn.Linear(hidden, 1)
        self.steps = steps

    def forward(self, trees: list[DesignTree], dropout: torch.Tensor | None = None) -> torch.Tensor:
        """V of each tree (B,); `dropout` (hidden,) a 0/2 mask on the output MLP's hidden layer."""
        tokens = torch.tensor([t for tree in trees for t in tree.tokens])
        offsets = np.cumsum([0] + [tree.n_links for tree in trees])
        child = torch.tensor([offsets[b] + i for b, tree in enumerate(trees) for i in range(1, tree.n_links)],
                             dtype=torch.long)
        parent = torch.tensor([offsets[b] + tree.parents[i] for b, tree in enumerate(trees)
                               for i in range(1, tree.n_links)], dtype=torch.long)
        n = len(tokens)
        degree = torch.zeros(n).index_add_(0, child, torch.ones(len(child))).index_add_(
            0, parent, torch.ones(len(parent))).clamp(min=1.0)
        h = torch.tanh(self.embed(nn.functional.one_hot(tokens, N_TOKENS).float()))  # (N, H)
        for _ in range(self.steps):
            message = torch.zeros_like(h).index_add_(0, child, self.down(h[parent]))
            message = message.index_add_(0, parent, self.up(h[child])) / degree[:, None]  # mean over neighbours
            h = self.gru(message, h)
        roots = h[torch.as_tensor(offsets[:-1], dtype=torch.long)]  # (B, H)
        hidden = torch.relu(self.hidden_layer(roots))
        if dropout is not None:
            hidden = hidden * dropout
        return self.out(hidden)[:, 0]


class GraphGA:
    def __init__(self, config: GAConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config = config
        self.rng = np.random.default_rng([seed, 0x4741])  # "GA"
        self.population: list[tuple[Proposal, float]] = []  # evaluated members of the current generation
        self.queue: list[Proposal] = []  # children made but not yet evaluated
        self.generation = 0
        self.stream, self.k = run_stream(seed, "ga"), 0  # the first generation's designs
        self.evaluated: dict[str, tuple[DesignTree, float]] = {}  # design id -> (design, its last score)
        with torch.random.fork_rng():  # the network's initialisation follows the run seed only
            torch.manual_seed(seed)
            self.value = ValueNet(config.hidden)
        self.adam = torch.optim.Adam(self.value.parameters(), lr=config.lr)

    def _next_generation(self) -> None:
        c = self.config
        ranked = sorted(range(len(self.population)), key=lambda i: -self.population[i][1])  # stable
        keep = c.population - max(1, int(c.cull_fraction * c.population))  # NGE's floor, at least one
        self.population = [self.population[i] for i in ranked[:keep]]
        slots = c.population - keep
        children, rejected = [], 0
        for _ in range(slots * (c.candidates if c.pruning else 1)):
            for _ in range(MAX_TRIES):
                parent = self.population[int(self.rng.integers(len(self.population)))][0]
                child = mutate(parent.tree, self.rng, c)
                if not self_colliding(child):
                    children.append(child)
                    break
                rejected += 1
            else:
                raise RuntimeError(f"GA: no buildable child in {MAX_TRIES} mutations")
        if c.pruning:
            picked = self._prune(children, slots)
            rejected += len(children) - slots
            children = [children[i] for i in picked]
        self.queue = [Proposal(child, None) for child in children]
        self.queue[0].rejected = rejected
        self.generation += 1

    def _train_value(self) -> None:
        """One Adam step of NGE's pruning network on min(64, n) evaluated designs (with replacement)."""
        designs = list(self.evaluated.values())
        scores = np.array([score for _, score in designs])
        batch = self.rng.integers(len(designs), size=min(64, len(designs)))
        target = torch.tensor((scores[batch] - scores.mean()) / (scores.std() + 1e-8), dtype=torch.float32)
        loss = torch.mean((self.value([designs[i][0] for i in batch]) - target) ** 2)
        self.adam.zero_grad()
        loss.backward()
        self.adam.step()

    def _prune(self, children: list[DesignTree], slots: int) -> list[int]:
        """The `slots` children kept: the top of V / tau + Gumbel noise under one dropout mask."""
        self._train_value()
        mask = torch.from_numpy((self.rng.random(self.config.hidden) < 0.5).astype(np.float32) * 2.0)
        with torch.no_grad():
            values = self.value(children, mask).numpy()
        gumbel = -np.log(-np.log(self.rng.uniform(1e-12, 1.0, size=len(children))))
        return sorted(np.argsort(-(values / self.config.temperature + gumbel), kind="stable")[:slots].tolist())

    def propose(self, env: SearchEnv) -> Proposal:
        if not self.queue:
            if self.generation == 0 and len(self.population) < self.config.population:
                proposal, self.k = random_grammar_design(self.stream, self.k, self.config.max_depth)
                return proposal
            self._next_generation()
        return self.queue.pop(0)

    def tell(self, proposal: Proposal, score: float) -> None:
        self.population.append((proposal, score))
        self.evaluated[proposal.tree.design_id] = (proposal.tree, score)
