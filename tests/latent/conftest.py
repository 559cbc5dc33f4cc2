"""Small grammar and no-grammar design sets (random derivations / random trees, no simulation)."""

import numpy as np
import pytest

from robocompose.dataset.nogram import random_graph
from robocompose.grammar.derivation import random_derivation


def grammar_trees(n: int, seed: int = 0, min_links: int = 1) -> list:
    rng, out = np.random.default_rng(seed), []
    while len(out) < n:
        d = random_derivation(rng)
        if d is not None and d.tree.n_links >= min_links:
            out.append(d.tree)
    return out


@pytest.fixture(scope="session")
def make_trees():
    """grammar_trees(n, seed, min_links): n random grammar designs."""
    return grammar_trees


@pytest.fixture(scope="session")
def trees() -> list:
    return grammar_trees(40, seed=0)


@pytest.fixture(scope="session")
def nogram_trees() -> list:
    rng = np.random.default_rng(0)
    return [random_graph(rng) for _ in range(30)]
