"""Fit2form baseline (Ha, Agrawal, Song 2020; thesis Table 5.1), for discrete designs: a generator trained to
maximise the fitness its designs get, by policy gradient (the thesis's change, since a modular design is not
differentiable).

The generator is EG-GAN's (same networks, same task encoder, z ~ N(0, I)), so the two differ only in how they
are trained. Every iteration: draw `tasks` tasks and `samples` noise vectors per task, one design per z, ask the
problem for their fitness (the same problem EG-GAN trains on: its learned fitness model and its budget of real
rollouts), and take one REINFORCE step on -mean(A log P_theta(x | z, T)) with the advantage A the fitness
standardised within each task's group (a baseline that removes the task's difficulty).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.eggan.problem import BudgetSpent, EgganProblem, check_problem
from robocompose.eggan.selection import ModelSelection
from robocompose.eggan.train import iteration_streams


@dataclass(frozen=True)
class Fit2formConfig:
    iterations: int = 300
    tasks: int = 8  # tasks per iteration
    samples: int = 8  # noise vectors (designs) per task
    lr: float = 1e-3  # Adam (Fit2form: 1e-4 over 500 epochs of 512 designs; raised for the short default)
    seed: int = 0
    threads: int = 1  # torch threads (results are bit-identical at a fixed thread count)
    validate_every: int = 0  # iterations between validations that select the model kept (selection.py; 0: the last)

    def __post_init__(self):
        for name in ("iterations", "tasks", "samples", "threads"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise ValueError(f"fit2form.{name}: expected a positive integer, found {getattr(self, name)!r}")
        if not isinstance(self.validate_every, int) or self.validate_every < 0 or self.validate_every % 10:
            raise ValueError(f"fit2form.validate_every: expected 0 or a multiple of 10, found {self.validate_every!r}")
        if self.samples < 2:
            raise ValueError("fit2form.samples: expected >= 2 (the advantage is standardised within a task)")


def train_fit2form(problem: EgganProblem, network: NetworkConfig, config: Fit2formConfig, progress: bool = False,
                   select: ModelSelection | None = None) -> tuple[Generator, list[dict]]:
    """Train the policy-gradient generator until `iterations` or the problem's budget is spent; returns it (eval
    mode; with `select`, the best validated one) and one log row per 10 iterations."""
    from tqdm import tqdm

    check_problem(problem)
    if not problem.discrete or len(problem.objectives) != 1:
        raise ValueError(f"fit2form: needs a discrete single-objective problem, {problem.name} is not")
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    generator = Generator(problem.task_shape, problem.design_shape, network)
    optimiser = torch.optim.Adam(generator.parameters(), lr=config.lr)
    sign = 1.0 if problem.objectives[0].maximise else -1.0
    k, s = config.tasks, config.samples
    rows, pending, stopped = [], [], False
    for iteration in tqdm(range(config.iterations), disable=not progress, desc="fit2form", mininterval=5.0):
        rng, stream = iteration_streams(config.seed, iteration)
        tasks = [problem.sample_task(rng) for _ in range(k)]
        codes = generator.encode(torch.stack([problem.encode_task(t) for t in tasks])).repeat_interleave(s, dim=0)
        generator.train()
        output = problem.design_head(generator(torch.randn(k * s, network.latent, generator=stream), codes))
        drawn = problem.sample_designs(output, stream)
        try:
            fitness = np.concatenate([np.asarray(problem.evaluate(t, drawn.designs[g * s:(g + 1) * s]))[:, 0]
                                      for g, t in enumerate(tasks)]).reshape(k, s)  # (k, s)
        except BudgetSpent:
            stopped = True
        else:
            advantage = sign * (fitness - fitness.mean(axis=1, keepdims=True)) / (
                fitness.std(axis=1, keepdims=True) + 1e-6)
            loss = -(torch.as_tensor(advantage.ravel(), dtype=torch.float32) * drawn.log_prob).mean()
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            pending.append(float(fitness.mean()))
        done = iteration + 1 - stopped
        if pending and (done % 10 == 0 or done == config.iterations or stopped):
            rows.append({"iteration": done, "fitness_mean": float(np.mean(pending)),
                         "real_evaluations": problem.real_evaluations})
            pending = []
            if select is not None:
                select.after(rows[-1], generator, done == config.iterations or stopped)
        if stopped:
            break
    if select is not None:
        select.restore(generator)
    return generator.eval(), rows
