"""A learned fitness model f(design, task) trained on real evaluations (the issue's allowed surrogate).

The group's public allocation code trained its GAN against a reward network; here a problem may answer its
evaluations from this model where it has no real result, and it must report the model's error on held-out
real evaluations. Structure: a height map is averaged over 2 x 2 cells and read by the networks' task encoder
with `filters` filters (two 3x3 convolutions + FC; a cheaper encoder than the generator's, since a fit runs
hundreds of steps), concatenated with the flattened design tensor, an MLP of `layers` x `hidden` ReLU units,
one output. The targets are standardised; fitting is full-data mini-batch Adam for a fixed number of steps from a seeded
stream, so the same data and seed give the same model.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from robocompose.eggan.networks import NetworkConfig, TaskEncoder


@dataclass(frozen=True)
class SurrogateConfig:
    hidden: int = 128  # width of each hidden layer
    layers: int = 3
    latent: int = 32  # the task code's size (the conv encoder's FC output)
    filters: int = 8  # filters of each 3x3 convolution (height maps only)
    steps: int = 400  # Adam steps per fit
    batch: int = 128
    lr: float = 3e-3
    weight_decay: float = 1e-4

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not value > 0:
                raise ValueError(f"surrogate.{name}: expected a positive value, found {value!r}")


class SurrogateNet(nn.Module):
    def __init__(self, task_shape: tuple[int, ...], design_shape: tuple[int, ...], config: SurrogateConfig):
        super().__init__()
        self.pool = len(task_shape) == 2
        shape = tuple(n // 2 for n in task_shape) if self.pool else task_shape
        self.task = TaskEncoder(shape, NetworkConfig(latent=config.latent, filters=config.filters))
        layers: list[nn.Module] = []
        width = self.task.code_size + math.prod(design_shape)
        for _ in range(config.layers):
            layers += [nn.Linear(width, config.hidden), nn.ReLU()]
            width = config.hidden
        self.body = nn.Sequential(*layers, nn.Linear(width, 1))

    def encode(self, tasks: torch.Tensor) -> torch.Tensor:
        """(U, *task_shape) -> (U, code)."""
        if self.pool:
            tasks = nn.functional.avg_pool2d(tasks.unsqueeze(1), 2).squeeze(1)
        return self.task(tasks)

    def forward(self, codes: torch.Tensor, design: torch.Tensor) -> torch.Tensor:
        """task codes (B, code), designs (B, *design_shape) -> (B,) standardised fitness."""
        return self.body(torch.cat([codes, design.flatten(1)], dim=1)).squeeze(1)


class Surrogate:
    """Fit on (task, design, value) triples; predict values for new pairs.

    Tasks are given once each, `tasks` (U, *task_shape), and rows point into them with `task_index` (N,): many
    rows share a task, and its encoding is computed once per step.
    """

    def __init__(self, task_shape: tuple[int, ...], design_shape: tuple[int, ...], config: SurrogateConfig,
                 seed: int = 0):
        self.task_shape, self.design_shape = tuple(task_shape), tuple(design_shape)
        self.config, self.seed = config, seed
        self.net: SurrogateNet | None = None
        self.mean, self.scale = 0.0, 1.0
        self.fits = 0

    def fit(self, tasks: torch.Tensor, task_index: torch.Tensor, designs: torch.Tensor, values: np.ndarray) -> None:
        """Train a fresh model on all data: tasks (U, *task_shape), task_index (N,), designs (N, ...), values (N,)."""
        if len(values) < 2:
            raise ValueError(f"surrogate: need at least 2 real evaluations to fit, have {len(values)}")
        torch.manual_seed(self.seed * 7919 + self.fits)
        net = SurrogateNet(self.task_shape, self.design_shape, self.config)
        values = np.asarray(values, dtype=np.float64)
        self.mean, self.scale = float(values.mean()), float(values.std() or 1.0)
        target = torch.as_tensor((values - self.mean) / self.scale, dtype=torch.float32)
        optimiser = torch.optim.Adam(net.parameters(), lr=self.config.lr, weight_decay=self.config.weight_decay)
        stream = torch.Generator().manual_seed(self.seed * 104729 + self.fits)
        for _ in range(self.config.steps):
            idx = torch.randint(len(target), (min(self.config.batch, len(target)),), generator=stream)
            codes = net.encode(tasks)[task_index[idx]]  # (batch, code)
            loss = torch.mean((net(codes, designs[idx]) - target[idx]) ** 2)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
        self.net = net.eval()
        self.fits += 1

    @torch.no_grad()
    def predict(self, tasks: torch.Tensor, task_index: torch.Tensor, designs: torch.Tensor) -> np.ndarray:
        """(B,) predicted values for tasks (U, *task_shape), task_index (B,), designs (B, *design_shape)."""
        if self.net is None:
            raise ValueError("surrogate: predict before the first fit")
        codes = self.net.encode(tasks)[task_index]
        return self.net(codes, designs).double().numpy() * self.scale + self.mean

    def state_dict(self) -> dict:
        return {"net": None if self.net is None else self.net.state_dict(), "mean": self.mean, "scale": self.scale,
                "fits": self.fits}

    def load_state_dict(self, state: dict) -> None:
        self.mean, self.scale, self.fits = state["mean"], state["scale"], state["fits"]
        self.net = None
        if state["net"] is not None:
            self.net = SurrogateNet(self.task_shape, self.design_shape, self.config)
            self.net.load_state_dict(state["net"])
            self.net.eval()


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman rank correlation (average ranks for ties)."""
    import pandas as pd

    return float(pd.Series(np.asarray(a)).rank().corr(pd.Series(np.asarray(b)).rank()))
