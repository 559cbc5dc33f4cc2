"""Real-time composition with a trained generator: one task in, many designs out (thesis 5.1, "0.003 min").

`generate` runs the generator once on a batch of n noise vectors for one task (the task is encoded once) and
draws one design per z. `rank_distinct` (discrete problems) ranks the distinct designs drawn by their
probability under the generator's mixture over the n z, (1/n) sum_z P_theta(x | z, T), highest first: the
ranking needs no simulation. `top_distinct` answers a query: the k most probable distinct designs, drawing
twice as many designs while fewer than k are found (a sharp generator repeats its favourites).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import torch

from robocompose.eggan.networks import Generator
from robocompose.eggan.problem import Design, EgganProblem, Sampled, Task
from robocompose.eggan.storage import load_model, save_model
from robocompose.io.errors import InputError


@torch.no_grad()
def generate(generator: Generator, problem: EgganProblem, task: Task, n: int, seed: int = 0,
             task_tensor: torch.Tensor | None = None, code: torch.Tensor | None = None) -> tuple[Sampled, torch.Tensor]:
    """n designs for `task` (or for a given task tensor, or its (1, code) encoding) and the generator's
    (n, *design_shape) output."""
    if n < 1:
        raise InputError(f"samples: expected a positive number of designs, found {n}")
    if generator.training:  # (walking every module costs ~0.4 ms: only when training left it in train mode)
        generator.eval()
    stream = torch.Generator().manual_seed(int(seed))
    if code is None:
        tensor = problem.encode_task(task) if task_tensor is None else task_tensor
        code = generator.encode(tensor.unsqueeze(0))  # (1, code)
    z = torch.randn(n, generator.config.latent, generator=stream)  # (n, P)
    output = problem.design_head(generator(z, code.expand(n, -1)))  # (n, *design_shape)
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


MAX_DOUBLINGS = 4  # draws tried: samples, 2x, 4x, 8x, 16x samples, before answering with fewer than k designs


@torch.no_grad()
def top_distinct(generator: Generator, problem: EgganProblem, task: Task, k: int, samples: int, seed: int = 0,
                 task_tensor: torch.Tensor | None = None,
                 keep: Callable[[Design], bool] | None = None) -> list[Ranked]:
    """The k most probable distinct designs for `task` that `keep` accepts, among `samples` draws, or among twice
    as many draws (up to `MAX_DOUBLINGS` times) while fewer than k are found; fewer than k if even that fails."""
    tensor = problem.encode_task(task) if task_tensor is None else task_tensor
    if generator.training:
        generator.eval()
    code = generator.encode(tensor.unsqueeze(0))  # (1, code): the task encoded once for every doubling
    ranked: list[Ranked] = []
    for doubling in range(MAX_DOUBLINGS + 1):
        sampled, output = generate(generator, problem, task, samples << doubling, seed, code=code)
        ranked = [r for r in rank_distinct(problem, sampled, output, len(sampled.designs))
                  if keep is None or keep(r.design)][:k]
        if len(ranked) == k:
            break
    return ranked


# --- the generator as a file: weights, sizes and provenance (the shipped default generator is one) ---

MODEL_CODE = ("robocompose.eggan.networks",)  # the modules a saved generator's weights are meaningful for
KIND = "an EG-GAN generator"  # what a generator file is, for the errors of a file of another kind


def model_code_digest() -> str:
    """Digest of the network code a generator file must match to be loaded (storage and errors excluded: a
    change to how results are kept must not orphan a trained generator)."""
    from robocompose.io.provenance import INFRASTRUCTURE, code_digest

    return code_digest(*MODEL_CODE, exclude=INFRASTRUCTURE)


def save_generator(generator: Generator, problem: EgganProblem, path: str | Path, meta: dict,
                   half: bool = False) -> Path:
    """Write the generator's weights and sizes to `path` (torch) and `meta` + provenance beside it (`.json`).

    `half` stores floating-point weights as float16 (half the file; the shipped generator), loaded as float32.
    """
    info = {"problem": problem.name, "task_shape": list(problem.task_shape),
            "design_shape": list(problem.design_shape), "network": asdict(generator.config),
            "model_code": model_code_digest(), "weights": "float16" if half else "float32", **meta}
    state = {k: v.half() if half and v.is_floating_point() else v.clone() for k, v in generator.state_dict().items()}
    return save_model(info, state, path)


def generator_info(path: str | Path) -> dict:
    """The info of a generator file (its problem, sizes, provenance and meta) without building the generator:
    what a world reads first when the file fixes the problem's sizes (the teams world's K)."""
    return load_model(path, KIND)[0]


def load_generator(path: str | Path, problem: EgganProblem) -> tuple[Generator, dict]:
    """A saved generator for `problem`, in eval mode, and its info; a clear error if it does not fit."""
    from robocompose.eggan.networks import NetworkConfig

    info, state = load_model(path, KIND)
    if info["problem"] != problem.name or tuple(info["design_shape"]) != tuple(problem.design_shape) or tuple(
            info["task_shape"]) != tuple(problem.task_shape):
        raise InputError(f"{path}: a generator for {info['problem']} {info['task_shape']} -> {info['design_shape']}, "
                         f"not for {problem.name} {list(problem.task_shape)} -> {list(problem.design_shape)}")
    generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig(**info["network"]))
    generator.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in state.items()})
    return generator.eval(), info
