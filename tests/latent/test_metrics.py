import numpy as np
import torch

from robocompose.latent.constraints import replay
from robocompose.latent.metrics import derivation_matches, prior_decodes, vae_metrics
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import Designs


def _designs(trees, kind: str) -> Designs:
    return Designs([t.design_id for t in trees], trees, [replay(t, kind, 30) for t in trees],
                   np.ones((len(trees), 16), dtype=np.float32))


def test_grammar_model_decodes_only_valid_designs(trees):
    torch.manual_seed(0)
    model = GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30))
    metrics = vae_metrics(model, _designs(trees[:30], "grammar"), _designs(trees[30:], "grammar"), 40, seed=0)
    assert metrics["prior_validity"] == 1.0 and metrics["prior_grammar_valid"] == 1.0
    assert 0 <= metrics["prior_rest_valid"] <= 1 and 0 < metrics["uniqueness"] <= 1 and 0 <= metrics["novelty"] <= 1
    assert metrics["heldout_designs"] == 10 and metrics["property_mse"] > 0


def test_free_model_decodes_trees_the_grammar_does_not_make(nogram_trees):
    torch.manual_seed(0)
    model = GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30, constraints="tree", predictor=False))
    trees = prior_decodes(model, 30, seed=1)
    assert all(t is not None for t in trees)
    assert not all(derivation_matches(t) for t in trees)
    metrics = vae_metrics(model, _designs(nogram_trees[:20], "tree"), _designs(nogram_trees[20:], "tree"), 10, 0)
    assert metrics["property_mse"] is None and metrics["prior_validity"] == 1.0
