"""GLSO's graph VAE (thesis 7.1): GRU message-passing tree encoder, depth-first tree decoder, property predictor.

Encoder (eqs. 7.1-7.8): GRU messages along every directed tree edge (here in one upward and one
downward sweep, which on a tree gives what the original's 20 synchronous iterations give; see
`batch.py` and `reference.py`), node states of the leaves that are not body links, summed; mean and
log-variance heads (log-variance = -|W h|, as the reference).
Decoder (eqs. 7.9-7.11): JT-VAE's depth-first decoder, teacher-forced in training. At every visit of a
node it predicts stop/expand from the node's token, z and the messages into it; a new child's label
comes from z and the message to it. Predictions are masked to what the constraints allow
(`constraints.py`): in training forced decisions carry no loss, in decoding every latent point gives a
complete design.
Property predictor: MLP on the latent mean -> the 16 rest-contact numbers (MSE).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from robocompose.grammar.tree import N_TOKENS
from robocompose.latent.batch import MAX_INCOMING, Levels, TreeBatch
from robocompose.latent.constraints import KINDS, Walk

N_CONTACTS = 16


@dataclass(frozen=True)
class VAEConfig:
    """Model sizes (thesis: hidden 450, latent 28, predictor 28 -> 128 x 3 -> 16)."""

    hidden: int = 450  # message, node and head width
    latent: int = 28  # latent dimensions
    predictor: bool = True  # co-train the property predictor (False: the GLSO_nopred ablation)
    predictor_hidden: int = 128  # width of the predictor's three hidden layers
    constraints: str = "grammar"  # decoding constraints: grammar (RoboGrammar trees) or tree (any tree)
    max_nodes: int = 50  # nodes a decoded design may have (the reference's 100 decoding steps)

    def __post_init__(self) -> None:
        for name in ("hidden", "latent", "predictor_hidden", "max_nodes"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be a positive integer, got {getattr(self, name)}")
        if self.constraints not in KINDS:
            raise ValueError(f"constraints must be one of {KINDS}, got {self.constraints!r}")


class TreeGRU(nn.Module):
    """The message GRU of eqs. 7.2-7.6; x_i is the sender's token embedding."""

    def __init__(self, hidden: int) -> None:
        super().__init__()
        self.hidden = hidden
        self.embedding = nn.Embedding(N_TOKENS, hidden)
        self.W = nn.Linear(hidden, 3 * hidden)  # W^z x, W^r x, W x (with the biases)
        self.U_z = nn.Linear(hidden, hidden, bias=False)
        self.U_r = nn.Linear(hidden, hidden, bias=False)
        self.U = nn.Linear(hidden, hidden, bias=False)

    def token_terms(self) -> torch.Tensor:
        """The x-dependent terms of every token, computed once per pass instead of once per message."""
        return self.W(self.embedding.weight)  # (42, 3H)

    def cell(self, x_terms: torch.Tensor, nei: torch.Tensor, nei_r: torch.Tensor) -> torch.Tensor:
        """New messages from x terms (n, 3H), incoming messages (n, K, H) and their U^r m (n, K, H)."""
        xz, xr, xh = x_terms.split(self.hidden, dim=1)
        s = nei.sum(1)  # (n, H) eq. 7.2
        z = torch.sigmoid(xz + self.U_z(s))  # eq. 7.3
        r = torch.sigmoid(xr.unsqueeze(1) + nei_r)  # (n, K, H) eq. 7.4
        m_tilde = torch.tanh(xh + self.U((r * nei).sum(1)))  # eq. 7.5
        return (1 - z) * s + z * m_tilde  # eq. 7.6

    def propagate(self, levels: Levels) -> torch.Tensor:
        """All messages, level by level; returns rows [m, U^r m] per message id (row 0: padding).

        U^r m is kept with each message because every message is read by up to three others. Per level,
        only the token table and the source levels are indexed, so that the backward pass accumulates
        into small tensors instead of zero-filling the whole buffer once per level.
        """
        table = self.token_terms()  # (42, 3H)
        pad = table.new_zeros(1, self.hidden)
        messages: list[torch.Tensor] = []  # per level (n_l, H)
        gated: list[torch.Tensor] = []  # per level U^r m (n_l, H)
        for lv, (lo, hi) in enumerate(zip(levels.bounds[:-1], levels.bounds[1:], strict=True)):
            index = levels.local[lo - 1: hi - 1]  # (n, 3)
            nei = gather(torch.cat([pad] + [messages[k] for k in levels.sources[lv]]), index)  # (n, 3, H)
            nei_r = gather(torch.cat([pad] + [gated[k] for k in levels.sources[lv]]), index)
            m = self.cell(gather(table, levels.sender_tokens[lo - 1: hi - 1]), nei, nei_r)
            messages.append(m)
            gated.append(self.U_r(m))
        return torch.cat([torch.cat([pad, *messages]), torch.cat([pad, *gated])], dim=1)


