"""The learners of Part II by world and name: learned methods that answer a task in real time with designs.

`LEARNERS[world][name]`. A learner is read from its model file (`load(path, problem)`) and answers through
`answer(model, samples)`, in its world's way: a modular learner gives an `Answer`, (problem, task, query seed,
k) -> k candidate designs, best first; a teams learner gives its `Draws`, (problem, task, query seed) -> the
designs it drew, whose front the teams world measures with the ergodic optimiser (`teams.eggan_problem.
query_front`). A learned baseline also says how it trains on a problem under the problem's budget of real
evaluations (`training`); EG-GAN itself trains with `robocompose.eggan.train` (Algorithm 1, checkpointed), each
world choosing its evolution (a modular EG-GAN variant names its own: `evolution`). Every learner works on an
`EgganProblem` (DQN on a `SequentialProblem`): a new learner is its own file (trainer, file writer and reader)
plus one line under its world in `LEARNERS`. The entry is the only list of it: its title (which the stages write
into their artifacts for the report), its settings' dataclass (checked when a profile is written), its place in
the tables (registry order) and in the training queue (`cost`) all live there.

Importing the registry imports no learner's own module: an entry names its loader, trainer, writer and settings as
`"package.module:name"` (`Ref`), and the module is imported on first use (`importlib`, which the import closure
does not follow), so a stage's import closure, and the code deps dvc.yaml derives from it, holds only the learners
it imports itself (the teams generator does not depend on DQN's code). A module that runs a world's learners
through the registry imports their modules itself (`robocompose.modular.experiments.generative`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch

from robocompose.eggan.problem import Design, EgganProblem, Task
from robocompose.eggan.query import generate, load_generator, save_generator, top_distinct

Answer = Callable[[EgganProblem, Task, int, int], list[Design]]  # (problem, task, query seed, k) -> designs
Draws = Callable[[EgganProblem, Task, int], list[Design]]  # (problem, task, query seed) -> the designs drawn
Ref = str  # "package.module:name": a definition of a learner's own module, imported on first use


def import_ref(ref: Any) -> Any:
    """The definition a `Ref` names (importing its module now, on first use); any other value as it is."""
    if not isinstance(ref, str):
        return ref
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


class _Resolved:
    """A frozen dataclass whose `LAZY` fields may hold a `Ref`: reading such a field gives the definition it names."""

    LAZY: tuple[str, ...] = ()

    def __getattribute__(self, name: str) -> Any:
        value = object.__getattribute__(self, name)
        return import_ref(value) if name in type(self).LAZY else value


def generator_answer(generator: torch.nn.Module, samples: int) -> Answer:
    """A generator's answer: the most probable distinct designs among `samples` draws (more draws if too few)."""

    def answer(problem: EgganProblem, task: Task, query_seed: int, k: int) -> list[Design]:
        return [r.design for r in top_distinct(generator, problem, task, k, samples, query_seed)]

    return answer


def generator_draws(generator: torch.nn.Module, samples: int) -> Draws:
    """A generator's draws: one design for each of `samples` noise vectors (continuous designs, unranked)."""

    def draws(problem: EgganProblem, task: Task, query_seed: int) -> list[Design]:
        return generate(generator, problem, task, samples, seed=query_seed)[0].designs

    return draws


def dqn_answer(net: torch.nn.Module, samples: int) -> Answer:
    """Whitman's DQN's answer: its greedy design, then the designs a best-first search on its Q reaches next
    (`robocompose.eggan.dqn.best_designs`); the same for every query of a task (no draws: `samples` unused)."""

    best_designs = import_ref("robocompose.eggan.dqn:best_designs")

    def answer(problem: EgganProblem, task: Task, query_seed: int, k: int) -> list[Design]:
        return [design for design, _ in best_designs(net, problem, task, k)]

    return answer


