"""DVC stage `train_vae@VARIANT`: params + designs -> models/vae_VARIANT.pt, its training log (dvclive, in
reports/training/vae_VARIANT/: curves for `dvc plots`, metrics.json with the final metrics; MCAP for Foxglove)."""

import sys
from pathlib import Path

from robocompose.io.errors import InputError
from robocompose.io.timings import timed
from robocompose.latent.metrics import vae_metrics
from robocompose.latent.params import VARIANTS, TrainVaeParams
from robocompose.latent.train import load_designs, log_evaluation, save_model, train, training_log
from robocompose.params import PARAMS_FILE, load_section
from robocompose.stage import run_stage


def main() -> None:
    params = load_section(TrainVaeParams, "train_vae")  # every variant's settings checked, whichever runs
    if len(sys.argv) != 2:
        raise InputError(f"usage: train_vae.py VARIANT (one of {', '.join(VARIANTS)})")
    name = sys.argv[1]
    try:
        variant, model_config, train_config, metrics_config = params.variant(name)
    except InputError as err:  # an unknown variant
        raise InputError(f"{PARAMS_FILE}: train_vae.{err}") from None
    designs = load_designs(variant.data, model_config.constraints, model_config.max_nodes)
    extra = load_designs(variant.extra, model_config.constraints, model_config.max_nodes) if variant.extra else None
    with timed(f"train_vae@{name}") as timing, training_log(f"reports/training/vae_{name}") as live:
        model, train_set, test_set = train(
            model_config, train_config, designs, Path(f"models/checkpoints/vae_{name}/last.pt"), live,
            Path(f"models/vae_{name}.mcap"), extra, progress=True)
        timing["steps_per_s"] = round(train_config.steps / timing.elapsed(), 2)
        save_model(model, f"models/vae_{name}.pt")
        log_evaluation(live, vae_metrics(model, train_set, test_set, metrics_config.prior_samples,
                                         metrics_config.seed))


if __name__ == "__main__":
    run_stage(main)
