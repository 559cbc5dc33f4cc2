"""The VAE training curves as dvclive logs them (`latent.train.training_log`), and reading them back: no torch,
so the report reads a training log without the model code."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

# log field -> metric name (plots/metrics/<name>.tsv)
CURVES = {"loss": "train/loss", "label_loss": "train/label_loss", "stop_loss": "train/stop_loss", "kl": "train/kl",
          "pred_loss": "train/pred_loss", "label_acc": "train/label_acc", "stop_acc": "train/stop_acc",
          "beta": "train/beta", "lr": "train/lr", "heldout_reconstruction": "heldout/reconstruction"}
LOG_FIELDS = ("step", *CURVES)


def read_curves(directory: str | Path) -> pd.DataFrame:
    """The curves of a `training_log` directory as one table: LOG_FIELDS columns, a row per logged step."""
    frame = pd.DataFrame({"step": pd.Series(dtype="int64")})
    for field, name in CURVES.items():
        path = Path(directory) / "plots" / "metrics" / f"{name}.tsv"
        if path.exists():
            curve = pd.read_csv(path, sep="\t").rename(columns={name.rpartition("/")[2]: field})
            frame = frame.merge(curve, on="step", how="outer")
    return frame.reindex(columns=list(LOG_FIELDS)).sort_values("step", ignore_index=True)
