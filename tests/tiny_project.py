"""A tiny copy of the project for the tests that run `dvc repro` on it (reliability, run cache): its params and
the environment its stages run in."""

import os
import sys
from pathlib import Path

TINY = {  # merged into the default profile: every stage at a few seconds
    "compute": {"workers": 1},
    "enumerate": {"n": 80, "seed": 0, "chunk": 8},
    "nogram": {"n": 12, "seed": 1},
    "evaluation": {"mppi": {"samples": 4, "first_samples": 4, "horizon": 4, "episode": 4}},
    "glso": {"methods": ["random", "ga", "glso"], "seeds": [0], "budget": 6, "bo": {"init": 3},
             "ga": {"population": 4}, "rung": ""},  # the tiny evaluation above, not the default's ladder rung
    "teams": {"chips": {"n_synthetic": 4}, "decompose": {"n_regions": 3},
              "coverage": {"iterations": 3, "n_observations": 5},
              "experiments": {"table_5_4_chips": 1, "table_5_5_chips": 1, "budgets": [5]},
              "eggan": {"iterations": 40, "batch": 16, "samples": 8, "checkpoint_every": 10, "validation_chips": 1}},
    "train_vae": {"model": {"hidden": 16, "latent": 4, "predictor_hidden": 8, "max_nodes": 50},
                  "train": {"steps": 200, "batch_size": 8, "log_every": 10, "eval_every": 50, "eval_designs": 4,
                            "checkpoint_every": 50, "beta_start": 50, "beta_every": 20, "lr_decay_every": 100},
                  "metrics": {"prior_samples": 8}, "extra": {"n": 8}},
}


def dvc_env(project: Path, **extra: str) -> dict:
    """The environment for `dvc` in `project`: its stages import the project's own copy of robocompose."""
    return {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
            "PYTHONPATH": str(project), "DVC_NO_ANALYTICS": "1", "DO_NOT_TRACK": "1", "MPLBACKEND": "Agg", **extra}
