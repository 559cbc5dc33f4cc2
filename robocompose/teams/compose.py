"""`robocompose compose teams`: the front of a trained EG-GAN generator for a label chip, in real time.

    robocompose compose teams --chip LABELS.png [--regions K] [--budget 30] [--model PATH]

Prints the front (allocations with both objectives, measured by the ergodic optimiser, and its hypervolume) or,
with `--budget`, the best allocation within it whose coverage cost lies inside the hypervolume box (or
`"allocation": null` and the reason), as JSON. The pick is made at the robots' start seed `--seed` and its
coverage cost reported as the mean (and sd) over the REPORT_SEEDS seeds after it, which it was not picked on;
its cost at `--seed` stays beside it as `selection_cost`. With no `--model`, the generator shipped in the
repository (trained by the default profile) is used.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocompose.arguments import input_file, non_negative_int, positive_int
from robocompose.io.errors import InputError

if TYPE_CHECKING:
    from robocompose.teams.chips import Chip
    from robocompose.teams.decompose import DecomposeConfig
    from robocompose.teams.ergodic import CoverageConfig

SHIPPED_MODEL = Path(__file__).resolve().parent / "pretrained" / "generator.pt"  # the default profile's, shipped
REPORT_SEEDS = 3  # robot-start seeds a picked allocation's cost is reported on (those after the selection seed)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `compose teams` to the `compose` command."""
    compose = subparsers.add_parser(
        "teams", help="allocations for a label chip from the trained EG-GAN generator: the front (or the best "
        "allocation within --budget) as JSON, every cost measured by the ergodic optimiser")
    compose.add_argument("--chip", type=input_file("a DroneDeploy label PNG"), required=True,
                         help="a DroneDeploy-format label PNG (its first 300 x 300 chip without IGNORE pixels)")
    compose.add_argument("--regions", type=positive_int, default=None, help="regions K (default and only choice: the "
                         "generator's K)")
    compose.add_argument("--budget", type=int, default=None,
                         help="deployment budget (robots, 1..60): print the front's best allocation within it, "
                         f"picked at --seed and its cost reported over the {REPORT_SEEDS} seeds after it")
    compose.add_argument("--model", type=input_file("a teams generator (.pt)"), default=None,
                         help=f"a generator file of the teams_eggan stage (default: the shipped {SHIPPED_MODEL.name})")
    compose.add_argument("--seed", type=non_negative_int, default=0, help="seed of the noise and of the robots' starts")
    compose.set_defaults(handler=_compose)

    ship = subparsers.add_parser("ship-teams", help="copy a trained teams generator to the shipped default")
    ship.add_argument("--from", dest="source", type=Path, default=Path("models/teams_eggan.pt"),
                      help="generator of `dvc repro teams_eggan` (default: models/teams_eggan.pt)")
    ship.set_defaults(handler=_ship)


def _ship(args: argparse.Namespace) -> None:
    import shutil

    from robocompose.io import atomic_write_json
    from robocompose.teams.generative import teams_generator_info

    info = teams_generator_info(args.source)  # checked: a checksum, a teams generator, the current design head
    shutil.copyfile(args.source, SHIPPED_MODEL)
    atomic_write_json(SHIPPED_MODEL.with_suffix(".json"), info)  # the info beside it, as save_generator writes it
    print(json.dumps({"shipped": str(SHIPPED_MODEL), "from": str(args.source), "bytes": SHIPPED_MODEL.stat().st_size}))


