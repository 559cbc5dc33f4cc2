"""What every GLSO search method shares: a proposal, the pybullet checks of a design, random grammar designs.

A method proposes one complete design at a time (`Proposal`); the run (`runs.py`) spends one objective
call on it and tells the method its score. Which designs a method may propose follows its original:
- grammar methods (random search, MCTS, GHS) redraw a derivation that is incomplete at the depth limit or
  self-penetrates when placed (RoboGrammar's `get_result` is None: no evaluation is spent on it);
- random search also applies the dataset's filters (>= 11 links, valid rest contacts);
- the graph GA rejects a child that self-penetrates before evaluating it;
- GLSO evaluates whatever the decoder gives; a design that cannot be simulated costs a call and scores
  `INVALID_SCORE` (the evaluator's status says why).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robocompose.grammar.derivation import MAX_DEPTH, random_derivation
from robocompose.grammar.tree import DesignTree

MIN_LINKS = 11  # the dataset keeps designs with at least 11 links (thesis 7.1)
MAX_TRIES = 1000  # redraws before a method gives up on finding a valid design (RoboGrammar's max_tries)


@dataclass
class Proposal:
    """One design a method wants evaluated. `rules` is its grammar derivation (None if the grammar cannot
    make it), `z` its latent point (latent methods), `info` what the method needs back when told."""

    tree: DesignTree
    rules: tuple[int, ...] | None
    z: np.ndarray | None = None
    info: Any = field(default=None, repr=False)


_CLIENT: int | None = None


def _client() -> int:
    """One headless pybullet client per process, made on first use (every check resets it)."""
    global _CLIENT
    if _CLIENT is None:
        from robocompose.sim.physics import connect

        _CLIENT = connect()
    return _CLIENT


def rejection(tree: DesignTree, dataset_filters: bool) -> str:
    """Why a design may not be proposed ("" = it may): "self_collision" when it self-penetrates at rest;
    with `dataset_filters` also the dataset's reasons ("too_few_links", "too_few_contacts", ...)."""
    from robocompose.sim.contacts import contact_features

    if dataset_filters and tree.n_links < MIN_LINKS:
        return "too_few_links"
    contacts = contact_features(tree, _client(), rest_self_penetrating=False)
    if contacts.reason == "self_collision" or (dataset_filters and not contacts.valid):
        return contacts.reason
    return ""


def random_grammar_design(rng: np.random.Generator, max_depth: int = MAX_DEPTH) -> Proposal:
    """A uniformly random derivation that passes the dataset's filters (as `enumerate` draws them)."""
    for _ in range(MAX_TRIES):
        derivation = random_derivation(rng, max_depth)
        if derivation is not None and not rejection(derivation.tree, dataset_filters=True):
            return Proposal(derivation.tree, derivation.rules)
    raise RuntimeError(f"no valid random derivation in {MAX_TRIES} tries")
