"""Quality of a trained VAE: reconstruction, what the prior decodes to, and the property predictor.

- reconstruction_accuracy: held-out designs whose latent mean decodes greedily to the same design (id).
- prior_validity: decodes of z ~ N(0, I) that are complete designs and build in pybullet with a finite
  rest state. Also reported: prior_grammar_valid (the grammar derives the design: its constructed rule
  sequence replays to the same design id) and prior_rest_valid (it passes the dataset's own rest check:
  no self-penetration, finite, GLSO's contact rule: >= 4 floor points, no mid-plane touch off the front).
- uniqueness: distinct designs among the valid prior decodes; novelty: distinct valid decodes that are
  not in the training set.
- property_mse: the predictor's MSE on the held-out contact vectors (None without a predictor);
  property_baseline_mse: the MSE of predicting the training designs' mean contact vector instead, and
  property_r2 = 1 - property_mse / property_baseline_mse (0: no better than the mean; None if that MSE is 0).

Each decoding metric is reported twice: with the model's own (masked) decoder, and under
"unconstrained" with the original's unmasked argmax over all 42 labels.
"""

from __future__ import annotations

import numpy as np
import torch

from robocompose.grammar.derivation import derive
from robocompose.latent.batch import collate
from robocompose.latent.constraints import grammar_rules, is_derivable
from robocompose.latent.model import GraphVAE
from robocompose.latent.train import Designs, reconstruction_accuracy

UNCONSTRAINED = "tree"  # the original's decoding: any label anywhere (see constraints.Walk)
DECODING_KEYS = ("reconstruction_accuracy", "prior_validity", "prior_grammar_valid", "prior_rest_valid",
                 "uniqueness", "novelty")


def prior_decodes(model: GraphVAE, n: int, seed: int, constraints: str | None = None) -> list:
    z = torch.randn(n, model.config.latent, generator=torch.Generator().manual_seed(seed))
    return [w.tree() if w.done else None for w in model.decoder.decode(z, constraints)]


def derivation_matches(tree) -> bool:
    """The grammar makes this design: its rule sequence derives a design with the same id."""
    return is_derivable(tree) and derive(grammar_rules(tree)).tree.design_id == tree.design_id


def decoding_metrics(model: GraphVAE, train_set: Designs, test_set: Designs, prior_samples: int, seed: int,
                     constraints: str | None, client: int) -> dict:
    """Reconstruction and prior metrics under one decoder (`constraints`: None = the model's own)."""
    from robocompose.sim.contacts import contact_features

    trees = prior_decodes(model, prior_samples, seed, constraints)
    reasons = [contact_features(t, client).reason if t is not None else "incomplete" for t in trees]
    valid = [t for t, r in zip(trees, reasons, strict=True) if r not in ("incomplete", "unstable")]
    distinct = {t.design_id for t in valid}
    known = set(train_set.ids)
    return {
        "reconstruction_accuracy": reconstruction_accuracy(model, test_set, constraints=constraints),
        "prior_validity": len(valid) / prior_samples,
        "prior_grammar_valid": sum(derivation_matches(t) for t in valid) / prior_samples,
        "prior_rest_valid": sum(r == "" for r in reasons) / prior_samples,
        "uniqueness": len(distinct) / max(1, len(valid)),
        "novelty": len(distinct - known) / max(1, len(distinct)),
    }


def vae_metrics(model: GraphVAE, train_set: Designs, test_set: Designs, prior_samples: int, seed: int) -> dict:
    """The model's own (constrained) decoding at the top level, the original's unmasked decoding under
    "unconstrained" (the same numbers for a model whose own constraints are already the unmasked ones)."""
    from robocompose.sim.physics import connect

    model.eval()
    client = connect()
    out = {"heldout_designs": len(test_set.ids), "prior_samples": prior_samples,
           "constraints": model.config.constraints,
           **decoding_metrics(model, train_set, test_set, prior_samples, seed, None, client),
           "property_mse": None, "property_baseline_mse": None, "property_r2": None}
    if model.predictor is not None:
        measured = ~np.isnan(test_set.contacts).any(1)
        with torch.no_grad():
            mean, _ = model.encoder(collate(test_set.replays, test_set.contacts))
            predicted = model.predictor(mean).numpy()
        target = test_set.contacts[measured]
        train_mean = train_set.contacts[~np.isnan(train_set.contacts).any(1)].mean(0)
        out["property_mse"] = float(np.mean((predicted[measured] - target) ** 2))
        out["property_baseline_mse"] = float(np.mean((train_mean - target) ** 2))
        if out["property_baseline_mse"] > 0:  # else every held-out vector is the mean: R^2 is undefined
            out["property_r2"] = 1 - out["property_mse"] / out["property_baseline_mse"]
    unconstrained = (out if model.config.constraints == UNCONSTRAINED else
                     decoding_metrics(model, train_set, test_set, prior_samples, seed, UNCONSTRAINED, client))
    out["unconstrained"] = {k: unconstrained[k] for k in DECODING_KEYS}
    return _rounded(out)


def _rounded(value):
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    return round(value, 6) if isinstance(value, float) else value
