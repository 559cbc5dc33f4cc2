"""The GLSO_nogram ablation's dataset, as GLSO's `collect_random_data.py` (`random_graph`) makes it.

A design has 2..24 nodes (uniform); every node, the root included, gets a token drawn uniformly from
all 42, so any link type with any joint type can sit anywhere; node i + 1's parent is drawn uniformly
from nodes 0..i, redrawn until that parent has fewer children than its budget (3, or 4 for the root:
at most 4 neighbours per node, as the VAE expects). Nothing is simulated or checked: the designs carry
no contact vector (NaN) and no rule sequence, so the `nogram` VAE trains without a predictor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.dataset.enumerate import EnumerateStats, Outcome, collect, design_row
from robocompose.fanout.executor import Executor
from robocompose.grammar.tree import N_TOKENS, DesignTree
from robocompose.io.errors import InputError

MIN_NODES, MAX_NODES = 2, 24
MAX_CHILDREN, MAX_ROOT_CHILDREN = 3, 4
NO_CONTACTS = np.full(16, np.nan, dtype=np.float32)


@dataclass(frozen=True)
class NogramConfig:
    """Settings of the no-grammar dataset."""

    n: int  # designs to collect
    seed: int = 1  # candidate k uses the random stream (seed, k)

    def __post_init__(self) -> None:
        if self.n < 1:
            raise InputError(f"n must be a positive integer, got {self.n}")


def random_graph(rng: np.random.Generator) -> DesignTree:
    """One random design: size, tokens and parents drawn as GLSO draws them (see the module)."""
    n_nodes = int(rng.integers(MIN_NODES, MAX_NODES + 1))
    tokens = tuple(int(t) for t in rng.integers(N_TOKENS, size=n_nodes))
    parents, children = [-1], [0] * n_nodes
    for i in range(1, n_nodes):
        while True:  # redraw until the parent has room (node i - 1 has no child yet, so one has)
            parent = int(rng.integers(i))
            if children[parent] < (MAX_ROOT_CHILDREN if parent == 0 else MAX_CHILDREN):
                break
        parents.append(parent)
        children[parent] += 1
    return DesignTree(tuple(parents), tokens)


def nogram_candidate(seed: int, k: int) -> Outcome:
    return "", design_row(random_graph(np.random.default_rng([seed, k])), (), NO_CONTACTS), 0


def enumerate_nogram(config: NogramConfig, executor: Executor | None = None, chunk: int = 64,
                     progress: str | None = "nogram") -> tuple[pd.DataFrame, EnumerateStats]:
    """`config.n` distinct random designs (repeats of a design id are drawn again and counted); `executor` None:
    in this process."""
    return collect(nogram_candidate, config.n, config.seed, (), executor or Executor(workers=1), chunk, progress)
