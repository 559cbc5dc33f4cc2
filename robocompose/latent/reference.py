"""The same model computed the original's way (JT-VAE / GLSO), for the benchmark and the equality tests.

- Encoder: 20 synchronous iterations in which every directed message of the batch is recomputed from
  the previous iteration's messages (fast_jtnn's GraphGRU with depth 20), U^r applied to the gathered
  neighbours each time.
- Decoder (teacher forcing): one step of the depth-first traversal at a time, all trees together
  (fast_jtnn's JTNNDecoder loop over traversal steps).
Each GRU runs on its own, with `TreeGRU.cell` (eqs. 7.2-7.6 as written). On a tree whose longest path
has fewer edges than the iteration count both give exactly the messages of `model.level_sweeps`'s two
sweeps: a message is final once its sender's far side (at most the tree's longest path) has been reached.
"""

from __future__ import annotations

import torch

from robocompose.latent.batch import TreeBatch
from robocompose.latent.model import Propagate, TreeGRU

ITERATIONS = 20  # the reference's message-passing iterations


def synchronous(gru: TreeGRU, batch: TreeBatch, iterations: int = ITERATIONS) -> torch.Tensor:
    """Encoder messages (M + 1, H), every one recomputed `iterations` times from the previous iteration's."""
    levels = batch.levels
    terms = gru.token_terms()[levels.sender_tokens]  # (M, 3H)
    h = terms.new_zeros(levels.bounds[-1], gru.hidden)  # (M + 1, H), row 0 padding
    for _ in range(iterations):
        nei = h[levels.incoming[0]]  # (M, 3, H)
        h = torch.cat([h[:1], gru.cell(terms, nei, gru.U_r(nei))])
    return h


def depth_first_steps(gru: TreeGRU, batch: TreeBatch) -> torch.Tensor:
    """Decoder messages (M + 1, H) in traversal order: step t computes the t-th message of every tree."""
    levels, dfs_step = batch.levels, batch.dfs_step
    terms = gru.token_terms()[levels.sender_tokens]  # (M, 3H)
    h = terms.new_zeros(levels.bounds[-1], gru.hidden)
    for t in range(int(dfs_step.max()) + 1 if len(dfs_step) else 0):
        rows = torch.nonzero(dfs_step == t).squeeze(1)  # message ids - 1
        nei = h[levels.incoming[1][rows]]  # (n, 3, H)
        h = h.index_copy(0, rows + 1, gru.cell(terms[rows], nei, gru.U_r(nei)))
    return h


def original(iterations: int = ITERATIONS) -> Propagate:
    """The reference's schedule for `GraphVAE.forward(..., propagate=original())`."""

    def propagate(grus: list[TreeGRU], batch: TreeBatch) -> torch.Tensor:
        schedules = (lambda g: synchronous(g, batch, iterations), lambda g: depth_first_steps(g, batch))
        return torch.stack([schedule(g) for schedule, g in zip(schedules, grus, strict=False)])

    return propagate
