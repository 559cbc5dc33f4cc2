"""DVC stage `vae_metrics`: the three variants' metrics in one file, reports/metrics/vae.json."""

import json
from pathlib import Path

from robocompose.io import atomic_write_json
from robocompose.latent.params import VARIANTS
from robocompose.stage import run_stage


def main() -> None:
    atomic_write_json("reports/metrics/vae.json", {
        name: json.loads(Path(f"reports/metrics/vae_{name}.json").read_text()) for name in VARIANTS})


if __name__ == "__main__":
    run_stage(main)
