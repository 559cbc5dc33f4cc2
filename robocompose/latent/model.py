"""GLSO's graph VAE (thesis 7.1): GRU message-passing tree encoder, depth-first tree decoder, property predictor.

Encoder (eqs. 7.1-7.8): GRU messages along every directed tree edge (here in one upward and one
downward sweep, which on a tree gives what the original's 20 synchronous iterations give; see
`batch.py` and `reference.py`), node states of the leaves that are not body links, summed; mean and
log-variance heads (log-variance = -|W h|, as the reference).
Decoder (eqs. 7.9-7.11): JT-VAE's depth-first decoder, teacher-forced in training. At every visit of a
node it predicts stop/expand from the node's token, z and the messages into it; a new child's label
comes from z and the message to it. Predictions are masked to what the constraints allow
(`constraints.py`): in training forced decisions carry no loss, in decoding every latent point gives a
complete design (`decode(z, "tree")` decodes as the original, unmasked).
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
from robocompose.io.errors import InputError
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
                raise InputError(f"{name} must be a positive integer, got {getattr(self, name)}")
        if self.constraints not in KINDS:
            raise InputError(f"constraints must be one of {KINDS}, got {self.constraints!r}")


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


def gather(source: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """source[index] via index_select, whose backward (index_add) is cheaper than advanced indexing's."""
    return source.index_select(0, index.reshape(-1)).view(*index.shape, *source.shape[1:])


def level_sweeps(grus: list[TreeGRU], batch: TreeBatch) -> torch.Tensor:
    """Messages of the encoder's GRU, or of the encoder's and the decoder's ([encoder.gru, decoder.gru]).

    Returns (G, M + 1, H): the messages of each of the G GRUs by id (row 0: padding). See `Sweeps`.
    """
    table = torch.stack([g.token_terms() for g in grus])  # (G, 42, 3H): W^z x, W^r x, W x
    U_z, U_r, U = (torch.stack([getattr(g, name).weight.t() for g in grus]) for name in ("U_z", "U_r", "U"))
    return Sweeps.apply(batch.levels, table, U_z, U_r, U)  # weights (G, H, H), transposed: x @ U^T


