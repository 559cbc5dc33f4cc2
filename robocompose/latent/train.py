"""Training the graph VAE: data split, the reference's schedules, checkpoints that resume, logs.

Every random choice is a function of (seed, step): the batch of step s is a slice of the permutation
of epoch s // steps_per_epoch, and its reparameterisation noise comes from a generator seeded with
(seed, s). A run resumed from a checkpoint (model, optimiser, step, log) therefore continues exactly
as the uninterrupted run would have (bit for bit at the same thread count).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from robocompose.grammar.tree import DesignTree
from robocompose.io import ArtifactError, McapWriter, read_table
from robocompose.io.checkpoint import load_checkpoint, save_checkpoint
from robocompose.io.errors import InputError, check_field, check_finite_fields, check_number
from robocompose.io.provenance import INFRASTRUCTURE, code_digest, settings_digest
from robocompose.io.torch_file import load_torch, save_torch
from robocompose.latent.batch import collate
from robocompose.latent.constraints import Replay, replay
from robocompose.latent.curves import CURVES, LOG_FIELDS
from robocompose.latent.model import GraphVAE, VAEConfig

if TYPE_CHECKING:
    import pandas as pd
    from dvclive import Live


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings (thesis: Adam 1e-3 x0.9 every 40k steps, clip 50, batch 32, 400k steps,
    beta 0 for 40k steps then +0.002 every 2k steps, predictor weight 20)."""

    steps: int = 400_000  # optimiser steps
    batch_size: int = 32
    lr: float = 1e-3
    lr_decay: float = 0.9  # learning rate x lr_decay every lr_decay_every steps
    lr_decay_every: int = 40_000
    clip_norm: float = 50.0
    beta_start: int = 40_000  # KL weight 0 until this step
    beta_every: int = 2_000  # then + beta_increment every beta_every steps
    beta_increment: float = 0.002
    beta_max: float = 1.0
    pred_weight: float = 20.0  # lambda of eq. 7.12 (ignored without a predictor)
    holdout: float = 0.1  # fraction of designs held out for reconstruction accuracy
    log_every: int = 100  # steps per logged row (losses averaged over them)
    eval_every: int = 2_000  # steps between held-out reconstruction checks in the log
    eval_designs: int = 200  # held-out designs decoded at each check
    checkpoint_every: int = 1_000  # steps between checkpoints
    seed: int = 0
    threads: int = 2  # torch intra-op threads

    def __post_init__(self) -> None:
        for name in ("steps", "batch_size", "lr_decay_every", "beta_every", "log_every", "eval_every",
                     "eval_designs", "checkpoint_every", "threads"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        for name in ("eval_every", "checkpoint_every"):  # logged rows must not straddle a resume
            check_field(getattr(self, name) % self.log_every == 0, name,
                        f"a multiple of log_every ({self.log_every})", getattr(self, name))
        check_field(self.beta_start >= 0, "beta_start", "an integer >= 0 (a step)", self.beta_start)
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)
        check_number(self.holdout, "holdout", 0.0, 1.0, "()")
        check_number(self.lr, "lr", 0.0, bounds="()")
        check_number(self.lr_decay, "lr_decay", 0.0, 1.0, "(]")  # x lr_decay every lr_decay_every steps
        check_number(self.clip_norm, "clip_norm", 0.0, bounds="()")
        check_number(self.beta_increment, "beta_increment", 0.0)
        check_number(self.beta_max, "beta_max", 0.0)
        check_number(self.pred_weight, "pred_weight", 0.0)
        check_finite_fields(self)


