"""Real-time composition with a trained generator: one task in, many designs out (thesis 5.1, "0.003 min").

`generate` runs the generator once on a batch of n noise vectors for one task (the task is encoded once) and
draws one design per z. `rank_distinct` (discrete problems) ranks the distinct designs drawn by their
probability under the generator's mixture over the n z, (1/n) sum_z P_theta(x | z, T), highest first: the
ranking needs no simulation.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from robocompose.eggan.networks import Generator
from robocompose.eggan.problem import Design, EgganProblem, Sampled, Task
from robocompose.io.errors import InputError


@torch.no_grad()
def generate(generator: Generator, problem: EgganProblem, task: Task, n: int, seed: int = 0,
             task_tensor: torch.Tensor | None = None) -> tuple[Sampled, torch.Tensor]:
    """n designs for `task` (or for a given task tensor) and the generator's (n, *design_shape) output."""
    if n < 1:
        raise InputError(f"samples: expected a positive number of designs, found {n}")
    generator.eval()
    stream = torch.Generator().manual_seed(int(seed))
    tensor = problem.encode_task(task) if task_tensor is None else task_tensor
    code = generator.encode(tensor.unsqueeze(0)).expand(n, -1)  # (n, code)
    z = torch.randn(n, generator.config.latent, generator=stream)  # (n, P)
    output = problem.design_head(generator(z, code))  # (n, *design_shape)
    return problem.sample_designs(output, stream), output


@dataclass(frozen=True)
class Ranked:
    design: Design
    score: float  # the generator's mixture probability of the design for the task


@torch.no_grad()
def rank_distinct(problem: EgganProblem, sampled: Sampled, output: torch.Tensor, k: int) -> list[Ranked]:
    """The k most probable distinct designs among those drawn (one-hot design tensors over the last axis)."""
    distinct: dict[str, Design] = {}
    for design in sampled.designs:
        distinct.setdefault(problem.design_id(design), design)
    designs = list(distinct.values())
    one_hot = problem.design_tensor(designs)  # (D, *design_shape)
    log_output = output.clamp_min(1e-12).log()  # (n, *design_shape)
    # log P(x_d | z_i) = sum over rows of log output[i, row, choice of x_d]
    log_p = torch.einsum("d...,i...->di", one_hot, log_output)  # (D, n)
    scores = log_p.exp().mean(dim=1)  # (D,)
    order = sorted(range(len(designs)), key=lambda i: (-float(scores[i]), problem.design_id(designs[i])))
    return [Ranked(designs[i], float(scores[i])) for i in order[:k]]