@dataclass
class TeamsComposer:
    """A trained teams generator kept warm: `query` is what `compose teams` prints and what the service
    (robocompose.serve) answers, one function for both."""

    path: Path
    info: dict  # the generator file's info: K, the settings it was trained with, metrics, provenance
    generator: Any
    coverage: CoverageConfig
    decompose: DecomposeConfig

    @classmethod
    def load(cls, path: Path | None) -> TeamsComposer:
        """The generator at `path` (default: the shipped one), with the decomposition and coverage settings it was
        trained with."""
        from robocompose.eggan.learners import LEARNERS
        from robocompose.teams.chips import synthetic_chip
        from robocompose.teams.decompose import DecomposeConfig, decompose_chip
        from robocompose.teams.eggan_problem import TeamsProblem
        from robocompose.teams.ergodic import CoverageConfig
        from robocompose.teams.generative import teams_generator_info

        path = Path(path or SHIPPED_MODEL)
        saved = teams_generator_info(path)
        coverage = CoverageConfig(**saved["params"]["coverage"])
        decompose = DecomposeConfig(**{**saved["params"]["decompose"], "n_regions": saved["n_regions"]})
        chip = synthetic_chip(0)  # any chip: the network's sizes are K x 4 -> K + 1 x species, K fixed by the file
        generator, _ = LEARNERS["teams"]["eggan"].load(
            path, TeamsProblem([(chip, decompose_chip(chip, decompose))], coverage))
        coverage.settings_hash()  # the code digest, parsed once now: ast.parse in concurrent threads is not safe
        return cls(path, saved, generator, coverage, decompose)

    @property
    def bank(self) -> int:
        """Robots of the bank: the largest deployment budget."""
        return self.coverage.robots_per_species * 3

    def query(self, chip: Chip, budget: int | None = None, seed: int = 0, measure: bool = True) -> dict:
        """The chip's decomposition and the generator's answer for it: with `measure`, the front (both objectives
        measured by the ergodic optimiser, robots' starts seeded by `seed`) or, with `budget`, its best allocation
        within the budget; without, the distinct allocations drawn (within `budget`, if given), costs not measured."""
        import numpy as np

        from robocompose.eggan.learners import LEARNERS
        from robocompose.teams.decompose import decompose_chip
        from robocompose.teams.eggan_problem import TeamsProblem
        from robocompose.teams.generative import draw_allocations, query_front
        from robocompose.teams.species import deployment_cost

        if budget is not None and not 1 <= budget <= self.bank:
            raise InputError(f"budget: {budget}: expected a number of robots in 1..{self.bank} (the bank)")
        started = time.perf_counter()
        decomposition = decompose_chip(chip, self.decompose)
        decomposition_ms = 1000 * (time.perf_counter() - started)
        problem = TeamsProblem([(chip, decomposition)], self.coverage)  # the task: the chip's K x 4 features
        draws = LEARNERS["teams"]["eggan"].answer(self.generator, self.info["params"]["eggan"]["samples"])
        out = {"chip": chip.chip_id, "regions": decomposition.n_regions,
               "centres": np.round(decomposition.centres[:, :2], 6).tolist(),
               "shares": np.round(problem.features[0], 6).tolist(), "measured": measure}
        if measure:
            query = query_front(draws, chip, decomposition, self.coverage, seed, problem=problem)
            front = [{"deployment_cost": int(deploy), "coverage_cost": float(cost), "counts": counts.tolist()}
                     for (cost, deploy), counts in zip(query.front, query.counts, strict=True)]
            out.update({"hypervolume": query.hypervolume, "distinct": query.distinct, "front": front})
            generator_seconds = query.generator_seconds
            if budget is not None:
                out.update({"budget": budget, **best_within(front, budget)})
                if out["allocation"] is not None:
                    out["allocation"] = self.reported(out["allocation"], chip, decomposition, seed)
        else:
            distinct, generator_seconds = draw_allocations(draws, problem, seed)
            costs = deployment_cost(distinct)
            order = np.argsort(costs, kind="stable")
            allocations = [{"deployment_cost": int(costs[i]), "counts": distinct[i].tolist()} for i in order
                           if budget is None or costs[i] <= budget]
            out.update({"distinct": len(distinct), "allocations": allocations, "budget": budget})
        return {**out, "generator_ms": round(1000 * generator_seconds, 3),
                "decomposition_ms": round(decomposition_ms, 1)}


    def reported(self, pick: dict, chip: Chip, decomposition, seed: int) -> dict:
        """A front point picked at robot-start seed `seed`, reported at the mean of its costs at the REPORT_SEEDS
        seeds after it (a pick is, on average, luckier at the seed it was picked on: teams/heldout.py)."""
        import numpy as np

        from robocompose.teams.heldout import allocation_costs

        seeds = [seed + offset for offset in range(1, REPORT_SEEDS + 1)]
        costs = allocation_costs(chip, decomposition, self.coverage, np.asarray([pick["counts"]]), seeds)[0]
        return {**pick, "coverage_cost": float(costs.mean()), "coverage_cost_sd": float(costs.std(ddof=1)),
                "report_seeds": seeds, "selection_cost": pick["coverage_cost"], "selection_seed": seed}


def _compose(args: argparse.Namespace) -> None:
    import torch

    from robocompose.teams.cli import first_chip

    torch.set_num_threads(1)
    composer = TeamsComposer.load(args.model)
    k = composer.decompose.n_regions
    if args.regions is not None and args.regions != k:
        raise InputError(f"--regions {args.regions}: the generator was trained for K = {k} regions (its task "
                         f"is the K x 4 feature matrix); use --regions {k} or another --model")
    if args.budget is not None and not 1 <= args.budget <= composer.bank:
        raise InputError(f"--budget {args.budget}: expected a number of robots in 1..{composer.bank} (the bank)")
    answer = composer.query(first_chip(args.chip), args.budget, args.seed)
    drawn = ("centres", "shares", "measured", "distinct") + (("front",) if args.budget is not None else ())
    print(json.dumps({k: v for k, v in answer.items() if k not in drawn}))  # the page draws those, the command not


def best_within(front: list[dict], budget: int) -> dict:
    """{"allocation": the front's lowest-coverage-cost allocation deploying <= `budget` robots whose cost lies
    inside the hypervolume box (an allocation outside it covers worse than the box's worst), or None and the
    reason}."""
    from robocompose.teams.nsga2 import REFERENCE_POINT

    worst = REFERENCE_POINT[0]
    inside = [point for point in front if point["coverage_cost"] < worst]
    within = [point for point in inside if point["deployment_cost"] <= budget]
    if within:
        return {"allocation": min(within, key=lambda point: point["coverage_cost"])}
    fewest = f"the fewest robots inside it: {inside[0]['deployment_cost']}" if inside else "no front point is inside it"
    return {"allocation": None, "reason": f"no allocation of the front deploys <= {budget} robots at a coverage "
                                          f"cost inside the box (< {worst}); {fewest}"}
