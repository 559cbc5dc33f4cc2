"""EG-GAN's generator and discriminator (thesis 4.1, 4.2 and the network sizes of 5.1 / 5.2).

Task encoder of a 2-D task (a terrain height map H x W, the first axis along the course), `encoder`:
- "conv" (thesis 5.1): two 3x3 convolutions of `filters` filters (ReLU), flattened, one fully connected layer to
  P numbers. On the 50 x 20 map its FC layer has ~754k weights fed raw heights: trained on 40 terrains it
  memorises them (issue 46: a terrain's own top-10 list scores no better on it than other terrains' lists).
- "pooled" (ours): the same two convolutions, then a max over each of `segments` stretches of the course (the
  whole width), so the FC layer sees filters x segments numbers (32 x 5 = 160): where along the course a
  filter fires, not at which of 736 cells.
- "features" (ours): no learned filters: per stretch of the course (`segments`) and over the whole map, the
  mean height, the tallest cell and the share of raised cells (a block count in area), 3 x (segments + 1)
  numbers, then a hidden layer of `hidden` units (ReLU) to P: the statistics issue 46 measured to predict
  the rough-versus-flat part of the terrain-design interaction (tallest block, block count).
Every 2-D code ends in a layer norm without parameters (below says why). A task of any other shape is flattened
and used as it is (thesis 5.2: an MLP on (z, task)); `encoder` does not apply to it.

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
import torch.nn.functional as F
from torch import nn

from robocompose.io.errors import InputError

NORMS = {"layer": nn.LayerNorm, "batch": nn.BatchNorm1d, "none": lambda width: nn.Identity()}
ENCODERS = ("conv", "pooled", "features")  # how a 2-D task is read (the module docstring)


@dataclass(frozen=True)
class NetworkConfig:
    """Sizes of both networks."""

    latent: int = 32  # P: the size of z and of the terrain code (thesis: P, value not given)
    hidden: int = 64  # width of the 3 hidden layers (thesis 64)
    layers: int = 3  # hidden layers (thesis 3)
    filters: int = 32  # filters of each 3x3 convolution (thesis 32)
    norm: str = "layer"  # hidden-layer normalisation: "layer" (ours), "batch" (the thesis's; mixes tasks), "none"
    # 2-D task encoder: "conv" (the thesis's: convolutions + FC on every cell), "pooled" (convolutions, max per
    # stretch of the course, small FC), "features" (height statistics per stretch, one hidden layer)
    encoder: str = "conv"
    segments: int = 5  # "pooled" and "features": stretches of the course (the task's first axis) read apart

    def __post_init__(self):
        for name, value in asdict(self).items():
            if name not in ("norm", "encoder") and (not isinstance(value, int) or isinstance(value, bool)
                                                    or value < 1):
                raise InputError(f"network.{name}: expected a positive integer, found {value!r}")
        if self.norm not in NORMS:
            raise InputError(f"network.norm: expected one of {sorted(NORMS)}, found {self.norm!r}")
        if self.encoder not in ENCODERS:
            raise InputError(f"network.encoder: expected one of {list(ENCODERS)}, found {self.encoder!r}")


def height_features(task: torch.Tensor, segments: int) -> torch.Tensor:
    """(B, H, W) height maps -> (B, 3 * (segments + 1)): per stretch of the first axis (`segments` of them,
    adaptive pooling's split), then over the whole map: mean height, tallest cell, share of raised cells."""
    maps = task.unsqueeze(1)  # (B, 1, H, W)
    raised = (maps > 0).float()
    stretches = torch.cat([F.adaptive_avg_pool2d(maps, (segments, 1)), F.adaptive_max_pool2d(maps, (segments, 1)),
                           F.adaptive_avg_pool2d(raised, (segments, 1))], dim=1).flatten(1)  # (B, 3 * segments)
    whole = torch.stack([maps.mean(dim=(1, 2, 3)), maps.amax(dim=(1, 2, 3)), raised.mean(dim=(1, 2, 3))], dim=1)
    return torch.cat([stretches, whole], dim=1)


class TaskEncoder(nn.Module):
    """(B, *task_shape) -> (B, code_size): the configured `encoder` for a 2-D task, flattening otherwise."""

    def __init__(self, task_shape: tuple[int, ...], config: NetworkConfig):
        super().__init__()
        self.image = len(task_shape) == 2
        self.encoder, self.segments = config.encoder, config.segments
        if self.image:
            h, w = task_shape
            if h < 5 or w < 5:
                raise InputError(f"task_shape {task_shape}: a height map needs at least 5 x 5 cells")
            longest = {"conv": h, "pooled": h - 4, "features": h}[config.encoder]  # after the convolutions
            if config.segments > longest:
                raise InputError(f"network.segments: expected at most {longest} stretches of a {h}-cell course "
                                 f"(encoder {config.encoder}), found {config.segments}")
            if config.encoder == "features":
                self.fc = nn.Sequential(nn.Linear(3 * (config.segments + 1), config.hidden), nn.ReLU(),
                                        nn.Linear(config.hidden, config.latent))
            else:
                self.convs = nn.Sequential(nn.Conv2d(1, config.filters, 3), nn.ReLU(),
                                           nn.Conv2d(config.filters, config.filters, 3), nn.ReLU())
                cells = (h - 4) * (w - 4) if config.encoder == "conv" else config.segments
                self.fc = nn.Linear(config.filters * cells, config.latent)
            self.norm = nn.LayerNorm(config.latent, elementwise_affine=False)
            self.code_size = config.latent
        else:
            self.code_size = math.prod(task_shape)

    def forward(self, task: torch.Tensor) -> torch.Tensor:
        if not self.image:
            return task.flatten(1)  # (B, prod task_shape)
        if self.encoder == "features":
            return self.norm(self.fc(height_features(task, self.segments)))  # (B, H, W) -> (B, P)
        maps = self.convs(task.unsqueeze(1))  # (B, filters, H - 4, W - 4)
        if self.encoder == "pooled":
            maps = F.adaptive_max_pool2d(maps, (self.segments, 1))  # (B, filters, segments, 1)
        return self.norm(self.fc(maps.flatten(1)))  # (B, P)


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
