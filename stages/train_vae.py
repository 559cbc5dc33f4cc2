"""DVC stage `train_vae`: params + design tables -> every VAE variant of `train_vae.variants` (full, nopred, nogram),
trained side by side on the compute workers (robocompose.latent.variants): models/vae_VARIANT.pt, its training log
(dvclive, in reports/training/vae_VARIANT/: curves for `dvc plots`, metrics.json with the final metrics; MCAP for
Foxglove, models/vae_VARIANT.mcap). A killed run resumes each variant from models/checkpoints/vae_VARIANT/."""

from pathlib import Path

from robocompose.fanout.compute import ComputeConfig
from robocompose.io.errors import check_field
from robocompose.io.timings import record, timed
from robocompose.latent.params import VARIANTS, TrainVaeParams
from robocompose.latent.variants import train_variants
from robocompose.params import PARAMS_FILE, load_section
from robocompose.stage import run_stage


def main() -> None:
    params = load_section(TrainVaeParams, "train_vae")
    check_field(sorted(params.variants) == sorted(VARIANTS), f"{PARAMS_FILE}: train_vae.variants",
                f"the variants dvc.yaml declares outputs for: {', '.join(VARIANTS)}", sorted(params.variants))
    compute = load_section(ComputeConfig, "compute")
    with timed("train_vae"), compute.executor() as executor:
        for name, figures in train_variants(params, Path("."), executor):
            record(f"train_vae@{name}", figures)  # each variant's own wall time, for the report's VAE table


if __name__ == "__main__":
    run_stage(main)
