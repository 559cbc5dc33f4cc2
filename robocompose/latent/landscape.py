"""The latent landscape (thesis Fig. 7.1): dataset designs' latent means in 2-D (PCA), with their
flat-terrain scores from the evaluator, for the VAE with and without the property predictor.

The thesis colours a few hundred designs; each score here is one MPPI episode (~10 s of a core at the
default evaluator settings), so the default scores a documented subset (`evaluated`) and places the
rest of the `designs` in the projection unscored. The designs that searches scored are free to reuse: every
simulated design of the committed step tables under `searches` (the fidelity searches, named
`<task>__<rung>__<method>.parquet`) and of the GLSO campaign's finished runs under `campaign` joins the projection
with its score, projected on the dataset designs' axes.

A number says whether the latent space orders scores (`knn_predictability`): each scored design's score is
predicted by the mean of its k nearest neighbours' scores in the full latent space (leave one out), and the
Spearman correlation of prediction and score is set against the same statistic after shuffling the scores
(a permutation test), per (task, rung) group of designs scored by the same evaluator.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from scipy.stats import spearmanr

from robocompose.grammar.tree import DesignTree
from robocompose.io import read_table
from robocompose.io.errors import InputError
from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import N_CONTACTS, GraphVAE
from robocompose.latent.train import Designs

TASK = "flat"


@dataclass(frozen=True)
class LandscapeConfig:
    """The `train_vae.landscape:` section."""

    designs: int = 400  # dataset designs projected
    evaluated: int = 32  # of those, scored on flat terrain by the evaluator
    seed: int = 0
    searches: str = "measured/fidelity/searches"  # step tables of searches whose simulated designs join ("" = none)
    campaign: str = "measured/glso_campaign"  # the GLSO campaign's finished runs: their designs join too ("" = none)
    neighbours: int = 5  # k of the k-NN predictability
    shuffles: int = 1000  # permutations of the scores for its null distribution
    min_group: int = 30  # fewer scored designs of one (task, rung): no k-NN figure for it

    def __post_init__(self) -> None:
        if not 0 < self.evaluated <= self.designs:
            raise InputError(f"need 0 < evaluated <= designs, got {self.evaluated} and {self.designs}")
        if not 0 < self.neighbours < self.min_group:
            raise InputError(f"need 0 < neighbours < min_group, got {self.neighbours} and {self.min_group}")
        if self.shuffles < 1:
            raise InputError(f"shuffles must be >= 1, got {self.shuffles}")


def principal_axes(x: np.ndarray, k: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """(k, d) first k principal axes of x (sign fixed: largest loading positive) and the fraction of the
    variance each explains; project with `(y - x.mean(0)) @ axes.T`."""
    _, s, vt = np.linalg.svd(x - x.mean(0), full_matrices=False)
    axes = vt[:k] * np.sign(vt[:k][np.arange(k), np.abs(vt[:k]).argmax(1)])[:, None]
    return axes, (s[:k] ** 2) / (s**2).sum()


def latent_means(model: GraphVAE, designs: Designs) -> np.ndarray:
    with torch.no_grad():
        mean, _ = model.encoder(collate(designs.replays, designs.contacts))
    return mean.double().numpy()


def read_search_designs(directory: str | Path, constraints: str, max_nodes: int,
                        campaign: str | Path = "") -> tuple[pd.DataFrame, Designs]:
    """The distinct (task, rung, design) that the step tables under `directory` (fidelity searches) and
    `campaign` (the GLSO campaign's finished runs, at the rung its manifest records) scored, with the evaluator's
    status and reward of its first call (a repeat is a cache hit: the same result), and the designs to encode.

    Designs the decoder's constraints cannot walk are left out (none of a grammar search's are). No directory
    ("") reads nothing; one that does not exist is an error."""
    frames = []
    for name, where in (("searches", directory), ("campaign", campaign)):
        if where and not Path(where).is_dir():
            raise InputError(f"train_vae.landscape.{name}: {where} is not a directory of search step tables")
    for path in sorted(Path(directory).glob("*.parquet")) if directory else []:
        parts = path.stem.split("__")
        if len(parts) != 3:
            raise InputError(f"{path}: expected a search table named <task>__<rung>__<method>.parquet")
        steps = read_table(path, "glso_steps")
        frames.append(steps.assign(rung=parts[1], source=f"search:{parts[2]}"))
    if campaign:
        from robocompose.evaluation.manifest import MANIFEST_FILE, read_manifest

        tables = sorted(Path(campaign).glob("*.parquet"))
        rung = read_manifest(campaign).get("rung")
        if tables and not rung:
            raise InputError(f"{Path(campaign) / MANIFEST_FILE}: missing; the campaign's runs do not say their rung")
        for path in tables:
            steps = read_table(path, "glso_steps")
            frames.append(steps.assign(rung=rung, source="campaign:" + steps["method"]))
    columns = ["task", "rung", "source", "design_id", "status", "reward"]
    if not frames:
        return pd.DataFrame(columns=columns), Designs([], [], [], np.zeros((0, N_CONTACTS), dtype=np.float32))
    steps = pd.concat(frames, ignore_index=True).drop_duplicates(["task", "rung", "design_id"])
    keep, trees, replays = [], [], []
    for i, row in enumerate(steps.itertuples()):
        tree = DesignTree(tuple(int(p) for p in row.parents), tuple(int(t) for t in row.tokens))
        try:
            replays.append(replay(tree, constraints, max_nodes))
        except ValueError:
            continue
        keep.append(i)
        trees.append(tree)
    table = steps.iloc[keep][columns].reset_index(drop=True)
    no_contacts = np.zeros((len(trees), N_CONTACTS), dtype=np.float32)  # search designs carry no contact vector
    return table, Designs(list(table["design_id"]), trees, replays, no_contacts)


def knn_predictability(latents: np.ndarray, scores: np.ndarray, k: int, shuffles: int, seed: int) -> dict:
    """Leave-one-out k-NN prediction of each score from its neighbours in latent space: the Spearman correlation
    of prediction and score, its mean and 95th percentile over `shuffles` permutations of the scores, and the
    one-sided permutation p-value (observed >= shuffled)."""
    distances = ((latents[:, None, :] - latents[None, :, :]) ** 2).sum(-1)  # (n, n)
    np.fill_diagonal(distances, np.inf)
    neighbours = np.argsort(distances, axis=1, kind="stable")[:, :k]  # (n, k)

    def statistic(values: np.ndarray) -> float:
        return float(spearmanr(values[neighbours].mean(1), values).statistic)

    observed = statistic(scores)
    rng = np.random.default_rng(seed)
    null = np.array([statistic(rng.permutation(scores)) for _ in range(shuffles)])
    null = np.nan_to_num(null, nan=0.0)  # a constant shuffled prediction correlates with nothing
    return {"designs": len(scores), "spearman": observed, "shuffled_mean": float(null.mean()),
            "shuffled_95": float(np.quantile(null, 0.95)),
            "p_value": float((1 + (null >= observed).sum()) / (1 + shuffles))}


def landscape(models: dict[str, GraphVAE], designs: Designs, config: LandscapeConfig, evaluation, cache=None,
              executor=None) -> tuple[pd.DataFrame, dict]:
    """One row per (variant, design): its 2-D position and, for the scored subset and the search designs, the
    evaluator's result; and the k-NN predictability of the scores per variant and (task, rung)."""
    from robocompose.evaluation.evaluate import evaluate_designs

    if config.designs > len(designs.ids):
        raise InputError(f"landscape: {config.designs} designs asked for, the dataset has {len(designs.ids)}")
    pick = np.random.default_rng(config.seed).choice(len(designs.ids), config.designs, replace=False)
    chosen = designs.subset(pick)
    scores = evaluate_designs(chosen.trees[: config.evaluated], [TASK], evaluation, seeds=[evaluation.seed],
                              cache=cache, executor=executor)
    model_config = next(iter(models.values())).config
    found, found_designs = read_search_designs(config.searches, model_config.constraints, model_config.max_nodes,
                                               config.campaign)
    frames, knn = [], {}
    for name, model in models.items():
        dataset_means = latent_means(model, chosen)
        axes, explained = principal_axes(dataset_means)
        xy = (dataset_means - dataset_means.mean(0)) @ axes.T
        frame = pd.DataFrame({"variant": name, "design_id": chosen.ids, "pc1": xy[:, 0], "pc2": xy[:, 1],
                              "explained1": explained[0], "explained2": explained[1], "status": "",
                              "reward": np.nan, "source": "dataset", "task": TASK, "rung": "default"})
        frame.loc[: config.evaluated - 1, "status"] = scores["status"].to_numpy()
        frame.loc[: config.evaluated - 1, "reward"] = scores["reward"].astype(float).to_numpy()
        frames.append(frame)
        if not found_designs.ids:
            continue
        means = latent_means(model, found_designs)
        projected = (means - dataset_means.mean(0)) @ axes.T
        frames.append(found.assign(variant=name, pc1=projected[:, 0], pc2=projected[:, 1],
                                   explained1=explained[0], explained2=explained[1]))
        for (task, rung), group in found[found["status"] == "ok"].groupby(["task", "rung"]):
            if len(group) >= config.min_group:
                knn[f"{name}/{task}/{rung}"] = knn_predictability(
                    means[group.index.to_numpy()], group["reward"].to_numpy(float), config.neighbours,
                    config.shuffles, config.seed)
    columns = list(frames[0].columns)
    return pd.concat([f[columns] for f in frames], ignore_index=True), knn
