"""The `train_vae` stage's work: every VAE variant of `train_vae.variants`, trained side by side.

Variant NAME reads its design tables (`data`, `extra`) and writes, under the project folder `root`:
models/vae_NAME.pt, its MCAP log models/vae_NAME.mcap, its dvclive log reports/training/vae_NAME/ (curves for
`dvc plots`, metrics.json with the final metrics) and its checkpoint models/checkpoints/vae_NAME/last.pt (no DVC out,
so a killed run resumes every variant from its own).

Each variant trains from start to end in one worker of the executor, alone there, so its bytes are those of a run
of its own: every random choice is a function of (seed, step), and `train` sets torch's threads to `train.threads`
in whichever process runs it (the executor's local workers come from a fork server and inherit no thread setting).
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import partial
from pathlib import Path

import torch

from robocompose.fanout.executor import Executor
from robocompose.io.timings import Timing
from robocompose.latent.metrics import vae_metrics
from robocompose.latent.params import TrainVaeParams
from robocompose.latent.train import load_designs, log_evaluation, save_model, train, training_log


def train_variant(name: str, params: TrainVaeParams, root: Path) -> dict:
    """Train variant `name` of `params` and write its files under `root`. Returns its timing figures: steps per
    second, the torch threads it trained with, and the seconds of training, saving and final metrics."""
    variant, model_config, train_config, metrics_config = params.variant(name)
    designs = load_designs(root / variant.data, model_config.constraints, model_config.max_nodes)
    extra = (load_designs(root / variant.extra, model_config.constraints, model_config.max_nodes)
             if variant.extra else None)
    timing = Timing()
    with training_log(root / f"reports/training/vae_{name}") as live:
        model, train_set, test_set = train(
            model_config, train_config, designs, root / f"models/checkpoints/vae_{name}/last.pt", live,
            root / f"models/vae_{name}.mcap", extra, progress=f"train_vae {name}")
        timing["steps_per_s"] = round(train_config.steps / timing.elapsed(), 2)
        timing["threads"] = torch.get_num_threads()  # what `train` set in this process
        save_model(model, root / f"models/vae_{name}.pt")
        log_evaluation(live, vae_metrics(model, train_set, test_set, metrics_config.prior_samples,
                                         metrics_config.seed))
    return timing.figures()


def train_variants(params: TrainVaeParams, root: Path, executor: Executor) -> Iterator[tuple[str, dict]]:
    """Train every variant of `params` (`train_variant`), one per worker of `executor`; yields (name, timing
    figures) of each as it finishes.

    They start in params order. The profiles list the two grammar variants first, the longer trainings (default
    profile: 303 and 353 s against `nogram`'s 246 s), so on two workers `nogram` takes the worker that frees up
    first and the stage ends when longest first would."""
    names = list(params.variants)
    for index, figures in executor.as_completed(partial(train_variant, params=params, root=root), names):
        yield names[index], figures