@dataclass(frozen=True)
class Training(_Resolved):
    """How a learned baseline trains: its settings' dataclass, its trainer, its file writer (each the definition or
    its `Ref`), its own metrics."""

    LAZY = ("settings", "train", "save")
    settings: type | Ref
    train: Callable | Ref  # (problem, network, settings, progress[, select=]) -> (model, log rows); `select`
    #                        (selection.py) only if settings have validate_every
    save: Callable | Ref  # (model, problem, path, meta) -> path
    metrics: Callable[[Any, list[dict]], dict]  # (settings, log rows) -> metrics beside the common ones


@dataclass(frozen=True)
class Learner(_Resolved):
    LAZY = ("load", "answer")
    title: str  # the thesis's name of the method
    load: Callable | Ref  # (path, problem) -> (model, info)
    answer: Callable[[Any, int], Answer | Draws] | Ref  # (model, samples per draw) -> its answer in its world's way
    training: Training | None = None  # None: trained by robocompose.eggan.train (EG-GAN)
    evolution: str | None = None  # an EG-GAN variant's evolution method (its world's `evolution_methods`)
    cost: int = 1  # relative training time: a stage that trains learners side by side starts the costliest first


LEARNERS: dict[str, dict[str, Learner]] = {
    # In the order of the thesis's Table 5.1 (its random sampling row stands between the baselines and EG-GAN).
    # Costs rank the training times on the default profile, slowest highest (MolGAN; Fit2form fastest).
    "modular": {
        "fit2form": Learner("Fit2form", load_generator, generator_answer,
                            Training("robocompose.eggan.fit2form:Fit2formConfig",
                                     "robocompose.eggan.fit2form:train_fit2form", save_generator,
                                     lambda settings, rows: {}), cost=1),
        "dqn": Learner("DQN", "robocompose.eggan.dqn:load_dqn", dqn_answer,
                       Training("robocompose.eggan.dqn:DQNConfig", "robocompose.eggan.dqn:train_dqn",
                                "robocompose.eggan.dqn:save_dqn",
                                lambda settings, rows: {"episodes": rows[-1]["episodes"]}), cost=2),
        "molgan": Learner("MolGAN", load_generator, generator_answer,
                          Training("robocompose.eggan.molgan:MolganConfig", "robocompose.eggan.molgan:train_molgan",
                                   save_generator, lambda settings, rows: {"lam": settings.lam}), cost=5),
        "ga": Learner("EG-GAN", load_generator, generator_answer, evolution="ga", cost=4),
        "crowding": Learner("EG-GAN-crowding", load_generator, generator_answer, evolution="crowding", cost=3),
    },
    "teams": {  # Tables 5.4 and 5.5 (NSGA-II and the random allocations are not learned: teams/baselines.py)
        "eggan": Learner("EG-GAN", load_generator, generator_draws),
    },
}


def baselines(world: str) -> dict[str, Learner]:
    """The learned baselines of `world` (its learners that train themselves), in registry order."""
    return {name: learner for name, learner in LEARNERS[world].items() if learner.training is not None}


def variants(world: str) -> dict[str, Learner]:
    """The EG-GAN variants of `world` (its learners trained by `robocompose.eggan.train` with their own evolution
    method), in registry order."""
    return {name: learner for name, learner in LEARNERS[world].items() if learner.evolution is not None}


def training_order(world: str) -> tuple[str, ...]:
    """Every learner of `world` that a stage trains (the variants and the baselines), costliest first (registry
    order among equals), so that workers started in this order finish close together."""
    trained = {**variants(world), **baselines(world)}
    return tuple(sorted(trained, key=lambda name: -trained[name].cost))


def ref_modules(world: str) -> tuple[str, ...]:
    """The learners' own modules that `world`'s entries name (`Ref`s), sorted: what a module running them all
    through the registry imports itself, so that its import closure holds them."""
    refs = [getattr(entry, "__dict__", {}).get(field) for learner in LEARNERS[world].values()
            for entry, fields in ((learner, Learner.LAZY), (learner.training, Training.LAZY)) for field in fields]
    return tuple(sorted({ref.partition(":")[0] for ref in refs if isinstance(ref, str)}))
