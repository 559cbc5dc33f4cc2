"""Two sweeps over a tree give the messages of a walk over the tree itself, and the original's 20 synchronous
iterations (and its depth-first decoder)."""

import dataclasses

import numpy as np
import torch

from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import GraphVAE, Sweeps, VAEConfig, level_sweeps
from robocompose.latent.reference import original, synchronous, walked_messages


def _longest_path(tree) -> int:
    depth = [0] * tree.n_links
    for i in range(1, tree.n_links):
        depth[i] = depth[tree.parents[i]] + 1
    best = [0] * tree.n_links  # longest downward path from each node
    longest = 0
    for i in reversed(range(tree.n_links)):
        kids = sorted((best[c] + 1 for c in tree.children(i)), reverse=True)
        best[i] = kids[0] if kids else 0
        longest = max(longest, sum(kids[:2]))
    return longest


def _losses_and_grads(model, batch, noise, propagate):
    out = model(batch, 0.3, 20.0, noise, propagate=propagate)
    grads = torch.autograd.grad(out["loss"], list(model.parameters()))
    return out, grads


def test_every_sweep_message_is_the_tree_walks_message_on_its_edge(trees, nogram_trees):
    torch.manual_seed(0)
    for kind, sample in (("grammar", trees[:10]), ("tree", nogram_trees[:10])):
        replays = [replay(t, kind, 50) for t in sample]
        batch = collate(replays, np.zeros((len(replays), 16)))
        model = GraphVAE(VAEConfig(hidden=16, latent=4, constraints=kind))
        grus = [model.encoder.gru, model.decoder.gru]
        with torch.no_grad():
            swept = level_sweeps(grus, batch)  # (2, M + 1, H)
            walked = [[walked_messages(g, r, decoder=bool(d)) for r in replays] for d, g in enumerate(grus)]
        assert batch.n_messages == sum(2 * (len(r.tokens) - 1) for r in replays)
        seen = set()
        for m, (tree, sender, receiver) in enumerate(batch.message_ends.tolist(), start=1):
            seen.add((tree, sender, receiver))
            for g in (0, 1):
                torch.testing.assert_close(swept[g, m], walked[g][tree][sender, receiver], rtol=1e-5, atol=1e-6)
        assert seen == {(b, *edge) for b, w in enumerate(walked[0]) for edge in w}  # each directed edge once


def test_a_miswired_message_is_caught(trees):
    """The walk does not read the level arrays: drop one incoming message from the decoder's wiring and
    the sweep's messages no longer all match it."""
    replays = [replay(t, "grammar", 50) for t in trees[:4]]
    batch = collate(replays, np.zeros((len(replays), 16)))
    model = GraphVAE(VAEConfig(hidden=8, latent=2))
    grus = [model.encoder.gru, model.decoder.gru]
    index = [ix.clone() for ix in batch.levels.index]
    lv = next(i for i, ix in enumerate(index) if (ix[0, 1] > batch.levels.bounds[-1]).any())
    j = int(torch.nonzero(index[lv][0, 1] > batch.levels.bounds[-1])[0])
    index[lv][0, 1, j] = batch.levels.bounds[-1]  # the decoder's padding row (message id 0)
    broken = dataclasses.replace(batch, levels=dataclasses.replace(batch.levels, index=index))
    with torch.no_grad():
        swept = level_sweeps(grus, broken)[1]
        walked = [walked_messages(grus[1], r, decoder=True) for r in replays]
    wrong = [m for m, (tree, s_, r_) in enumerate(broken.message_ends.tolist(), start=1)
             if not torch.allclose(swept[m], walked[tree][s_, r_], atol=1e-6)]
    assert wrong and wrong[0] == batch.levels.bounds[lv] + j


def test_two_sweeps_equal_twenty_synchronous_iterations(trees):
    torch.manual_seed(0)
    assert max(_longest_path(t) for t in trees) < 20
    batch = collate([replay(t, "grammar", 50) for t in trees], np.zeros((len(trees), 16)))
    model = GraphVAE(VAEConfig(hidden=16, latent=4))
    noise = torch.randn(len(trees), 4)
    ours, g_ours = _losses_and_grads(model, batch, noise, level_sweeps)
    ref, g_ref = _losses_and_grads(model, batch, noise, original())
    for key in ("loss", "label_loss", "stop_loss", "kl", "pred_loss"):
        torch.testing.assert_close(ours[key], ref[key], rtol=1e-5, atol=1e-5)
    for a, b in zip(g_ours, g_ref, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5)


def test_synchronous_messages_are_final_after_longest_path_iterations(trees):
    tree = max(trees, key=_longest_path)
    longest = _longest_path(tree)
    batch = collate([replay(tree, "grammar", 50)], np.zeros((1, 16)))
    gru = GraphVAE(VAEConfig(hidden=8, latent=2)).encoder.gru
    with torch.no_grad():
        sweeps = level_sweeps([gru], batch)[0]
        torch.testing.assert_close(synchronous(gru, batch, longest), sweeps)
        early = synchronous(gru, batch, longest - 1)
    assert not torch.allclose(early, sweeps)


def test_written_out_backward_matches_finite_differences(trees, nogram_trees):
    """Sweeps' hand-written backward, for the encoder alone (G = 1) and both GRUs (G = 2), in float64."""
    replays = [replay(t, "grammar", 50) for t in trees[:4]] + [replay(t, "tree", 50) for t in nogram_trees[:4]]
    levels = collate(replays, np.zeros((len(replays), 16))).levels
    gen = torch.Generator().manual_seed(0)
    for G in (1, 2):
        H = 4
        inputs = [torch.randn(G, 42, 3 * H, generator=gen, dtype=torch.float64)]
        inputs += [0.5 * torch.randn(G, H, H, generator=gen, dtype=torch.float64) for _ in range(3)]
        inputs = [x.requires_grad_() for x in inputs]
        assert torch.autograd.gradcheck(lambda *x: Sweeps.apply(levels, *x), inputs, fast_mode=True)
