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
from weakref import WeakKeyDictionary

import numpy as np
import torch

from robocompose.grammar.tree import BODY_LINK_TYPE, N_TOKENS
from robocompose.latent.constraints import Replay, stop_predictions

MAX_INCOMING = 3  # incoming messages of one message (4 neighbours minus the receiver)


@dataclass(frozen=True)
class Levels:
    """Message levels in computation order: level l computes messages bounds[l]..bounds[l+1]-1.

    Encoder and decoder messages share ids, senders and levels and differ only in what they read
    (`incoming[0]`, `incoming[1]`), so `model.Sweeps` computes level l of both GRUs together, from one
    buffer holding the encoder's M + 1 message rows followed by the decoder's.
    """

    bounds: list[int]
    sender_tokens: torch.Tensor  # (M,) token of each message's sender, message m at row m-1
    incoming: torch.Tensor  # (2, M, 3) incoming message ids (0 = none) of [encoder, decoder]
    # Per level (3, 2, n_l): [k, g, j] is the buffer row of the k-th message into the level's j-th
    # message for GRU g (encoder: its id; decoder: M + 1 + its id). Slot-major, so that summing over
    # the incoming messages adds three contiguous blocks.
    index: list[torch.Tensor]


def _levels(bounds: list[int], sender: np.ndarray, incoming: np.ndarray) -> Levels:
    stacked = incoming + np.array([0, bounds[-1]])[:, None, None]  # (2, M, 3); bounds[-1] = M + 1
    index = [torch.as_tensor(np.ascontiguousarray(stacked[:, lo - 1: hi - 1].transpose(2, 0, 1)))
             for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)]
    return Levels(bounds, torch.as_tensor(sender), torch.as_tensor(incoming), index)


@dataclass(frozen=True)
class TreeBatch:
    n_trees: int
    n_messages: int
    levels: Levels
    message_ends: torch.Tensor  # (M, 3) tree, sender node, receiver node (replay numbering) of message m at row m-1
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


@dataclass(frozen=True)
class TreeArrays:
    """One tree's share of a batch, computed once per design (`arrays_of`) so that `collate` only
    concatenates. Its 2(n-1) messages have local ids j = 1..2(n-1): up from node c is c, down to node c
    is n-1+c; message references hold local ids (0 = none) until `collate` maps them to batch ids."""

    phase: np.ndarray  # (m,) 0 up, 1 down
    level: np.ndarray  # (m,) up: -depth of the sender; down: depth of the sender
    node: np.ndarray  # (m,) the child node of the message's edge
    ends: np.ndarray  # (m, 2) sender and receiver node
    sender: np.ndarray  # (m,) sender token
    enc_in: np.ndarray  # (m, 3) local ids of incoming messages, encoder
    dec_in: np.ndarray  # (m, 3) decoder
    dfs_step: np.ndarray  # (m,)
    leaf_tokens: np.ndarray  # (l,)
    leaf_in: np.ndarray  # (l,)
    stop_tokens: np.ndarray  # (p,)
    stop_in: np.ndarray  # (p, 4)
    stop_target: np.ndarray  # (p,) float32
    stop_free: np.ndarray  # (p,) bool
    label_in: np.ndarray  # (n,)
    label_target: np.ndarray  # (n,)
    label_mask: np.ndarray  # (n, 42) bool


