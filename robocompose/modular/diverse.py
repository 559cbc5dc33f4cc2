"""The diverse query (issue 46): a generator's candidates pairwise at Hamming distance >= `min_hamming`.

A query ranks the distinct designs it draws by the generator's probability (`robocompose.eggan.query`), so its k
most probable designs are often one-port variants of each other. `spread` walks the ranking in probability order
and takes a design only if it differs in at least `min_hamming` ports from every design already taken;
`diverse_distinct` draws as `top_distinct` does (samples, then twice as many up to `MAX_DOUBLINGS` times, while
fewer than k are taken) and answers the spread designs. If even the last draws leave fewer than k designs that
far apart, it answers the fewer it has (as `top_distinct` does for distinct designs): the caller sees the count
(`compose modular`'s `found`, the protocol's `candidates` column), never a design made up to fill the list.
`min_hamming` 1 is the plain query (distinct designs).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from robocompose.io.errors import check_field
from robocompose.modular.robot import N_PORTS

if TYPE_CHECKING:
    import torch

    from robocompose.eggan.networks import Generator
    from robocompose.eggan.problem import EgganProblem  # the world does not import its plugins (test_layout)
    from robocompose.eggan.query import Ranked


def check_min_hamming(value: object, field: str) -> int:
    """`value` as a Hamming distance a query can ask its candidates to keep (1 .. the ports); else an InputError
    naming `field`."""
    check_field(isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= N_PORTS, field,
                f"an integer from 1 (distinct designs) to {N_PORTS} (the ports)", value)
    return int(value)


def _far(a: str, b: str, min_hamming: int) -> bool:
    return sum(x != y for x, y in zip(a, b, strict=True)) >= min_hamming


def spread(designs: Iterable[str], k: int, min_hamming: int) -> list[str]:
    """At most `k` of `designs`, in their order, each at Hamming distance >= `min_hamming` from every one taken
    before it (greedy: a design within `min_hamming` - 1 ports of one taken is skipped)."""
    taken: list[str] = []
    for design in designs:
        if len(taken) == k:
            break
        if all(_far(design, other, min_hamming) for other in taken):
            taken.append(design)
    return taken


def diverse_distinct(generator: Generator, problem: EgganProblem, task: int | None, k: int, samples: int,
                     min_hamming: int, seed: int = 0, task_tensor: torch.Tensor | None = None,
                     keep: Callable[[str], bool] | None = None) -> list[Ranked]:
    """The `spread` of the generator's distinct designs for `task` that `keep` accepts, ranked by probability among
    `samples` draws, or among twice as many (up to `MAX_DOUBLINGS` times) while fewer than `k` are far enough
    apart; fewer than `k` if even that fails (see the module docstring)."""
    from robocompose.eggan.query import MAX_DOUBLINGS, generate, rank_distinct

    check_min_hamming(min_hamming, "min_hamming")
    tensor = problem.encode_task(task) if task_tensor is None else task_tensor
    if generator.training:
        generator.eval()
    code = generator.encode(tensor.unsqueeze(0))  # the task encoded once for every doubling
    picked: list[Ranked] = []
    for doubling in range(MAX_DOUBLINGS + 1):
        sampled, output = generate(generator, problem, task, samples << doubling, seed, code=code)
        ranked = [r for r in rank_distinct(problem, sampled, output, len(sampled.designs))
                  if keep is None or keep(r.design)]
        by_design = {r.design: r for r in ranked}
        picked = [by_design[d] for d in spread((r.design for r in ranked), k, min_hamming)]
        if len(picked) == k:
            break
    return picked


def diverse_answer(generator: Generator, samples: int, min_hamming: int):
    """A Table 5.1 proposer (problem, terrain seed, query seed, candidates -> designs) of the diverse query."""
    check_min_hamming(min_hamming, "min_hamming")

    def answer(problem: EgganProblem, terrain_seed: int, query_seed: int, candidates: int) -> list[str]:
        return [r.design for r in diverse_distinct(generator, problem, terrain_seed, candidates, samples,
                                                   min_hamming, query_seed)]

    return answer
