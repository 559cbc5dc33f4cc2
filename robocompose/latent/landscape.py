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

The gate a thesis-scale VAE must pass before a campaign uses it (issue 42, item 6; `vae_gate`), per variant and
group, from the scores the group already has (no simulation): its latent k-NN Spearman must beat the same statistic
on a learning-free baseline, each design's count of every node type (`node_type_counts`), by `gate_margin` (0.1),
and a `window_width`-wide box (0.5: GLSO's collapsed domain-reduction window) around the group's best designs'
latent means must decode to >= `gate_distinct` (10) distinct designs of `window_samples` (200) uniform draws
(`window_distinct`; the median over the `gate_top` (5) best designs by reward).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from scipy.stats import spearmanr

from robocompose.grammar.tree import N_TOKENS, DesignTree
from robocompose.io import read_table
from robocompose.io.errors import InputError, check_field, check_number
from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import N_CONTACTS, GraphVAE
from robocompose.latent.train import Designs

TASK = "flat"
GATE_MARGIN = 0.1  # the latent k-NN Spearman must beat the node-type-count baseline's by this much (issue 42)
GATE_DISTINCT = 10  # distinct designs a window around a good design must decode to
WINDOW_WIDTH = 0.5  # per coordinate: the floor GLSO's domain reduction collapses to (BOConfig.minimum_window)
WINDOW_SAMPLES = 200  # uniform draws decoded per window
GATE_TOP = 5  # the window's median is over this many best designs of the group (by reward)
BOUND = 3.0  # GLSO's latent box [-BOUND, BOUND]^latent (BOConfig.bound)


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
    min_group: int = 30  # fewer scored designs of one (task, rung): no k-NN figure (and no gate) for it
    gate_margin: float = GATE_MARGIN  # the gate: latent k-NN Spearman - node-type-count k-NN Spearman >= this ...
    gate_distinct: int = GATE_DISTINCT  # ... and the window around the best designs decodes to >= this many designs
    window_width: float = WINDOW_WIDTH  # the window's width in every latent coordinate
    window_samples: int = WINDOW_SAMPLES  # uniform draws decoded per window
    gate_top: int = GATE_TOP  # best designs of a group (by reward) whose windows' median is the gate's figure

    def __post_init__(self) -> None:
        if not 0 < self.evaluated <= self.designs:
            raise InputError(f"need 0 < evaluated <= designs, got {self.evaluated} and {self.designs}")
        if not 0 < self.neighbours < self.min_group:
            raise InputError(f"need 0 < neighbours < min_group, got {self.neighbours} and {self.min_group}")
        if self.shuffles < 1:
            raise InputError(f"shuffles must be >= 1, got {self.shuffles}")
        check_number(self.gate_margin, "gate_margin", -2.0, 2.0)  # a difference of two Spearman correlations
        check_number(self.window_width, "window_width", 0.0, 2 * BOUND, "(]")
        check_field(self.window_samples >= 1, "window_samples", "an integer >= 1", self.window_samples)
        check_field(1 <= self.gate_distinct <= self.window_samples, "gate_distinct",
                    f"an integer in [1, window_samples ({self.window_samples})]", self.gate_distinct)
        check_field(1 <= self.gate_top <= self.min_group, "gate_top",
                    f"an integer in [1, min_group ({self.min_group})]", self.gate_top)


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
    # (n, n), a block of rows at a time (3,000 designs x 42 features at once would be 3 GB); the same numbers
    distances = np.concatenate([((block[:, None, :] - latents[None, :, :]) ** 2).sum(-1)
                                for block in np.array_split(latents, max(1, len(latents) // 256))])
    np.fill_diagonal(distances, np.inf)
    # Ties (integer features such as node-type counts tie often) go to the lower index: the stable sort keeps
    # the input order among equal distances, so the neighbours are a function of the data and its order alone.
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


def node_type_counts(trees: list[DesignTree]) -> np.ndarray:
    """(n, N_TOKENS) the learning-free baseline's features: how many nodes of each token each design has."""
    counts = np.zeros((len(trees), N_TOKENS))
    for row, tree in zip(counts, trees, strict=True):
        row += np.bincount(tree.tokens, minlength=N_TOKENS)
    return counts


def window_distinct(model: GraphVAE, z_centre: np.ndarray, width: float = WINDOW_WIDTH,
                    samples: int = WINDOW_SAMPLES, seed: int = 0, bound: float = BOUND) -> int:
    """Distinct designs (design ids) that `samples` points drawn uniformly in a box `width` wide in every
    coordinate around `z_centre` decode to, greedily (GLSO's decoding, `robocompose.glso.bo.decode`, batched).

    A box that would cross the latent box [-bound, bound] is shifted inside it, keeping its width, as
    bayes_opt's domain reduction keeps its window at the floor width near an edge."""
    check_number(width, "width", 0.0, 2 * bound)
    z_centre = np.asarray(z_centre, dtype=np.float64)
    low = np.clip(z_centre - width / 2, -bound, bound - width)
    points = np.random.default_rng(seed).uniform(low, low + width, size=(samples, len(z_centre)))
    with torch.no_grad():
        walks = model.decoder.decode(torch.as_tensor(points, dtype=torch.float32))
    return len({walk.tree().design_id for walk in walks})


def vae_gate(model: GraphVAE, latents: np.ndarray, baseline: dict, rewards: np.ndarray, latent_knn: dict,
             config: LandscapeConfig) -> dict:
    """The gate of one VAE on one group of scored designs: `latent_knn` (knn_predictability on `latents`) against
    `baseline` (the same on the group's node-type counts), and the distinct designs a window around each of the
    `gate_top` best designs by reward (ties: first in the group's order) decodes to, their median."""
    best = np.argsort(-rewards, kind="stable")[: config.gate_top]
    each = [window_distinct(model, latents[i], config.window_width, config.window_samples, config.seed)
            for i in best]
    margin = latent_knn["spearman"] - baseline["spearman"]
    distinct = float(np.median(each))
    return {"designs": latent_knn["designs"], "latent_spearman": latent_knn["spearman"],
            "node_count_spearman": baseline["spearman"], "margin": margin, "window_distinct": distinct,
            "window_distinct_each": each, "window_samples": config.window_samples,
            "window_width": config.window_width, "gate_margin": config.gate_margin,
            "gate_distinct": config.gate_distinct, "gate_top": config.gate_top,
            "passes": bool(margin >= config.gate_margin and distinct >= config.gate_distinct)}


def landscape(models: dict[str, GraphVAE], designs: Designs, config: LandscapeConfig, evaluation, cache=None,
              executor=None) -> tuple[pd.DataFrame, dict, dict]:
    """One row per (variant, design): its 2-D position and, for the scored subset and the search designs, the
    evaluator's result; the k-NN predictability of the scores per variant and (task, rung); and the gate
    (`vae_gate`) per variant and (task, rung), under the same keys."""
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
    frames, knn, gate, baselines = [], {}, {}, {}
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
            if len(group) < config.min_group:
                continue
            rows, rewards = group.index.to_numpy(), group["reward"].to_numpy(float)
            key = f"{name}/{task}/{rung}"
            knn[key] = knn_predictability(means[rows], rewards, config.neighbours, config.shuffles, config.seed)
            if (task, rung) not in baselines:  # the same for every variant
                counts = node_type_counts([found_designs.trees[i] for i in rows])
                baselines[task, rung] = knn_predictability(counts, rewards, config.neighbours, config.shuffles,
                                                           config.seed)
            gate[key] = vae_gate(model, means[rows], baselines[task, rung], rewards, knn[key], config)
    columns = list(frames[0].columns)
    return pd.concat([f[columns] for f in frames], ignore_index=True), knn, gate