def gather(source: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """source[index] via index_select, whose backward (index_add) is cheaper than advanced indexing's."""
    return source.index_select(0, index.reshape(-1)).view(*index.shape, *source.shape[1:])


# How messages are computed: (gru, levels, batch) -> message buffer. `reference.py` has the original's.
Propagate = Callable[[TreeGRU, Levels, TreeBatch], torch.Tensor]


def level_sweeps(gru: TreeGRU, levels: Levels, batch: TreeBatch) -> torch.Tensor:
    return gru.propagate(levels)


class Encoder(nn.Module):
    def __init__(self, hidden: int, latent: int) -> None:
        super().__init__()
        self.gru = TreeGRU(hidden)
        self.W_e = nn.Linear(hidden, hidden)  # eq. 7.7
        self.U_e = nn.Linear(hidden, hidden, bias=False)
        self.mean = nn.Linear(hidden, latent)
        self.log_var = nn.Linear(hidden, latent)

    def forward(self, batch: TreeBatch, propagate: Propagate = level_sweeps) -> tuple[torch.Tensor, torch.Tensor]:
        H = self.gru.hidden
        messages = propagate(self.gru, batch.encoder, batch)[:, :H]  # (M + 1, H)
        x = self.gru.embedding(batch.leaf_tokens)
        # A leaf's only incoming message is its parent's (eq. 7.7 summed over one neighbour).
        h_leaf = F.relu(self.W_e(x) + self.U_e(gather(messages, batch.leaf_incoming)))  # (L, H)
        h_tree = h_leaf.new_zeros(batch.n_trees, H).index_add(0, batch.leaf_tree, h_leaf)  # (B, H) eq. 7.8
        return self.mean(h_tree), -torch.abs(self.log_var(h_tree))


class Decoder(nn.Module):
    def __init__(self, hidden: int, latent: int, constraints: str, max_nodes: int) -> None:
        super().__init__()
        self.constraints, self.max_nodes = constraints, max_nodes
        self.gru = TreeGRU(hidden)
        self.stop_x = nn.Linear(hidden, hidden)  # eq. 7.9: W1 x + W2 z + W3 sum h, then u
        self.stop_z = nn.Linear(latent, hidden, bias=False)
        self.stop_h = nn.Linear(hidden, hidden, bias=False)
        self.stop_u = nn.Linear(hidden, 1)
        self.label_z = nn.Linear(latent, hidden)  # eq. 7.10: U tau(W1 z + W2 h)
        self.label_h = nn.Linear(hidden, hidden, bias=False)
        self.label_u = nn.Linear(hidden, N_TOKENS)

    def stop_logits(self, tokens: torch.Tensor, z: torch.Tensor, incoming_sum: torch.Tensor) -> torch.Tensor:
        x = self.gru.embedding(tokens)
        return self.stop_u(F.relu(self.stop_x(x) + self.stop_z(z) + self.stop_h(incoming_sum))).squeeze(1)

    def label_logits(self, z: torch.Tensor, message: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        logits = self.label_u(F.relu(self.label_z(z) + self.label_h(message)))
        return logits.masked_fill(~mask, float("-inf"))

    def forward(self, batch: TreeBatch, z: torch.Tensor, propagate: Propagate = level_sweeps) -> dict:
        """Teacher-forced losses (summed over the batch's decisions) and accuracies."""
        H = self.gru.hidden
        messages = propagate(self.gru, batch.decoder, batch)[:, :H]  # (M + 1, H)
        incoming = gather(messages, batch.stop_incoming).sum(1)  # (P, H)
        stop = self.stop_logits(batch.stop_tokens, gather(z, batch.stop_tree), incoming)  # (P,)
        free = batch.stop_free
        stop_loss = F.binary_cross_entropy_with_logits(stop[free], batch.stop_target[free], reduction="sum")
        labels = self.label_logits(gather(z, batch.label_tree), gather(messages, batch.label_incoming),
                                   batch.label_mask)  # (N, 42)
        label_loss = F.cross_entropy(labels, batch.label_target, reduction="sum")
        return {
            "label_loss": label_loss, "stop_loss": stop_loss,
            "label_acc": (labels.argmax(1) == batch.label_target).float().mean(),
            "stop_acc": ((stop[free] > 0).float() == batch.stop_target[free]).float().mean(),
        }

    @torch.no_grad()
    def decode(self, z: torch.Tensor) -> list[Walk]:
        """Greedy depth-first decoding of every row of z (B, latent), all trees one step at a time."""
        H, B = self.gru.hidden, len(z)
        walks = [Walk(self.constraints, self.max_nodes) for _ in range(B)]
        root_mask = torch.as_tensor(np.stack([w.root_labels() for w in walks]))
        roots = self.label_logits(z, z.new_zeros(B, H), root_mask).argmax(1)
        for w, token in zip(walks, roots.tolist(), strict=True):
            w.push(token)
        terms = self.gru.token_terms()  # (42, 3H)
        buf = z.new_zeros(2 * B * self.max_nodes + 1, 2 * H)  # message rows [m, U^r m]; row 0 padding
        n_msg = 1
        down_into: list[dict[int, int]] = [{} for _ in range(B)]  # node -> id of its parent's message
        ups_into: list[dict[int, list[int]]] = [{} for _ in range(B)]  # node -> ids of its children's messages
        active = list(range(B))
        while active:
            def incoming(b: int, from_parent: bool) -> list[int]:
                x = walks[b].current
                return ([down_into[b][x]] if from_parent and x else []) + ups_into[b].get(x, [])

            stop_in = torch.tensor([_pad(incoming(b, True), MAX_INCOMING + 1) for b in active])
            tokens = torch.tensor([walks[b].tokens[walks[b].current] for b in active])
            stop = self.stop_logits(tokens, z[active], buf[stop_in, :H].sum(1)).tolist()
            expand, options = [], []
            for b, logit in zip(active, stop, strict=True):
                may_stop, may_expand, labels = walks[b].options()
                expand.append(may_expand and (not may_stop or logit > 0))
                options.append(labels)
            # Expanding: the message to the new child; stopping: the message back to the parent (none
            # from a root, whose row is computed from nothing and never read).
            gru_in = torch.tensor([_pad(incoming(b, e) if e or walks[b].current else [], MAX_INCOMING)
                                   for b, e in zip(active, expand, strict=True)])
            nei = buf[gru_in]  # (n, 3, 2H)
            m = self.gru.cell(terms[tokens], nei[..., :H], nei[..., H:])  # (n, H)
            ids = list(range(n_msg, n_msg + len(active)))
            buf[n_msg: n_msg + len(active)] = torch.cat([m, self.gru.U_r(m)], dim=1)
            n_msg += len(active)
            grow = [i for i, e in enumerate(expand) if e]
            if grow:
                mask = torch.as_tensor(np.stack([options[i] for i in grow]))
                picked = self.label_logits(z[[active[i] for i in grow]], m[grow], mask).argmax(1).tolist()
            for i, b in enumerate(active):
                w = walks[b]
                if expand[i]:
                    w.push(picked[grow.index(i)])
                    down_into[b][w.current] = ids[i]
                else:
                    w.pop()
                    if w.current >= 0:
                        ups_into[b].setdefault(w.current, []).append(ids[i])
            active = [b for b in active if not walks[b].done]
        return walks


def _pad(ids: list[int], width: int) -> list[int]:
    return ids + [0] * (width - len(ids))


class PropertyPredictor(nn.Module):
    def __init__(self, latent: int, hidden: int) -> None:
        super().__init__()
        self.net = nn.Sequential(nn.Linear(latent, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                                 nn.Linear(hidden, hidden), nn.ReLU(), nn.Linear(hidden, N_CONTACTS))

    def forward(self, mean: torch.Tensor) -> torch.Tensor:
        return self.net(mean)


class GraphVAE(nn.Module):
    def __init__(self, config: VAEConfig) -> None:
        super().__init__()
        self.config = config
        self.encoder = Encoder(config.hidden, config.latent)
        self.decoder = Decoder(config.hidden, config.latent, config.constraints, config.max_nodes)
        self.predictor = PropertyPredictor(config.latent, config.predictor_hidden) if config.predictor else None
        for p in self.parameters():  # the reference's initialisation
            if p.dim() == 1:
                nn.init.zeros_(p)
            else:
                nn.init.xavier_normal_(p)

    def forward(self, batch: TreeBatch, beta: float, pred_weight: float, noise: torch.Tensor | None = None,
                propagate: Propagate = level_sweeps) -> dict:
        """Loss (eq. 7.12: label + stop + beta KL + lambda pred, each summed per tree and averaged over
        the batch except the predictor's MSE, a mean as in the reference) and its parts.

        `noise` (B, latent) is the reparameterisation's standard normal draw; None decodes from the mean.
        """
        B = batch.n_trees
        mean, log_var = self.encoder(batch, propagate)  # (B, latent) each
        z = mean if noise is None else mean + torch.exp(0.5 * log_var) * noise
        out = self.decoder(batch, z, propagate)
        out["kl"] = -0.5 * torch.sum(1 + log_var - mean.pow(2) - log_var.exp()) / B
        out["label_loss"], out["stop_loss"] = out["label_loss"] / B, out["stop_loss"] / B
        loss = out["label_loss"] + out["stop_loss"] + beta * out["kl"]
        measured = ~torch.isnan(batch.contacts).any(1)  # designs without rest contacts train no predictor
        if self.predictor is not None and bool(measured.any()):
            out["pred_loss"] = F.mse_loss(self.predictor(mean[measured]), batch.contacts[measured])
            loss = loss + pred_weight * out["pred_loss"]
        out["loss"] = loss
        return out
