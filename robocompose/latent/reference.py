"""The same model computed the original's way (JT-VAE / GLSO), for the benchmark and the equality tests.

- Tree walk (`walked_messages`): the readable statement of which messages feed which. It walks one
  design tree itself, node by node, and applies eqs. 7.2-7.6 (`TreeGRU.cell`) to each directed edge,
  reading nothing the batch's level arrays hold; the tests compare every message of `model.Sweeps`
  (looked up by its tree, sender and receiver) with it, so a wrong wiring of the fast path fails.

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
from robocompose.latent.constraints import Replay
from robocompose.latent.model import Propagate, TreeGRU

ITERATIONS = 20  # the reference's message-passing iterations


def walked_messages(gru: TreeGRU, r: Replay, decoder: bool) -> dict[tuple[int, int], torch.Tensor]:
    """Every message of one tree, (sender, receiver) -> (H,), by walking the tree (replay numbering).

    Encoder (eq. 7.1): the message i -> j is computed from x_i and the messages into i from all of i's
    neighbours except j, recursively. Decoder (JT-VAE's teacher forcing): messages are made in the
    depth-first walk, each from the messages its sender had received when it was sent: going down to a
    child, its parent's message and those of the children already walked back from; going back up,
    those of its own children.
    """
    terms = gru.token_terms()  # (42, 3H)
    neighbours = [[p] if p >= 0 else [] for p in r.parents]
    for x, kids in enumerate(r.children):
        neighbours[x] = neighbours[x] + kids

    def send(sender: int, incoming: list[torch.Tensor]) -> torch.Tensor:
        nei = torch.stack(incoming).unsqueeze(0) if incoming else terms.new_zeros(1, 1, gru.hidden)  # (1, K, H)
        return gru.cell(terms[r.tokens[sender]].unsqueeze(0), nei, gru.U_r(nei))[0]

    out: dict[tuple[int, int], torch.Tensor] = {}
    if not decoder:
        def message(i: int, j: int) -> torch.Tensor:
            if (i, j) not in out:
                out[i, j] = send(i, [message(k, i) for k in neighbours[i] if k != j])
            return out[i, j]

        for i in range(len(r.tokens)):
            for j in neighbours[i]:
                message(i, j)
        return out
    received: list[list[torch.Tensor]] = [[] for _ in r.tokens]  # messages into each node so far

    def visit(x: int) -> None:
        for c in r.children[x]:
            out[x, c] = send(x, received[x])
            received[c].append(out[x, c])
            visit(c)
            out[c, x] = send(c, [out[k, c] for k in r.children[c]])
            received[x].append(out[c, x])

    visit(0)
    return out


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