def tree_arrays(r: Replay) -> TreeArrays:
    """The per-tree arrays of `collate` (see `TreeArrays`)."""
    n = len(r.tokens)
    depth = [0] * n
    for i in range(1, n):
        depth[i] = depth[r.parents[i]] + 1
    up = lambda c: c  # noqa: E731
    down = lambda c: n - 1 + c if c else 0  # noqa: E731
    nodes = list(range(1, n))
    m = 2 * (n - 1)
    enc_in = np.zeros((m, MAX_INCOMING), dtype=np.int64)
    dec_in = np.zeros((m, MAX_INCOMING), dtype=np.int64)
    for c in nodes:
        kids = r.children[c]  # c -> p sees c's children
        enc_in[up(c) - 1, : len(kids)] = dec_in[up(c) - 1, : len(kids)] = [up(k) for k in kids]
        p = r.parents[c]  # p -> c sees p's parent and c's siblings (the decoder: earlier siblings only)
        siblings = r.children[p]
        above = [down(p)] if p else []
        enc = above + [up(s) for s in siblings if s != c]
        dec = above + [up(s) for s in siblings[: siblings.index(c)]]
        enc_in[down(c) - 1, : len(enc)] = enc
        dec_in[down(c) - 1, : len(dec)] = dec
    dfs_step = np.zeros(m, dtype=np.int64)
    step = 0

    def visit(x: int) -> None:  # depth-first traversal: down to each child, later back up
        nonlocal step
        for c in r.children[x]:
            dfs_step[down(c) - 1] = step
            step += 1
            visit(c)
            dfs_step[up(c) - 1] = step
            step += 1

    visit(0)
    leaves = [i for i in range(n) if not r.children[i]]
    limbs = [i for i in leaves if r.tokens[i] // 14 != BODY_LINK_TYPE]
    readout = limbs or leaves
    stops = stop_predictions(r.children)
    stop_in = np.zeros((len(stops), MAX_INCOMING + 1), dtype=np.int64)
    for row, (x, k) in enumerate(stops):
        incoming = ([down(x)] if x else []) + [up(c) for c in r.children[x][:k]]
        stop_in[row, : len(incoming)] = incoming
    i64 = lambda x: np.array(x, dtype=np.int64)  # noqa: E731
    return TreeArrays(
        phase=i64([0] * (n - 1) + [1] * (n - 1)),
        level=i64([-depth[c] for c in nodes] + [depth[c] - 1 for c in nodes]),
        node=i64(nodes + nodes),
        ends=i64([(c, r.parents[c]) for c in nodes] + [(r.parents[c], c) for c in nodes]).reshape(-1, 2),
        sender=i64([r.tokens[c] for c in nodes] + [r.tokens[r.parents[c]] for c in nodes]),
        enc_in=enc_in, dec_in=dec_in, dfs_step=dfs_step,
        leaf_tokens=i64([r.tokens[i] for i in readout]), leaf_in=i64([down(i) for i in readout]),
        stop_tokens=i64([r.tokens[x] for x, _ in stops]), stop_in=stop_in,
        stop_target=np.array([k < len(r.children[x]) for x, k in stops], dtype=np.float32),
        stop_free=np.asarray(r.stop_free, dtype=bool),
        label_in=i64([down(i) for i in range(n)]), label_target=i64(r.tokens),
        label_mask=np.asarray(r.label_masks, dtype=bool).reshape(n, N_TOKENS),
    )


_ARRAYS: WeakKeyDictionary[Replay, TreeArrays] = WeakKeyDictionary()  # each design's arrays, computed once


def arrays_of(r: Replay) -> TreeArrays:
    """`tree_arrays(r)`, cached for as long as the replay lives (training collates each design many times)."""
    if r not in _ARRAYS:
        _ARRAYS[r] = tree_arrays(r)
    return _ARRAYS[r]


def collate(replays: list[Replay], contacts: np.ndarray) -> TreeBatch:
    """Index tensors for a batch of trees walked in decoder order (`constraints.replay`)."""
    trees = [arrays_of(r) for r in replays]
    cat = lambda name: np.concatenate([getattr(a, name) for a in trees])  # noqa: E731
    tree_of = lambda name: np.repeat(np.arange(len(trees)), [len(getattr(a, name)) for a in trees])  # noqa: E731
    # Batch message ids: sorted by (phase, level, tree, node), numbered from 1 (0 is padding).
    phase, level, node, tree = cat("phase"), cat("level"), cat("node"), tree_of("phase")
    order = np.lexsort((node, tree, level, phase))
    n_msg = len(order)
    offset = np.cumsum([0] + [len(a.phase) for a in trees])  # first row of each tree in the concatenation
    batch_id = np.zeros(n_msg + 1, dtype=np.int64)  # [0, batch id of concatenated row 0, 1, ...]
    batch_id[1 + order] = np.arange(1, n_msg + 1)

    def ids(name: str) -> np.ndarray:  # a reference field, local ids -> batch ids
        local = cat(name)
        shift = offset[tree_of(name)].reshape(-1, *[1] * (local.ndim - 1))
        return batch_id[np.where(local > 0, local + shift, 0)]

    sender = cat("sender")[order]
    ph, lv = phase[order], level[order]
    change = np.flatnonzero((ph[1:] != ph[:-1]) | (lv[1:] != lv[:-1])) + 1
    bounds = [0, *change.tolist(), n_msg]
    bounds = [x + 1 for x in bounds]  # message ids start at 1

    t = torch.as_tensor
    return TreeBatch(
        n_trees=len(replays), n_messages=n_msg,
        levels=_levels(bounds, sender, np.stack([ids("enc_in")[order], ids("dec_in")[order]])),
        message_ends=t(np.column_stack([tree[order], cat("ends")[order]])),
        dfs_step=t(cat("dfs_step")[order]),
        leaf_tokens=t(cat("leaf_tokens")), leaf_incoming=t(ids("leaf_in")), leaf_tree=t(tree_of("leaf_tokens")),
        stop_tokens=t(cat("stop_tokens")), stop_incoming=t(ids("stop_in")), stop_tree=t(tree_of("stop_tokens")),
        stop_target=t(cat("stop_target")), stop_free=t(cat("stop_free")),
        label_incoming=t(ids("label_in")), label_tree=t(tree_of("label_in")), label_target=t(cat("label_target")),
        label_mask=t(cat("label_mask")),
        contacts=t(np.asarray(contacts, dtype=np.float32)).reshape(len(replays), -1),
    )
