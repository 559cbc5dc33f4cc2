"""NSGA-II's genomes for team allocations: the only list of them (`GENOMES`).

Every gene is in [0, 1]; a genome decodes to K x O fractions (species.allocation_to_counts turns them into robots):
- "fractions" (the thesis's): the K x O fractions themselves, flattened. Uniform mutation redraws a gene of a
  typical ~0.06 to U(0, 1), so a mutation mostly adds robots and populations drift towards the whole bank.
- "share_split" (the factorisation of EG-GAN's output head): per species a deployed share s and K split weights
  w; fraction (i, j) = s_j w_ij / sum_i w_ij (an all-zero column splits evenly). A mutated split weight moves
  robots between regions without changing how many are deployed; a mutated share changes only that.
Both start from the same first population (the same draws of `deployment_share_draws`), so only the genome
differs between their runs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Genome:
    """NSGA-II's real vector in [0, 1]^n for K regions x O species: its size, its decoding and encoding."""

    title: str
    size: Callable[[int, int], int]  # (K, O) -> n_var
    decode: Callable[[np.ndarray, int, int], np.ndarray]  # (B, n_var), K, O -> (B, K, O) fractions
    encode: Callable[[np.ndarray], np.ndarray]  # (B, K, O) share x split fractions -> (B, n_var)


def _split_fractions(X: np.ndarray, n_regions: int, n_species: int) -> np.ndarray:
    """(B, K, O) fractions of (B, K*O + O) share x split genomes."""
    weights = X[:, :n_regions * n_species].reshape(-1, n_regions, n_species)  # (B, K, O)
    share = X[:, None, n_regions * n_species:]  # (B, 1, O)
    total = weights.sum(1, keepdims=True)  # (B, 1, O)
    split = np.where(total > 0, weights / np.where(total > 0, total, 1.0), 1.0 / n_regions)
    return share * split


def _split_genes(fractions: np.ndarray) -> np.ndarray:
    """(B, K*O + O) genes of (B, K, O) fractions whose columns sum to at most 1: split weights, then shares."""
    share = fractions.sum(1)  # (B, O)
    split = np.where(share[:, None] > 0, fractions / np.where(share > 0, share, 1.0)[:, None], 1.0)
    return np.concatenate([split.reshape(len(fractions), -1), share], axis=1)


GENOMES = {
    "fractions": Genome("raw fractions (thesis)", lambda k, o: k * o,
                        lambda X, k, o: X.reshape(-1, k, o), lambda f: f.reshape(len(f), -1)),
    "share_split": Genome("share x split", lambda k, o: k * o + o, _split_fractions, _split_genes),
}
