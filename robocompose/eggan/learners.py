"""The learners of Part II by name: learned methods that answer a task in real time with candidate designs.

A learner is read from its model file (`load(path, problem)`) and answers through `answer(model, samples)`:
a function (problem, task, query seed, k) -> k candidate designs, best first. A learned baseline also says
how it trains on a problem under the problem's budget of real evaluations (`training`); EG-GAN itself trains
with `robocompose.eggan.train` (Algorithm 1, checkpointed), each world choosing its evolution. Every learner
works on an `EgganProblem` (DQN on a `SequentialProblem`), so both worlds take theirs from here: a new learner
is its own file (trainer, file writer and reader) plus one line in `LEARNERS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch

from robocompose.eggan.dqn import DQNConfig, best_designs, load_dqn, save_dqn, train_dqn
from robocompose.eggan.fit2form import Fit2formConfig, train_fit2form
from robocompose.eggan.molgan import MolganConfig, train_molgan
from robocompose.eggan.problem import Design, EgganProblem, Task
from robocompose.eggan.query import generate, load_generator, rank_distinct, save_generator

Answer = Callable[[EgganProblem, Task, int, int], list[Design]]  # (problem, task, query seed, k) -> designs


def generator_answer(generator: torch.nn.Module, samples: int) -> Answer:
    """A generator's answer: the most probable distinct designs among `samples` draws (more draws if too few)."""

    def answer(problem: EgganProblem, task: Task, query_seed: int, k: int) -> list[Design]:
        tensor = problem.encode_task(task)
        ranked = []
        for chunk in range(16):  # a sharp generator may need more than one batch for k distinct designs
            sampled, output = generate(generator, problem, task, samples * (chunk + 1), seed=query_seed,
                                       task_tensor=tensor)
            ranked = rank_distinct(problem, sampled, output, k)
            if len(ranked) == k:
                break
        return [r.design for r in ranked]

    return answer


def dqn_answer(net: torch.nn.Module, samples: int) -> Answer:
    """Whitman's DQN's answer: its greedy design, then the designs a best-first search on its Q reaches next
    (`robocompose.eggan.dqn.best_designs`); the same for every query of a task (no draws: `samples` unused)."""

    def answer(problem: EgganProblem, task: Task, query_seed: int, k: int) -> list[Design]:
        return [design for design, _ in best_designs(net, problem, task, k)]

    return answer


@dataclass(frozen=True)
class Training:
    """How a learned baseline trains: its settings' dataclass, its trainer, its file writer, its own metrics."""

    settings: type
    train: Callable  # (problem, network, settings, progress) -> (model, log rows)
    save: Callable  # (model, problem, path, meta) -> path
    metrics: Callable[[Any, list[dict]], dict]  # (settings, log rows) -> metrics beside the common ones


@dataclass(frozen=True)
class Learner:
    title: str  # the thesis's name of the method
    load: Callable  # (path, problem) -> (model, info)
    answer: Callable[[Any, int], Answer]  # (model, samples per draw) -> its answer
    training: Training | None = None  # None: trained by robocompose.eggan.train (EG-GAN)


LEARNERS: dict[str, Learner] = {  # the baselines in the order of the thesis's Table 5.1
    "eggan": Learner("EG-GAN", load_generator, generator_answer),
    "fit2form": Learner("Fit2form", load_generator, generator_answer,
                        Training(Fit2formConfig, train_fit2form, save_generator, lambda settings, rows: {})),
    "dqn": Learner("DQN", load_dqn, dqn_answer,
                   Training(DQNConfig, train_dqn, save_dqn, lambda settings, rows: {"episodes": rows[-1]["episodes"]})),
    "molgan": Learner("MolGAN", load_generator, generator_answer,
                      Training(MolganConfig, train_molgan, save_generator,
                               lambda settings, rows: {"lam": settings.lam})),
}


def baselines() -> dict[str, Learner]:
    """The learned baselines (the learners that train themselves), in registry order."""
    return {name: learner for name, learner in LEARNERS.items() if learner.training is not None}
