"""A batch of design trees as index tensors for level-wise message passing.

Every tree edge carries two directed messages: up (child -> parent) and down (parent -> child). On a
tree, one upward sweep (deepest senders first) followed by one downward sweep (shallowest senders
first) computes each message exactly once from messages already computed; all messages whose senders
sit at the same depth, across all trees of the batch, form one level and are computed together.

Messages are numbered in computation order (0 is an all-zero padding message), so each level is a
contiguous slice of one buffer. Each message lists up to three incoming messages (a node has at most
four neighbours):
- encoder (eqs. 7.1-7.6): all messages into the sender except the one from the receiver;
- decoder (teacher forcing, JT-VAE's depth-first order): a down message to the k-th child sees the
  sender's down message and the up messages of children 0..k-1 only, as when it was generated.
Each message also records its step in the depth-first traversal, for the reference schedule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from robocompose.grammar.tree import BODY_LINK_TYPE, N_TOKENS
from robocompose.latent.constraints import Replay, stop_predictions

MAX_INCOMING = 3  # incoming messages of one message (4 neighbours minus the receiver)


@dataclass(frozen=True)
class Levels:
    """Message levels in computation order: level l computes messages bounds[l]..bounds[l+1]-1.

    A level reads only a few earlier levels (`sources[l]`); `local` indexes its incoming messages in
    [padding row, *those levels' rows], so that the gather's gradient is the size of what it read,
    not of the whole message buffer.
    """

    bounds: list[int]
    sender_tokens: torch.Tensor  # (M,) token of each message's sender, message m at row m-1
    incoming: torch.Tensor  # (M, 3) incoming message ids (0 = none)
    sources: list[list[int]]
    local: torch.Tensor  # (M, 3) incoming rows in the concatenation of padding and the source levels


def _levels(bounds: list[int], sender: np.ndarray, incoming: np.ndarray) -> Levels:
    first = np.array(bounds)
    level_of = np.searchsorted(first, np.arange(bounds[-1]), side="right") - 1  # id -> level (id 0 -> -1)
    local = np.zeros_like(incoming)
    sources = []
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        inc = incoming[lo - 1: hi - 1]
        lv = level_of[inc]
        used = np.unique(lv[inc > 0])
        start = np.zeros(len(bounds), dtype=np.int64)  # first row of each source level in the concatenation
        start[used] = 1 + np.concatenate([[0], np.cumsum(first[used + 1] - first[used])[:-1]])
        local[lo - 1: hi - 1] = np.where(inc > 0, start[lv] + inc - first[lv], 0)
        sources.append(used.tolist())
    return Levels(bounds, torch.as_tensor(sender), torch.as_tensor(incoming), sources, torch.as_tensor(local))


@dataclass(frozen=True)
class TreeBatch:
    n_trees: int
    n_messages: int
    encoder: Levels
    decoder: Levels
    dfs_step: torch.Tensor  # (M,) step of each message in its tree's depth-first traversal
    # Encoder readout (eqs. 7.7-7.8): leaves that are not body links (all leaves if a tree has none).
    leaf_tokens: torch.Tensor  # (L,)
    leaf_incoming: torch.Tensor  # (L,) the down message into each leaf (0 for a single-node tree)
    leaf_tree: torch.Tensor  # (L,)
    # Decoder stop/expand predictions (eq. 7.9), one per node visit.
    stop_tokens: torch.Tensor  # (P,)
    stop_incoming: torch.Tensor  # (P, 4) messages into the node at that moment
    stop_tree: torch.Tensor  # (P,)
    stop_target: torch.Tensor  # (P,) 1 = expand
    stop_free: torch.Tensor  # (P,) bool: both decisions allowed (forced decisions carry no loss)
    # Decoder label predictions (eq. 7.10), one per node; the root's from z alone.
    label_incoming: torch.Tensor  # (N,) the down message that created the node (0 for roots)
    label_tree: torch.Tensor  # (N,)
    label_target: torch.Tensor  # (N,)
    label_mask: torch.Tensor  # (N, 42) bool
    contacts: torch.Tensor  # (B, 16)


def collate(replays: list[Replay], contacts: np.ndarray) -> TreeBatch:
    """Index tensors for a batch of trees walked in decoder order (`constraints.replay`)."""
    # Directed messages: (phase, level, tree, child node); phase 0 up (level = -depth), 1 down.
    keys, depth_of = [], []
    for b, r in enumerate(replays):
        depth = [0] * len(r.tokens)
        for i in range(1, len(r.tokens)):
            depth[i] = depth[r.parents[i]] + 1
        depth_of.append(depth)
        for c in range(1, len(r.tokens)):
            keys += [(0, -depth[c], b, c), (1, depth[c] - 1, b, c)]
    keys.sort()
    msg_id = {(phase, b, c): m + 1 for m, (phase, _, b, c) in enumerate(keys)}
    up = lambda b, c: msg_id[(0, b, c)]  # noqa: E731
    down = lambda b, c: msg_id.get((1, b, c), 0)  # noqa: E731

    n_msg = len(keys)
    sender = np.zeros(n_msg, dtype=np.int64)
    enc_in = np.zeros((n_msg, MAX_INCOMING), dtype=np.int64)
    dec_in = np.zeros((n_msg, MAX_INCOMING), dtype=np.int64)
    dfs_step = np.zeros(n_msg, dtype=np.int64)
    for m, (phase, _, b, c) in enumerate(keys):
        r = replays[b]
        p = r.parents[c]
        if phase == 0:  # c -> p sees c's children
            sender[m] = r.tokens[c]
            enc_in[m, : len(r.children[c])] = dec_in[m, : len(r.children[c])] = [up(b, k) for k in r.children[c]]
        else:  # p -> c sees p's parent and c's siblings (the decoder: earlier siblings only)
            sender[m] = r.tokens[p]
            siblings = r.children[p]
            before = siblings[: siblings.index(c)]
            above = [down(b, p)] if p else []
            enc = above + [up(b, s) for s in siblings if s != c]
            dec = above + [up(b, s) for s in before]
            enc_in[m, : len(enc)] = enc
            dec_in[m, : len(dec)] = dec
    for b, r in enumerate(replays):  # depth-first traversal: down to each child, later back up
        step = 0

        def visit(x: int, b: int = b, r: Replay = r) -> None:
            nonlocal step
            for c in r.children[x]:
                dfs_step[down(b, c) - 1] = step
                step += 1
                visit(c)
                dfs_step[up(b, c) - 1] = step
                step += 1

        visit(0)

    levels = [(ph, lv) for ph, lv, _, _ in keys]
    bounds = [0] + [m for m in range(1, n_msg) if levels[m] != levels[m - 1]] + [n_msg]
    bounds = [x + 1 for x in bounds]  # message ids start at 1

    leaf_tokens, leaf_in, leaf_tree = [], [], []
    stop_tokens, stop_in, stop_tree, stop_target, stop_free = [], [], [], [], []
    label_in, label_tree, label_target, label_mask = [], [], [], []
    for b, r in enumerate(replays):
        leaves = [i for i in range(len(r.tokens)) if not r.children[i]]
        limbs = [i for i in leaves if r.tokens[i] // 14 != BODY_LINK_TYPE]
        for i in limbs or leaves:
            leaf_tokens.append(r.tokens[i])
            leaf_in.append(down(b, i) if i else 0)
            leaf_tree.append(b)
        for (x, k), free in zip(stop_predictions(r.children), r.stop_free, strict=True):
            incoming = ([down(b, x)] if x else []) + [up(b, c) for c in r.children[x][:k]]
            stop_tokens.append(r.tokens[x])
            stop_in.append(incoming + [0] * (MAX_INCOMING + 1 - len(incoming)))
            stop_tree.append(b)
            stop_target.append(float(k < len(r.children[x])))
            stop_free.append(bool(free))
        for i in range(len(r.tokens)):
            label_in.append(down(b, i) if i else 0)
            label_tree.append(b)
            label_target.append(r.tokens[i])
        label_mask.append(r.label_masks)

    t = torch.as_tensor
    return TreeBatch(
        n_trees=len(replays), n_messages=n_msg,
        encoder=_levels(bounds, sender, enc_in), decoder=_levels(bounds, sender, dec_in),
        dfs_step=t(dfs_step),
        leaf_tokens=t(leaf_tokens), leaf_incoming=t(leaf_in), leaf_tree=t(leaf_tree),
        stop_tokens=t(stop_tokens), stop_incoming=t(np.array(stop_in, dtype=np.int64)), stop_tree=t(stop_tree),
        stop_target=t(stop_target, dtype=torch.float32), stop_free=t(stop_free),
        label_incoming=t(label_in), label_tree=t(label_tree), label_target=t(label_target),
        label_mask=t(np.concatenate(label_mask).reshape(-1, N_TOKENS)),
        contacts=t(np.asarray(contacts, dtype=np.float32)).reshape(len(replays), -1),
    )