class Sweeps(torch.autograd.Function):
    """Eqs. 7.2-7.6 level by level for G GRUs at once, with the backward pass written out.

    At this size (H = 128, ~60 messages per level) a step costs per-op overhead and memory traffic as
    much as arithmetic, so:
    - both GRUs compute level l together (same senders): their weights are stacked and every op of a
      level serves both (bmm over G);
    - each message is stored with U^r m, because every message is read by up to three others: eq.
      7.4's U^r m_k then costs one matmul per message instead of one per reader;
    - the backward pass is written out instead of recorded by autograd (~15 plain ops per level
      instead of ~50 tracked ones), scatters into one gradient buffer, and computes each weight's
      gradient with one matmul over all messages at the end.
    The tests check losses and gradients against `reference.py` (autograd through `TreeGRU.cell`).
    """

    @staticmethod
    def forward(ctx, levels: Levels, table: torch.Tensor, U_z: torch.Tensor, U_r: torch.Tensor,
                U: torch.Tensor) -> torch.Tensor:
        G, H = U.shape[:2]
        K = MAX_INCOMING
        rows = table.new_zeros(G * levels.bounds[-1], 2 * H)  # [m, U^r m] of GRU g, message id i at g (M + 1) + i
        buf = rows.view(G, -1, 2 * H)  # (G, M + 1, 2H)
        x_all = table.index_select(1, levels.sender_tokens)  # (G, M, 3H): W^z x, W^r x, W x of every sender
        saved = []
        for lv, (lo, hi) in enumerate(zip(levels.bounds[:-1], levels.bounds[1:], strict=True)):
            n = hi - lo
            nei = rows.index_select(0, levels.index[lv][:, :G].reshape(-1)).view(K, G, n, 2 * H)
            m_in, ur_in = nei.split(H, dim=3)  # (3, G, n, H) each: incoming m_k and U^r m_k
            xz, xr, xh = x_all[:, lo - 1: hi - 1].split(H, dim=2)  # (G, n, H)
            s = m_in.sum(0)  # (G, n, H) eq. 7.2
            z = torch.sigmoid(torch.baddbmm(xz, s, U_z))  # eq. 7.3
            r = torch.sigmoid(xr + ur_in)  # (3, G, n, H) eq. 7.4
            q = (r * m_in).sum(0)  # (G, n, H)
            # eq. 7.5: m~ = tanh(.) = 2 sigma(2 .) - 1 (torch's float tanh is several times slower than sigmoid)
            h = torch.sigmoid(torch.baddbmm(xh, q, U, beta=2, alpha=2)).mul_(2).sub_(1)
            d = h - s
            m = torch.addcmul(s, z, d, out=buf[:, lo:hi, :H])  # eq. 7.6: (1 - z) s + z m~
            torch.bmm(m, U_r, out=buf[:, lo:hi, H:])
            saved.append((m_in, r, s, z, h, d, q))
        ctx.levels, ctx.saved, ctx.buf = levels, saved, buf
        ctx.save_for_backward(U_z, U_r, U)
        return buf[..., :H]

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple:
        """grad (G, M + 1, H) of the messages -> gradients of table, U_z, U_r and U.

        Levels in reverse: when level l is reached, every reader of its messages (a later level, or the
        heads via `grad`) has added its part to the level's rows of `grads`. With a = pre-activation:
        m = s + z (m~ - s), m~ = tanh(a_h), z = sigma(a_z), r_k = sigma(a_r,k),
        a_h = W x + U q, q = sum_k r_k m_k, a_z = W^z x + U^z s, a_r,k = W^r x + U^r m_k.
        """
        levels, buf = ctx.levels, ctx.buf
        U_z, U_r, U = ctx.saved_tensors
        G, H = U.shape[:2]
        grads = grad.new_zeros(G * levels.bounds[-1], 2 * H)  # gradient of every stored row [m, U^r m]
        gbuf = grads.view(G, -1, 2 * H)
        gbuf[..., :H] = grad
        d_x, d_pre_z, d_pre_h = [], [], []  # per level, last level first
        for lv in reversed(range(len(levels.bounds) - 1)):
            lo, hi = levels.bounds[lv], levels.bounds[lv + 1]
            m_in, r, s, z, h, d, q = ctx.saved[lv]
            g = gbuf[:, lo:hi]  # complete: every reader of this level is a later level, already done
            dm = torch.baddbmm(g[..., :H], g[..., H:], U_r.transpose(1, 2))  # (G, n, H): direct and via U^r m
            dh = dm * z
            dpre_h = torch.ops.aten.tanh_backward(dh, h)  # dh (1 - m~^2)
            dpre_z = torch.ops.aten.sigmoid_backward(dm * d, z)  # dm (m~ - s) z (1 - z)
            ds = torch.baddbmm(dm - dh, dpre_z, U_z.transpose(1, 2))  # dm (1 - z) + via U^z s
            dq = torch.bmm(dpre_h, U.transpose(1, 2))  # (G, n, H)
            dm_in = torch.addcmul(ds, dq, r)  # (3, G, n, H): via s and via r_k m_k
            dpre_r = torch.ops.aten.sigmoid_backward(dq * m_in, r)  # (3, G, n, H)
            # Rows [m_k, U^r m_k] read by this level get [dm_in, dpre_r].
            d_nei = torch.cat([dm_in, dpre_r], dim=3)
            grads.index_add_(0, levels.index[lv][:, :G].reshape(-1), d_nei.view(-1, 2 * H))
            d_x.append(torch.cat([dpre_z, dpre_r.sum(0), dpre_h], dim=2))  # (G, n, 3H)
            d_pre_z.append(dpre_z)
            d_pre_h.append(dpre_h)
        tokens = levels.sender_tokens
        d_table = grad.new_zeros(G, N_TOKENS, 3 * H).index_add_(1, tokens, torch.cat(d_x[::-1], dim=1))
        s_all, q_all = (torch.cat([x[i] for x in ctx.saved], dim=1) for i in (2, 6))  # (G, M, H)
        d_U_z = torch.bmm(s_all.transpose(1, 2), torch.cat(d_pre_z[::-1], dim=1))
        d_U_r = torch.bmm(buf[:, 1:, :H].transpose(1, 2), gbuf[:, 1:, H:])
        d_U = torch.bmm(q_all.transpose(1, 2), torch.cat(d_pre_h[::-1], dim=1))
        return None, d_table, d_U_z, d_U_r, d_U


