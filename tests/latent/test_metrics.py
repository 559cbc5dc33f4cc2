import numpy as np
import pytest
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
    # uniqueness and novelty are the counts of the same 40 prior decodes (all valid here)
    decoded = {t.design_id for t in prior_decodes(model, 40, seed=0)}
    known = {t.design_id for t in trees[:30]}
    assert metrics["uniqueness"] == pytest.approx(len(decoded) / 40, abs=1e-6)
    assert metrics["novelty"] == pytest.approx(len(decoded - known) / len(decoded), abs=1e-6)
    assert metrics["prior_rest_valid"] <= metrics["prior_validity"]  # the rest check only removes designs
    assert metrics["heldout_designs"] == 10 and metrics["property_mse"] > 0
    # The original's unmasked decoding of the same untrained model: labels from all 42 tokens, so (almost)
    # nothing it decodes is a grammar design.
    unmasked = metrics["unconstrained"]
    assert set(unmasked) == {"reconstruction_accuracy", "prior_validity", "prior_grammar_valid", "prior_rest_valid",
                             "uniqueness", "novelty"}
    assert unmasked["prior_grammar_valid"] < 0.5 and unmasked["reconstruction_accuracy"] == 0.0


def test_unconstrained_decoding_places_any_token_anywhere():
    torch.manual_seed(0)
    model = GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30))
    trees = prior_decodes(model, 60, seed=2, constraints="tree")
    assert len({t.tokens[0] for t in trees}) > 1  # the root is not forced to be the root body
    assert max(len(t.children(0)) for t in trees) <= 4
    assert all(len(t.children(i)) <= 3 for t in trees for i in range(1, t.n_links))


def test_free_model_decodes_trees_the_grammar_does_not_make(nogram_trees):
    torch.manual_seed(0)
    model = GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30, constraints="tree", predictor=False))
    trees = prior_decodes(model, 30, seed=1)
    assert all(t is not None for t in trees)
    assert not all(derivation_matches(t) for t in trees)
    metrics = vae_metrics(model, _designs(nogram_trees[:20], "tree"), _designs(nogram_trees[20:], "tree"), 10, 0)
    assert metrics["property_mse"] is None and metrics["prior_validity"] == 1.0


class _Constant(torch.nn.Module):
    def __init__(self, value: np.ndarray) -> None:
        super().__init__()
        self.value = torch.as_tensor(value, dtype=torch.float32)

    def forward(self, mean: torch.Tensor) -> torch.Tensor:  # (B, latent) -> (B, 16)
        return self.value.expand(len(mean), -1)


def test_property_r2_is_zero_for_the_training_mean_and_negative_below_it(trees):
    rng = np.random.default_rng(0)
    train, test = _designs(trees[:30], "grammar"), _designs(trees[30:], "grammar")
    train = Designs(train.ids, train.trees, train.replays, rng.normal(size=(30, 16)).astype(np.float32))
    test = Designs(test.ids, test.trees, test.replays, rng.normal(size=(10, 16)).astype(np.float32))
    model = GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30))
    train_mean = train.contacts.mean(0)
    model.predictor = _Constant(train_mean)
    at_mean = vae_metrics(model, train, test, 4, seed=0)
    assert at_mean["property_baseline_mse"] == pytest.approx(float(np.mean((train_mean - test.contacts) ** 2)), 1e-5)
    assert at_mean["property_mse"] == pytest.approx(at_mean["property_baseline_mse"], 1e-5)
    assert at_mean["property_r2"] == pytest.approx(0.0, abs=1e-5)
    model.predictor = _Constant(train_mean + 1.0)
    assert vae_metrics(model, train, test, 4, seed=0)["property_r2"] < -0.5
