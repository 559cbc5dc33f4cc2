"""The GLSO_nogram ablation's dataset: random topologies and node labels over the grammar's vocabulary.

Each design is a random recursive tree (every node at most 4 neighbours, as the VAE expects) whose
size is drawn from the grammar dataset's link counts, with uniformly random link types and joint
types. It is kept when it builds in pybullet with a finite rest state. Nothing else is asked of it:
siblings that share a joint end overlap, so nearly every random topology self-penetrates at placement
(measured: all of the first 300), and that invalidity is exactly what the ablation is about; the
contact vector is still recorded, from the (penetrating) rest pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.grammar.enumerate import EnumerateStats, Outcome, _client, collect, design_row
from robocompose.grammar.tree import LINK_TYPES, N_JOINT_TYPES, DesignTree, token_of
from robocompose.io.errors import InputError

MAX_NEIGHBOURS = 4


@dataclass(frozen=True)
class NogramConfig:
    """Settings of the no-grammar dataset."""

    n: int  # designs to collect
    seed: int = 1  # candidate k uses the random stream (seed, k)

    def __post_init__(self) -> None:
        if self.n < 1:
            raise InputError(f"n must be a positive integer, got {self.n}")


def random_tree(rng: np.random.Generator, n_links: int) -> DesignTree:
    parents, degree = [-1], [0]
    for i in range(1, n_links):
        # The root may take 4 children; any other node 3 (its parent is its fourth neighbour).
        free = [j for j in range(i) if degree[j] < MAX_NEIGHBOURS - (j > 0)]
        parent = free[int(rng.integers(len(free)))]
        parents.append(parent)
        degree[parent] += 1
        degree.append(0)
    # Parents are drawn among earlier nodes, so the tree is already in parent-before-child order.
    tokens = [token_of(int(rng.integers(len(LINK_TYPES))), 0 if i == 0 else int(rng.integers(1, N_JOINT_TYPES)))
              for i in range(n_links)]
    return DesignTree(tuple(parents), tuple(tokens))


def nogram_candidate(seed: int, k: int, sizes: tuple[int, ...]) -> Outcome:
    from robocompose.sim.contacts import contact_features

    rng = np.random.default_rng([seed, k])
    tree = random_tree(rng, sizes[int(rng.integers(len(sizes)))])
    contacts = contact_features(tree, _client())
    if contacts.reason == "unstable":
        return contacts.reason, None
    return "", design_row(tree, (), contacts.features)


def enumerate_nogram(config: NogramConfig, sizes: list[int], workers: int = 0, chunk: int = 64,
                     progress: str | None = "nogram", address: str = "") -> tuple[pd.DataFrame, EnumerateStats]:
    """`config.n` distinct random-topology designs whose sizes are drawn from `sizes` (the grammar dataset's)."""
    if not sizes:
        raise InputError("nogram: needs the link counts of the grammar dataset, got none")
    return collect(nogram_candidate, config.n, config.seed, (tuple(int(s) for s in sizes),), workers, chunk,
                   progress, address)
