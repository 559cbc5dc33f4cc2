"""What the GLSO search methods share: the pybullet checks of a design, random grammar designs.

A method proposes one complete design at a time (`method.Proposal`); the run (`runs.py`) spends one objective
call on it and tells the method its score. Which designs a method may propose follows its original:
- grammar methods (random search, MCTS, GHS) redraw a derivation that is incomplete at the depth limit or
  self-penetrates when placed (RoboGrammar's `get_result` is None: no evaluation is spent on it);
- random search (and the GA's first generation) draws with the dataset's enumeration and filters (>= 11
  links, valid rest contacts);
- the graph GA rejects a child that self-penetrates before evaluating it;
- GLSO evaluates whatever the decoder gives; a design that cannot be simulated costs a call and scores
  GLSO's `INVALID_SCORE` (the evaluator's status says why).
Every design a method discards before evaluation is counted in its proposal's `rejected` (the step table's
`rejected` column): a pre-filter costs no call, but what it saved is on the record.
"""

from __future__ import annotations

from robocompose.glso.method import Proposal
from robocompose.grammar.derivation import MAX_DEPTH
from robocompose.grammar.tree import DesignTree

MAX_TRIES = 1000  # redraws before a method gives up on finding a valid design (RoboGrammar's max_tries)


def self_colliding(tree: DesignTree) -> bool:
    """Whether the design self-penetrates when placed at rest (it cannot be simulated): the static capsule test
    of robocompose.sim.self_collision, which agrees with pybullet's check on 10,000 enumeration candidates."""
    from robocompose.sim.builder import SELF_PENETRATION_TOLERANCE
    from robocompose.sim.self_collision import capsule_self_penetrating

    return capsule_self_penetrating(tree.canonical_order(), SELF_PENETRATION_TOLERANCE)


def run_stream(seed: int, method: str) -> int:
    """An enumeration seed of a method's run seed, far from the dataset's own (`enumerate.seed`, 0)."""
    return 10_000 * (1 + seed) + sum(ord(c) for c in method)


def random_grammar_design(seed: int, k: int, max_depth: int = MAX_DEPTH) -> tuple[Proposal, int]:
    """The first candidate from k on of the dataset's enumeration stream `seed` that passes its filters
    (depth limit, >= 11 links, no self-penetration, valid rest contacts; the candidates before it are its
    `rejected`), and the next k to draw from."""
    from robocompose.dataset.enumerate import MIN_LINKS, candidate

    for j in range(k, k + MAX_TRIES):
        reason, row, _ = candidate(seed, j, MIN_LINKS, max_depth)
        if not reason:
            return Proposal(DesignTree(tuple(row["parents"]), tuple(row["tokens"])), tuple(row["rules"]),
                            rejected=j - k), j + 1
    raise RuntimeError(f"no valid random derivation in {MAX_TRIES} candidates")
