"""EG-GAN's generator and discriminator (thesis 4.1, 4.2 and the network sizes of 5.1 / 5.2).

Task encoder: a 2-D task (a terrain height map H x W) goes through two 3x3 convolutions of 32 filters
(ReLU), is flattened and mapped by one fully connected layer to P numbers (thesis 5.1); a task of any other
shape is flattened and used as it is (thesis 5.2: an MLP on (z, task)).

Generator G(z, task): [task code, z ~ N(0, I_P)] -> MLP of 3 hidden layers of 64 (layer norm + ReLU each)
-> prod(design_shape) logits -> the problem's design head (e.g. a row softmax over 6 ports x 4 modules).
Discriminator D(x, task): the same structure on [task code, design tensor] -> one logit; D = sigmoid(logit).

Normalisation (`norm`). The thesis says batch normalisation ("batch"); the default is layer normalisation
("layer"), which normalises each row over its own hidden units. Batch norm subtracts the batch mean of every
unit: a batch holds several tasks (one task per batch would remove the task's contribution altogether), so one
task's rows shift another's, and at query time the running means of training answer instead. Layer norm (and
"none") keep every row a function of its own (z, task) only, in training and in a query alike
(tests/eggan/test_networks.py checks it). On the toy problem of tests/eggan batch norm learns fastest; what
each choice does on the modular pool is measured in docs/eggan.md.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import torch
from torch import nn

from robocompose.io.errors import InputError

NORMS = {"layer": nn.LayerNorm, "batch": nn.BatchNorm1d, "none": lambda width: nn.Identity()}


@dataclass(frozen=True)
class NetworkConfig:
    """Sizes of both networks."""

    latent: int = 32  # P: the size of z and of the terrain code (thesis: P, value not given)
    hidden: int = 64  # width of the 3 hidden layers (thesis 64)
    layers: int = 3  # hidden layers (thesis 3)
    filters: int = 32  # filters of each 3x3 convolution (thesis 32)
    norm: str = "layer"  # hidden-layer normalisation: "layer" (ours), "batch" (the thesis's; mixes tasks), "none"

    def __post_init__(self):
        for name, value in asdict(self).items():
            if name != "norm" and (not isinstance(value, int) or value < 1):
                raise InputError(f"network.{name}: expected a positive integer, found {value!r}")
        if self.norm not in NORMS:
            raise InputError(f"network.norm: expected one of {sorted(NORMS)}, found {self.norm!r}")


class TaskEncoder(nn.Module):
    """(B, *task_shape) -> (B, code_size): convolutions + FC for a 2-D task, flattening otherwise."""

    def __init__(self, task_shape: tuple[int, ...], config: NetworkConfig):
        super().__init__()
        self.image = len(task_shape) == 2
        if self.image:
            h, w = task_shape
            if h < 5 or w < 5:
                raise InputError(f"task_shape {task_shape}: a height map needs at least 5 x 5 cells")
            self.convs = nn.Sequential(nn.Conv2d(1, config.filters, 3), nn.ReLU(),
                                       nn.Conv2d(config.filters, config.filters, 3), nn.ReLU(), nn.Flatten())
            self.fc = nn.Linear(config.filters * (h - 4) * (w - 4), config.latent)
            self.norm = nn.LayerNorm(config.latent, elementwise_affine=False)
            self.code_size = config.latent
        else:
            self.code_size = math.prod(task_shape)

    def forward(self, task: torch.Tensor) -> torch.Tensor:
        if self.image:
            return self.norm(self.fc(self.convs(task.unsqueeze(1))))  # (B, 1, H, W) -> (B, P)
        return task.flatten(1)  # (B, prod task_shape)


def mlp(inputs: int, outputs: int, config: NetworkConfig) -> nn.Sequential:
    """`layers` hidden layers of `hidden` units with the configured normalisation and ReLU, then a linear output
    layer."""
    modules: list[nn.Module] = []
    width = inputs
    for _ in range(config.layers):
        modules += [nn.Linear(width, config.hidden), NORMS[config.norm](config.hidden), nn.ReLU()]
        width = config.hidden
    modules.append(nn.Linear(width, outputs))
    return nn.Sequential(*modules)


class Generator(nn.Module):
    """G(z, task) -> (B, *design_shape) logits; the problem's `design_head` makes them the output X~."""

    def __init__(self, task_shape: tuple[int, ...], design_shape: tuple[int, ...], config: NetworkConfig):
        super().__init__()
        self.config, self.design_shape = config, tuple(design_shape)
        self.task = TaskEncoder(tuple(task_shape), config)
        self.body = mlp(self.task.code_size + config.latent, math.prod(design_shape), config)

    def encode(self, task: torch.Tensor) -> torch.Tensor:
        """(B, *task_shape) -> (B, code): computed once per query and repeated for many z."""
        return self.task(task)

    def forward(self, z: torch.Tensor, task_code: torch.Tensor) -> torch.Tensor:
        """z (B, P), task code (B, code) -> logits (B, *design_shape)."""
        return self.body(torch.cat([task_code, z], dim=1)).view(len(z), *self.design_shape)


class Discriminator(nn.Module):
    """D(x, task) -> (B,) logits, D = sigmoid(logit): "this design came from the evolution" (label 1)."""

    def __init__(self, task_shape: tuple[int, ...], design_shape: tuple[int, ...], config: NetworkConfig):
        super().__init__()
        self.task = TaskEncoder(tuple(task_shape), config)
        self.body = mlp(self.task.code_size + math.prod(design_shape), 1, config)

    def encode(self, task: torch.Tensor) -> torch.Tensor:
        """(B, *task_shape) -> (B, code)."""
        return self.task(task)

    def forward(self, design: torch.Tensor, task_code: torch.Tensor) -> torch.Tensor:
        """design (B, *design_shape), task code (B, code) -> (B,) logits."""
        return self.body(torch.cat([task_code, design.flatten(1)], dim=1)).squeeze(1)