# How messages are computed: ([encoder.gru] or [encoder.gru, decoder.gru], batch) -> (G, M + 1, H).
# `reference.py` has the original's.
Propagate = Callable[[list[TreeGRU], TreeBatch], torch.Tensor]


class Encoder(nn.Module):
    def __init__(self, hidden: int, latent: int) -> None:
        super().__init__()
        self.gru = TreeGRU(hidden)
        self.W_e = nn.Linear(hidden, hidden)  # eq. 7.7
        self.U_e = nn.Linear(hidden, hidden, bias=False)
        self.mean = nn.Linear(hidden, latent)
        self.log_var = nn.Linear(hidden, latent)

    def forward(self, batch: TreeBatch, messages: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent mean and log-variance (B, latent); `messages` (M + 1, H) if already computed."""
        H = self.gru.hidden
        if messages is None:
            messages = level_sweeps([self.gru], batch)[0]  # (M + 1, H)
        # A leaf's only incoming message is its parent's (eq. 7.7 summed over one neighbour); W_e x is
        # computed once per token (42 rows) instead of once per leaf.
        x_terms = gather(self.W_e(self.gru.embedding.weight), batch.leaf_tokens)  # (L, H)
        h_leaf = F.relu(x_terms + self.U_e(gather(messages, batch.leaf_incoming)))  # (L, H)
        h_tree = h_leaf.new_zeros(batch.n_trees, H).index_add(0, batch.leaf_tree, h_leaf)  # (B, H) eq. 7.8
        return self.mean(h_tree), -torch.abs(self.log_var(h_tree))


class Decoder(nn.Module):
    def __init__(self, hidden: int, latent: int, constraints: str, max_nodes: int) -> None:
        super().__init__()
        self.constraints, self.max_nodes = constraints, max_nodes
        self.gru = TreeGRU(hidden)
        # eq. 7.9 with GLSO's extra hidden layer (its U_i): u . tau(V tau(W1 x + W3 sum h) + W2 z)
        self.stop_x = nn.Linear(hidden, hidden)  # U_i's x part (with its bias)
        self.stop_h = nn.Linear(hidden, hidden, bias=False)  # U_i's message part
        self.stop_hidden = nn.Linear(hidden, hidden)  # U's hidden part (with its bias)
        self.stop_z = nn.Linear(latent, hidden, bias=False)  # U's z part
        self.stop_u = nn.Linear(hidden, 1)  # U_o
        self.label_z = nn.Linear(latent, hidden)  # eq. 7.10: U tau(W1 z + W2 h)
        self.label_h = nn.Linear(hidden, hidden, bias=False)
        self.label_u = nn.Linear(hidden, N_TOKENS)

    # The x and z terms are computed once per token (42 rows) and per tree (B rows), then gathered for
    # each prediction (the same numbers as applying the layers to every prediction's row).

    def stop_logits(self, tokens: torch.Tensor, tree: torch.Tensor, z: torch.Tensor,
                    incoming_sum: torch.Tensor) -> torch.Tensor:
        """(P,) from each prediction's node token, tree (row of z) and sum of incoming messages (P, H)."""
        x_terms = gather(self.stop_x(self.gru.embedding.weight), tokens)  # (P, H)
        inner = F.relu(x_terms + self.stop_h(incoming_sum))  # (P, H)
        z_terms = gather(self.stop_z(z), tree)  # (P, H)
        return self.stop_u(F.relu(self.stop_hidden(inner) + z_terms)).squeeze(1)

    def label_logits(self, z: torch.Tensor, tree: torch.Tensor, message: torch.Tensor,
                     mask: torch.Tensor) -> torch.Tensor:
        """(N, 42) from each new node's tree (row of z), the message to it (N, H) and allowed labels."""
        logits = self.label_u(F.relu(gather(self.label_z(z), tree) + self.label_h(message)))
        return logits.masked_fill(~mask, float("-inf"))

    def forward(self, batch: TreeBatch, z: torch.Tensor, messages: torch.Tensor) -> dict:
        """Teacher-forced losses (summed over the batch's decisions) and accuracies, from the decoder's
        messages (M + 1, H) (`level_sweeps`, computed with the encoder's)."""
        incoming = gather(messages, batch.stop_incoming).sum(1)  # (P, H)
        stop = self.stop_logits(batch.stop_tokens, batch.stop_tree, z, incoming)  # (P,)
        free = batch.stop_free
        stop_loss = F.binary_cross_entropy_with_logits(stop[free], batch.stop_target[free], reduction="sum")
        labels = self.label_logits(z, batch.label_tree, gather(messages, batch.label_incoming),
                                   batch.label_mask)  # (N, 42)
        label_loss = F.cross_entropy(labels, batch.label_target, reduction="sum")
        chosen = batch.label_mask.sum(1) > 1  # labels the mask leaves a choice for (forced ones are always right)
        return {
            "label_loss": label_loss, "stop_loss": stop_loss,
            "label_acc": (labels.argmax(1) == batch.label_target)[chosen].float().mean(),
            "stop_acc": ((stop[free] > 0).float() == batch.stop_target[free]).float().mean(),
        }

    @torch.no_grad()
    def decode(self, z: torch.Tensor, constraints: str | None = None) -> list[Walk]:
        """Greedy depth-first decoding of every row of z (B, latent), all trees one step at a time.

        `constraints` defaults to the model's own (ours: masked to what the training data's kind allows);
        "tree" is the original's decoding: an argmax over all 42 labels, stop/expand unmasked except for
        the at most 4 neighbours and `max_nodes` nodes a tree may have.
        """
        H, B = self.gru.hidden, len(z)
        walks = [Walk(constraints or self.constraints, self.max_nodes) for _ in range(B)]
        root_mask = torch.as_tensor(np.stack([w.root_labels() for w in walks]))
        roots = self.label_logits(z, torch.arange(B), z.new_zeros(B, H), root_mask).argmax(1)
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
            stop = self.stop_logits(tokens, torch.tensor(active), z, buf[stop_in, :H].sum(1)).tolist()
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
                picked = self.label_logits(z, torch.tensor([active[i] for i in grow]), m[grow], mask).argmax(1).tolist()
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
        encoder_messages, decoder_messages = propagate([self.encoder.gru, self.decoder.gru], batch)
        mean, log_var = self.encoder(batch, encoder_messages)  # (B, latent) each
        z = mean if noise is None else mean + torch.exp(0.5 * log_var) * noise
        out = self.decoder(batch, z, decoder_messages)
        out["kl"] = -0.5 * torch.sum(1 + log_var - mean.pow(2) - log_var.exp()) / B
        out["label_loss"], out["stop_loss"] = out["label_loss"] / B, out["stop_loss"] / B
        loss = out["label_loss"] + out["stop_loss"] + beta * out["kl"]
        measured = ~torch.isnan(batch.contacts).any(1)  # designs without rest contacts train no predictor
        if self.predictor is not None and bool(measured.any()):
            out["pred_loss"] = F.mse_loss(self.predictor(mean[measured]), batch.contacts[measured])
            loss = loss + pred_weight * out["pred_loss"]
        out["loss"] = loss
        return out
