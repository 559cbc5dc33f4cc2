"""The latent landscape (thesis Fig. 7.1): dataset designs' latent means in 2-D (PCA), with their
flat-terrain scores from the evaluator, for the VAE with and without the property predictor.

The thesis colours a few hundred designs; each score here is one MPPI episode (~10 s of a core at the
default evaluator settings), so the default scores a documented subset (`evaluated`) and places the
rest of the `designs` in the projection unscored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
import torch

from robocompose.io.errors import InputError
from robocompose.latent.batch import collate
from robocompose.latent.model import GraphVAE
from robocompose.latent.train import Designs

TASK = "flat"


@dataclass(frozen=True)
class LandscapeConfig:
    """The `train_vae.landscape:` section."""

    designs: int = 400  # dataset designs projected
    evaluated: int = 32  # of those, scored on flat terrain by the evaluator
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 < self.evaluated <= self.designs:
            raise InputError(f"need 0 < evaluated <= designs, got {self.evaluated} and {self.designs}")


def principal_components(x: np.ndarray, k: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(n, k) projection on the first k principal axes (sign fixed: largest loading positive), and the
    fraction of variance each explains."""
    centred = x - x.mean(0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    axes = vt[:k] * np.sign(vt[:k][np.arange(k), np.abs(vt[:k]).argmax(1)])[:, None]
    return centred @ axes.T, (s[:k] ** 2) / (s**2).sum()


def latent_means(model: GraphVAE, designs: Designs) -> np.ndarray:
    with torch.no_grad():
        mean, _ = model.encoder(collate(designs.replays, designs.contacts))
    return mean.double().numpy()


def landscape(models: dict[str, GraphVAE], designs: Designs, config: LandscapeConfig, evaluation, cache=None,
              executor=None) -> pd.DataFrame:
    """One row per (variant, design): its 2-D position and, for the scored subset, the evaluator's result."""
    from robocompose.evaluation.evaluate import evaluate_designs

    if config.designs > len(designs.ids):
        raise InputError(f"landscape: {config.designs} designs asked for, the dataset has {len(designs.ids)}")
    pick = np.random.default_rng(config.seed).choice(len(designs.ids), config.designs, replace=False)
    chosen = designs.subset(pick)
    scores = evaluate_designs(chosen.trees[: config.evaluated], [TASK], evaluation, seeds=[evaluation.seed],
                              cache=cache, executor=executor)
    frames = []
    for name, model in models.items():
        xy, explained = principal_components(latent_means(model, chosen))
        frame = pd.DataFrame({"variant": name, "design_id": chosen.ids, "pc1": xy[:, 0], "pc2": xy[:, 1],
                              "explained1": explained[0], "explained2": explained[1], "status": "",
                              "reward": np.nan})
        frame.loc[: config.evaluated - 1, "status"] = scores["status"].to_numpy()
        frame.loc[: config.evaluated - 1, "reward"] = scores["reward"].astype(float).to_numpy()
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)