@dataclass(frozen=True)
class Designs:
    """A designs table prepared for the VAE: trees, their decoder walks and contact vectors."""

    ids: list[str]
    trees: list[DesignTree]
    replays: list[Replay]
    contacts: np.ndarray  # (n, 16)

    def join(self, other: Designs) -> Designs:
        return Designs(self.ids + other.ids, self.trees + other.trees, self.replays + other.replays,
                       np.concatenate([self.contacts, other.contacts]))

    def digest(self) -> str:
        """SHA-256 (16 hex digits) of the content: each design's tree as given (order matters to the decoder
        walk), its contact vector, and their order."""
        digest = hashlib.sha256()
        for design_id, tree in zip(self.ids, self.trees, strict=True):
            digest.update(f"{design_id}:{tree.parents}:{tree.tokens};".encode())
        digest.update(np.ascontiguousarray(self.contacts, dtype=np.float32).tobytes())
        return digest.hexdigest()[:16]

    def subset(self, idx: np.ndarray) -> Designs:
        return Designs([self.ids[i] for i in idx], [self.trees[i] for i in idx], [self.replays[i] for i in idx],
                       self.contacts[idx])


def load_designs(path: str | Path, constraints: str, max_nodes: int) -> Designs:
    """Read a `designs` table; every design must satisfy the decoder's constraints (else InputError)."""
    return designs_from_table(read_table(path, "designs"), constraints, max_nodes, str(path))


def designs_from_table(table: pd.DataFrame, constraints: str, max_nodes: int, source: str) -> Designs:
    """A `designs` table (read from `source`) prepared for the VAE; every design must satisfy the decoder's
    constraints (else InputError naming `source`)."""
    trees = [DesignTree(tuple(int(p) for p in row.parents), tuple(int(t) for t in row.tokens))
             for row in table.itertuples()]
    replays = []
    for tree, design_id in zip(trees, table["design_id"], strict=True):
        try:
            replays.append(replay(tree, constraints, max_nodes))
        except ValueError as err:
            raise InputError(f"{source}: design {design_id} cannot be decoded under {constraints!r}: {err}") from None
    contacts = np.array([np.asarray(c, dtype=np.float32) for c in table["contacts"]]).reshape(len(table), 16)
    return Designs(list(table["design_id"]), trees, replays, contacts)


def split(n: int, holdout: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train, held-out) indices: a seeded permutation, the first `holdout` fraction held out."""
    perm = np.random.default_rng([seed, 1]).permutation(n)
    k = max(1, round(holdout * n))
    return np.sort(perm[k:]), np.sort(perm[:k])


def batch_indices(step: int, n: int, batch_size: int, seed: int) -> np.ndarray:
    """Rows of step `step`: consecutive slices of one permutation per epoch (the last partial slice dropped)."""
    per_epoch = max(1, n // batch_size)
    epoch, k = divmod(step, per_epoch)
    perm = np.random.default_rng([seed, 2, epoch]).permutation(n)
    return perm[k * batch_size: (k + 1) * batch_size]


def beta_at(step: int, c: TrainConfig) -> float:
    if step < c.beta_start:
        return 0.0
    return min(c.beta_max, c.beta_increment * ((step - c.beta_start) // c.beta_every + 1))


def lr_at(step: int, c: TrainConfig) -> float:
    return c.lr * c.lr_decay ** (step // c.lr_decay_every)


def reconstruction_accuracy(model: GraphVAE, designs: Designs, chunk: int = 256,
                            constraints: str | None = None) -> float:
    """Fraction of designs whose latent mean decodes (greedily, under `constraints`: None = the model's
    own) to the same design."""
    hits = 0
    with torch.no_grad():
        for lo in range(0, len(designs.ids), chunk):
            part = designs.subset(np.arange(lo, min(lo + chunk, len(designs.ids))))
            mean, _ = model.encoder(collate(part.replays, part.contacts))
            walks = model.decoder.decode(mean, constraints)
            hits += sum(w.tree().design_id == i for w, i in zip(walks, part.ids, strict=True))
    return hits / len(designs.ids)


# Settings that do not change what step s computes: a checkpoint of a run that differs only in these
# continues (so raising `steps` extends a finished run instead of starting again).
BOOKKEEPING = ("steps", "log_every", "eval_every", "eval_designs", "checkpoint_every")


def run_key(model_config: VAEConfig, config: TrainConfig, designs: Designs, train_set: Designs) -> str:
    """What a checkpoint must match to be resumed: the model, the training settings except bookkeeping, the
    data's content (trees and contact vectors, not only their ids) and the source of the training code."""
    unused = ("pred_weight",) if not model_config.predictor else ()
    settings = {k: v for k, v in dataclasses.asdict(config).items() if k not in BOOKKEEPING + unused}
    return settings_digest([dataclasses.asdict(model_config), settings, designs.digest(), train_set.digest(),
                            code_digest("robocompose.latent.train", exclude=INFRASTRUCTURE)])


