"""DVC stage `vae_metrics`: the three variants' metrics in one file, reports/metrics/vae.json."""

from robocompose.io import atomic_write_json, read_json
from robocompose.latent.params import VARIANTS
from robocompose.stage import run_stage


def main() -> None:
    atomic_write_json("reports/metrics/vae.json", {
        name: read_json(f"reports/metrics/vae_{name}.json") for name in VARIANTS})


if __name__ == "__main__":
    run_stage(main)
