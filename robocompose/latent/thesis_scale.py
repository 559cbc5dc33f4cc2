"""The VAE at the thesis's scale, measured here in committed pieces (issue 42, item 6).

The default profile's VAE (hidden 128, 6,000 steps, ~13k designs, predictor weight 5) fails the gate a VAE must
pass before a GLSO campaign searches it (`landscape.vae_gate`). This is the VAE a reviewer asks for before
blaming GLSO: hidden 450 and predictor weight 20 (the thesis's), trained on >= 100k enumerated designs for
>= 100k steps (thesis: 5e5 designs, 400k steps). That is ~6-8 core-hours of training here, more than a session,
so it runs in resumable pieces committed under `directory` (`robocompose glso-campaign vae`):

    designs-KKK.parquet   `piece` designs each (the last as many as are missing), the dataset's own
                          enumeration (`enumerate:` filters) with seed `seed` + K; enumerated until the pieces
                          hold `designs` distinct designs (a design in two pieces counts once: the first keeps it)
    checkpoint-VARIANT.pt the training run in progress of each VAE of `variants` (model, Adam state, step, log),
                          every `checkpoint_every` steps; committed at the end of a session, resumed bit for bit
    log/VARIANT/          its training curves (dvclive) and vae_thesis_VARIANT.mcap, rewritten at every checkpoint
    vae_VARIANT.pt        the trained model, once `train.steps` are done (its checkpoint is then removed)

The variants are the two latent methods' VAEs, trained one after the other on the same designs: `full` (GLSO's: the
property predictor, weight 20; the one the gate judges) and `nopred` (GLSO_nopred's: the same VAE without the
predictor), which a campaign needs only once `full` passes its gate (issue 42: "if it passes, run GLSO and
GLSO_nopred on it"), so `variants` starts as [full].

The schedule is the thesis's compressed from 400k to `train.steps` steps (learning-rate decay, KL warm-up and KL
increments every quarter as many steps), so the final KL weight is the thesis's ~0.36. The run's key covers the
settings, the designs' content and the training code; a committed checkpoint of another key is refused (one line,
before the training log is touched), never silently restarted: deleting it is the user's call. Outside the pinned
dispatch (`io.dispatch`) the key also carries the processor, so train through the `robocompose` command (pinned): a
natively trained checkpoint resumes on no machine of other processor flags. Stage `vae_landscape` gates the finished
`full` model on the campaign's scored designs beside the default VAEs (`thesis` rows) and reports progress until
then; a campaign searches a thesis-scale VAE only once that gate has passed on this very model file
(`glso.campaign.check_thesis_gate`).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, replace
from pathlib import Path

from robocompose.io import read_table, write_table
from robocompose.io.errors import InputError, check_field
from robocompose.latent.model import VAEConfig
from robocompose.latent.train import Designs, TrainConfig, designs_from_table

PIECE_GLOB = "designs-*.parquet"
VARIANTS = ("full", "nopred")  # GLSO's VAE (gated) and GLSO_nopred's (no property predictor)
MIN_DESIGNS = 100_000  # issue 42: a thesis-scale VAE sees at least this many designs ...
MIN_STEPS = 100_000  # ... for at least this many optimiser steps (fewer: a trial, labelled so by `progress`)
VARIANT = "thesis"  # the gated (full) VAE's key in vae_landscape's gate and k-NN figures
TITLE = "GLSO's VAE at thesis scale"


def thesis_schedule(steps: int) -> TrainConfig:
    """The thesis's optimisation (`TrainConfig`'s defaults: 400k steps) with its step counts scaled to `steps`."""
    thesis = TrainConfig()
    scale = steps / thesis.steps
    return replace(thesis, steps=steps, lr_decay_every=round(thesis.lr_decay_every * scale),
                   beta_start=round(thesis.beta_start * scale), beta_every=round(thesis.beta_every * scale),
                   log_every=500, eval_every=10_000, eval_designs=300, checkpoint_every=1_000, threads=1)


@dataclass(frozen=True)
class ThesisScaleConfig:
    """The `vae_thesis:` section of params.yaml."""

    directory: str = "measured/vae_thesis"  # the committed pieces (module docstring)
    designs: int = MIN_DESIGNS  # distinct designs to train on
    piece: int = 10_000  # designs per committed piece
    seed: int = 2000  # enumeration seed of piece K: seed + K (the dataset uses 0, train_vae.extra 1000)
    model: VAEConfig = field(default_factory=VAEConfig)  # the thesis's sizes (hidden 450, latent 28)
    train: TrainConfig = field(default_factory=lambda: thesis_schedule(MIN_STEPS))
    variants: list[str] = field(default_factory=lambda: ["full"])  # VAEs to train, in order (module docstring)

    def __post_init__(self) -> None:
        check_field(self.designs >= 1, "designs", "an integer >= 1", self.designs)
        check_field(1 <= self.piece <= self.designs, "piece", f"an integer in [1, designs ({self.designs})]",
                    self.piece)
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)
        check_field(self.model.predictor and self.model.constraints == "grammar", "model",
                    "GLSO's VAE: predictor true, constraints grammar", self.model)
        check_field(bool(self.variants) and len(set(self.variants)) == len(self.variants)
                    and set(self.variants) <= set(VARIANTS), "variants",
                    f"distinct names of {list(VARIANTS)}", self.variants)

    def variant_model(self, variant: str) -> VAEConfig:
        """The VAE of `variant`: `model`, without the property predictor for nopred."""
        return replace(self.model, predictor=variant == "full")


def checkpoint_path(config: ThesisScaleConfig, variant: str) -> Path:
    return Path(config.directory) / f"checkpoint-{variant}.pt"


def log_dir(config: ThesisScaleConfig, variant: str) -> Path:
    return Path(config.directory) / "log" / variant


def model_path(config: ThesisScaleConfig, variant: str) -> Path:
    return Path(config.directory) / f"vae_{variant}.pt"


def pieces(config: ThesisScaleConfig) -> list[Path]:
    return sorted(Path(config.directory).glob(PIECE_GLOB))


def design_ids(config: ThesisScaleConfig) -> set[str]:
    return {i for path in pieces(config) for i in read_table(path, "designs")["design_id"]}


def distinct_designs(config: ThesisScaleConfig) -> int:
    return len(design_ids(config))


def enumerate_pieces(config: ThesisScaleConfig, enumeration, executor=None) -> list[Path]:
    """Enumerate and write pieces until they hold `config.designs` distinct designs; each piece is written once
    complete (a killed enumeration redoes only the piece it was in). `enumeration`: the `enumerate:` section
    (its filters; n and seed are the piece's)."""
    from robocompose.dataset.enumerate import enumerate_designs

    Path(config.directory).mkdir(parents=True, exist_ok=True)
    ids, k = design_ids(config), len(pieces(config))  # the committed pieces, read once
    while len(ids) < config.designs:
        n = min(config.piece, config.designs - len(ids))  # the last piece only as large as the target needs
        table, _ = enumerate_designs(replace(enumeration, n=n, seed=config.seed + k), executor,
                                     f"vae_thesis piece {k} ({len(ids):,} of {config.designs:,} designs)")
        write_table(table, Path(config.directory) / f"designs-{k:03d}.parquet", "designs")
        ids, k = ids | set(table["design_id"]), k + 1
    return pieces(config)


def load_pieces(config: ThesisScaleConfig) -> Designs:
    """Every piece's designs in piece order, a design that an earlier piece holds dropped; an InputError while
    fewer than `config.designs` are there."""
    import pandas as pd

    tables = [read_table(path, "designs") for path in pieces(config)]
    if not tables:
        raise InputError(f"{config.directory}: no {PIECE_GLOB} pieces; run `robocompose glso-campaign vae`")
    table = pd.concat(tables, ignore_index=True).drop_duplicates("design_id", keep="first")
    if len(table) < config.designs:
        raise InputError(f"{config.directory}: {len(table):,} distinct designs in its pieces, expected >= "
                         f"{config.designs:,} (vae_thesis.designs); run `robocompose glso-campaign vae`")
    return designs_from_table(table.reset_index(drop=True), config.model.constraints, config.model.max_nodes,
                              f"{config.directory}/{PIECE_GLOB}")


def train_thesis_scale(config: ThesisScaleConfig, variant: str) -> Path:
    """Train (or resume) the thesis-scale VAE `variant` on the committed pieces; its model file once done."""
    from robocompose.latent.train import save_model, train, training_log

    if model_path(config, variant).exists():
        return model_path(config, variant)
    designs = load_pieces(config)
    check_resumable(config, variant, designs)  # before the log opens: a fresh log would erase the committed one
    with training_log(log_dir(config, variant)) as live:
        model, _, _ = train(config.variant_model(variant), config.train, designs, checkpoint_path(config, variant),
                            live, log_dir(config, variant) / f"vae_thesis_{variant}.mcap",
                            progress=f"vae_thesis {variant}", named=True)
    save_model(model, model_path(config, variant))
    checkpoint_path(config, variant).unlink(missing_ok=True)
    return model_path(config, variant)


def check_resumable(config: ThesisScaleConfig, variant: str, designs: Designs) -> None:
    """An InputError (one line) if `variant`'s committed checkpoint holds another run: another key (settings,
    designs, training code, or a dispatch other than the pinned one: `io.dispatch`) or a damaged file."""
    from robocompose.io.checkpoint import load_checkpoint
    from robocompose.latent.train import run_key, split

    train_idx, _ = split(len(designs.ids), config.train.holdout, config.train.seed)  # train()'s split
    key = run_key(config.variant_model(variant), config.train, designs, designs.subset(train_idx))
    load_checkpoint(checkpoint_path(config, variant), key, named=True)


def progress(config: ThesisScaleConfig) -> dict:
    """Where the measurement stands, without loading a model: pieces, distinct designs, and per VAE of `variants`
    the steps done (from its training log's summary) of those asked, whether it is finished and its model file's
    SHA-256 (what a campaign checks the gate against)."""
    trained = {}
    for variant in config.variants:
        summary, model = log_dir(config, variant) / "metrics.json", model_path(config, variant)
        trained[variant] = {"step": json.loads(summary.read_text())["step"] if summary.exists() else 0,
                            "finished": model.exists(),
                            "sha256": hashlib.sha256(model.read_bytes()).hexdigest() if model.exists() else None}
    return {"directory": config.directory, "pieces": len(pieces(config)), "designs": distinct_designs(config),
            "designs_asked": config.designs, "steps": config.train.steps, "trained": trained,
            "hidden": config.model.hidden, "pred_weight": config.train.pred_weight,
            "issue_scale": config.designs >= MIN_DESIGNS and config.train.steps >= MIN_STEPS,
            "variant": VARIANT, "title": TITLE}


def finished_model(config: ThesisScaleConfig, variant: str = "full") -> Path | None:
    path = model_path(config, variant)
    return path if path.exists() else None
