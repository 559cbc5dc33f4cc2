"""What a GLSO search method implements, and what it exchanges with the run (`runs.py`).

A method is a class registered in `registry.METHODS` with the dataclass of its settings (a section of
params.yaml's `glso:`). The run makes it, then asks and tells once per objective call:

    method = Method(settings, seed, budget, env)    # fresh; every random stream from `seed`
    proposal = method.propose(env)                  # one complete design to evaluate
    method.tell(proposal, score)                    # its score (an invalid design's score included)

Its state is the object itself, and it must follow from the seed and what it was told: the run's checkpoint
keeps only the step rows, and a killed run resumes by making the method afresh and replaying them (each
recorded step proposed again and told its recorded score). So a method draws every random number from
generators it keeps as attributes, seeded by `seed` (never a global RNG, the clock or an unseeded source),
and holds no reference to `env` (the task and the VAE are not its state).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from robocompose.grammar.tree import DesignTree


@dataclass
class Proposal:
    """One design a method wants evaluated. `rules` is its grammar derivation (None if the grammar cannot
    make it), `z` its latent point (latent methods), `info` what the method needs back when told,
    `rejected` the designs it drew and discarded before this one without evaluating them (its pre-filters:
    incomplete at the depth limit, self-penetrating, failing the dataset's filters), counted, not paid."""

    tree: DesignTree
    rules: tuple[int, ...] | None
    z: np.ndarray | None = None
    info: Any = field(default=None, repr=False)
    rejected: int = 0


@dataclass
class SearchEnv:
    """What a method reads but does not own (not part of its state): the task and the VAE (latent methods)."""

    task: str
    model: Any = None


class SearchMethod(Protocol):
    """A search method of the GLSO comparison (see the module docstring)."""

    def __init__(self, settings: Any, seed: int, budget: int, env: SearchEnv) -> None:
        """A fresh search: `settings` its params section, `budget` the run's objective calls."""

    def propose(self, env: SearchEnv) -> Proposal:
        """The next design to spend one objective call on."""
        ...

    def tell(self, proposal: Proposal, score: float) -> None:
        """The objective of the design `propose` returned last (higher is better)."""