def save_model(model: GraphVAE, path: str | Path) -> Path:
    return save_torch({"config": dataclasses.asdict(model.config), "state": model.state_dict()}, path)


def load_model(path: str | Path) -> GraphVAE:
    """The VAE saved by `save_model` at `path`; any other file is an InputError naming it.

    Loaded with `weights_only=True`: tensors and plain containers only, never arbitrary pickled objects.
    """
    path = Path(path)
    expected = "expected a VAE saved by train_vae, e.g. models/vae_full.pt"
    if not path.is_file():
        raise InputError(f"{path}: no such model file ({expected}; train one with `dvc repro train_vae`)")
    try:
        saved = load_torch(path)  # the checksum first: a cut or flipped file never reaches torch.load
    except ArtifactError as err:  # cut, flipped, no torch archive, or objects other than tensors
        raise InputError(f"{err} ({expected})") from None
    if not isinstance(saved, dict) or not {"config", "state"} <= set(saved):
        raise InputError(f"{path}: not a robocompose model ({expected}, a dict with 'config' and 'state')")
    try:
        model = GraphVAE(VAEConfig(**saved["config"]))
        model.load_state_dict(saved["state"])
    except (TypeError, ValueError, RuntimeError) as err:  # other fields, other shapes: another model's file
        raise InputError(f"{path}: model does not match this code's VAE ({expected}): "
                         f"{' '.join(str(err).split())[:240]}") from None
    return model.eval()


def training_log(directory: str | Path) -> Live:
    """dvclive, DVC's own logger, writing the curves under `directory` (plots/metrics/**.tsv and the summary
    metrics.json) for `dvc plots show/diff` and `dvc exp show`.

    Offline and passive: it saves no DVC experiment, leaves dvc.yaml and git alone (the stage's dvc.yaml entry
    declares its files) and posts nothing to Studio. It starts empty, so a resumed run logs its checkpoint's
    rows again and its files match those of an uninterrupted run.
    """
    os.environ.setdefault("DVC_STUDIO_OFFLINE", "true")
    os.environ.setdefault("DVCLIVE_LOGLEVEL", "WARNING")  # read when dvclive is imported
    from dvclive import Live

    return Live(str(directory), save_dvc_exp=False, dvcyaml=None, report=None, monitor_system=False)


def log_row(live: Live, row: dict) -> None:
    live.step = row["step"]
    for field, name in CURVES.items():
        if row[field] is not None and math.isfinite(row[field]):  # held-out reconstruction: every eval_every
            live.log_metric(name, float(row[field]))  # no timestamp, so the files are byte-reproducible


def log_evaluation(live: Live, metrics: dict, prefix: str = "evaluation") -> None:
    """Final metrics of the trained model, into the same summary (metrics.json, under `evaluation`; a nested
    group such as the unconstrained decoder's numbers under `evaluation/<group>`)."""
    for key, value in metrics.items():
        if isinstance(value, dict):
            log_evaluation(live, value, f"{prefix}/{key}")
        elif isinstance(value, int | float):
            live.log_metric(f"{prefix}/{key}", value, plot=False)


def write_logs(rows: list[dict], live: Live, mcap_path: Path) -> None:
    """At a checkpoint: dvclive's summary of the rows logged so far, and an MCAP log (one `/vae/train` message
    per row) for Foxglove."""
    # dvclive keeps the summary's keys in the order they were first logged: a straight run logs `step` before the
    # first held-out check, a resumed one replays that check first; sorted, both write the same metrics.json
    live.summary["step"] = live.step
    live.summary = dict(sorted(live.summary.items()))
    live.make_summary()
    with McapWriter(mcap_path) as log:
        for row in rows:
            log.scalars("/vae/train", float(row["step"]),
                        {k: v for k, v in row.items() if k != "step" and v is not None and not math.isnan(v)})


