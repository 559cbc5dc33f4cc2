"""Model selection on validation for the learned baselines (Fit2form, DQN, MolGAN): EG-GAN's early stopping rule.

EG-GAN keeps the generator of its best validation score (`train.best_by`); a baseline that reports its final
model instead would be compared under another selection rule. With a `ModelSelection`, a baseline's trainer hands
every logged row to `after`: every `every` iterations and at its last row the model is scored on the validation
terrains (`validate`, never trained on), the scores join the row, and the weights of the best `score` so far (ties
keep the earlier) are kept; `restore` loads them at the end. The draws of training come from generators seeded by
(seed, iteration), so validating between iterations leaves the run's training bytes as they were.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import torch

from robocompose.io.errors import InputError


@dataclass
class ModelSelection:
    validate: Callable[[torch.nn.Module], dict]  # model -> validation scores (maximised)
    every: int  # iterations between validations (a multiple of the trainer's 10-iteration log rows)
    score: str  # the score that selects, e.g. "val_max_distance" (EG-GAN's `train.best_by`)
    best: dict | None = field(default=None, init=False)  # {"iteration", "score", "state"}

    def __post_init__(self) -> None:
        if not isinstance(self.every, int) or self.every < 10 or self.every % 10:
            raise InputError(f"validate_every: expected a positive multiple of 10 (the log rows), found {self.every!r}")

    def after(self, row: dict, model: torch.nn.Module, final: bool) -> None:
        """Validate at a due row (or the `final` one): its scores and the best iteration so far join `row`."""
        if row["iteration"] % self.every and not final:
            return
        row.update(self.validate(model))
        if self.score not in row:
            raise InputError(f"best_by: expected one of the validation scores "
                             f"{sorted(k for k in row if k.startswith('val_'))}, found {self.score!r}")
        if self.best is None or row[self.score] > self.best["score"]:
            self.best = {"iteration": int(row["iteration"]), "score": float(row[self.score]),
                         "state": {k: v.detach().clone() for k, v in model.state_dict().items()}}
        row["best_iteration"] = self.best["iteration"]

    def restore(self, model: torch.nn.Module) -> int | None:
        """Load the best validated weights into `model`; their iteration (None: nothing was validated)."""
        if self.best is None:
            return None
        model.load_state_dict(self.best["state"])
        return self.best["iteration"]
