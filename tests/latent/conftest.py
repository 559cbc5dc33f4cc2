"""Small grammar and no-grammar design sets (random derivations / random trees, no simulation), a designs table
writer, and a tiny VAE."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robocompose.dataset.nogram import random_graph
from robocompose.grammar.derivation import random_derivation
from robocompose.io import write_table
from robocompose.latent.model import VAEConfig

TINY = VAEConfig(hidden=16, latent=4, predictor_hidden=8, max_nodes=30)


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


def write_designs_table(path: Path, trees: list) -> Path:
    """A `designs` table of `trees` at `path` (contact vectors: the link count, 16 times)."""
    rows = [{"design_id": t.design_id, "rules": [], "parents": list(t.parents), "tokens": list(t.tokens),
             "n_links": t.n_links, "n_joints": t.n_joints, "contacts": [float(t.n_links)] * 16}
            for t in trees]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_table(pd.DataFrame(rows), path, "designs")
    return path


@pytest.fixture
def write_designs(make_trees):
    """write_designs(path, n, seed): a designs table of n random grammar designs (>= 3 links each)."""
    return lambda path, n, seed=0: write_designs_table(path, make_trees(n, seed, min_links=3))