def train(model_config: VAEConfig, config: TrainConfig, designs: Designs, checkpoint: Path, live: Live,
          mcap_path: Path, extra: Designs | None = None, progress: str | None = None,
          named: bool = False) -> tuple[GraphVAE, Designs, Designs]:
    """Train (resuming from `checkpoint` when it holds a run of the same settings), logging to `live` (a fresh
    `training_log`); returns the model and the (train, held-out) designs. `extra` designs join the training
    split (any that are held out are dropped). `progress`: a label, then a tqdm bar of the steps (on stderr). `named`:
    `checkpoint` holds a committed measurement, so a file of another run there is an InputError, never overwritten."""
    torch.set_num_threads(config.threads)
    train_idx, test_idx = split(len(designs.ids), config.holdout, config.seed)
    train_set, test_set = designs.subset(train_idx), designs.subset(test_idx)
    if extra is not None:
        held_out = set(test_set.ids)
        train_set = train_set.join(extra.subset(np.array([i for i, d in enumerate(extra.ids) if d not in held_out],
                                                         dtype=np.int64)))
    eval_set = test_set.subset(np.arange(min(config.eval_designs, len(test_idx))))
    torch.manual_seed(config.seed)
    model = GraphVAE(model_config)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr, fused=True)  # one kernel, not one loop per tensor
    key = run_key(model_config, config, designs, train_set)
    start, rows = 0, []
    saved = load_checkpoint(checkpoint, key, named=named)  # None unless it holds this run (damaged: moved aside)
    if saved is not None and saved["step"] > config.steps:
        print(f"{checkpoint} is at step {saved['step']}, past this run's {config.steps} steps: starting afresh",
              flush=True)
        saved = None
    if saved is not None:
        model.load_state_dict(saved["model"])
        optimizer.load_state_dict(saved["optimizer"])
        start, rows = saved["step"], saved["rows"]
        print(f"resuming from {checkpoint} at step {start}", flush=True)
        for row in rows:
            log_row(live, row)

    from tqdm import tqdm

    running: dict[str, float] = {}
    bar = tqdm(total=config.steps, initial=start, disable=progress is None, desc=progress, mininterval=5.0)
    for step in range(start, config.steps):
        model.train()
        idx = batch_indices(step, len(train_set.ids), config.batch_size, config.seed)
        batch = collate([train_set.replays[i] for i in idx], train_set.contacts[idx])
        noise = torch.randn(len(idx), model_config.latent, generator=torch.Generator().manual_seed(
            config.seed * 1_000_003 + step))
        beta, lr = beta_at(step, config), lr_at(step, config)
        for group in optimizer.param_groups:
            group["lr"] = lr
        out = model(batch, beta, config.pred_weight, noise)
        optimizer.zero_grad()
        out["loss"].backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), config.clip_norm)
        optimizer.step()
        for k, v in out.items():
            running[k] = running.get(k, 0.0) + float(v.detach())
        done = step + 1
        if done % config.log_every == 0 or done == config.steps:
            n = done - rows[-1]["step"] if rows else done
            row = {k: running.get(k, math.nan) / n for k in LOG_FIELDS[1:8]}
            row.update(step=done, beta=beta, lr=lr, heldout_reconstruction=math.nan)
            if done % config.eval_every == 0 or done == config.steps:
                model.eval()
                row["heldout_reconstruction"] = reconstruction_accuracy(model, eval_set)
            rows.append(row)
            log_row(live, row)
            running = {}
            bar.set_postfix(loss=f"{row['loss']:.2f}", rec=f"{row['heldout_reconstruction']:.2f}")
        if done % config.checkpoint_every == 0 or done == config.steps:
            save_checkpoint(checkpoint, key, {"step": done, "model": model.state_dict(),
                                              "optimizer": optimizer.state_dict(), "rows": rows})
            write_logs(rows, live, mcap_path)
        bar.update(1)
    bar.close()
    if start >= config.steps:  # already finished: make sure the logs exist
        write_logs(rows, live, mcap_path)
    return model.eval(), train_set, test_set
