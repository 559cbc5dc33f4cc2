"""A batch computes what its trees compute one at a time (collate's id remapping and levels)."""

import numpy as np
import torch

from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import GraphVAE, VAEConfig


def test_batch_equals_its_trees_one_at_a_time(trees, nogram_trees):
    torch.manual_seed(0)
    for kind, sample in (("grammar", trees[:12]), ("tree", nogram_trees[:12])):
        replays = [replay(t, kind, 50) for t in sample]
        model = GraphVAE(VAEConfig(hidden=16, latent=4, constraints=kind))
        with torch.no_grad():
            whole = model(collate(replays, np.zeros((len(replays), 16))), 0.5, 1.0)
            mean, _ = model.encoder(collate(replays, np.zeros((len(replays), 16))))
            one = [model(collate([r], np.zeros((1, 16))), 0.5, 1.0) for r in replays]
            means = torch.cat([model.encoder(collate([r], np.zeros((1, 16))))[0] for r in replays])
        torch.testing.assert_close(mean, means, rtol=1e-5, atol=1e-6)
        for key in ("label_loss", "stop_loss", "kl"):  # per-tree sums averaged over the batch
            torch.testing.assert_close(whole[key], torch.stack([o[key] for o in one]).mean(), rtol=1e-5, atol=1e-5)
