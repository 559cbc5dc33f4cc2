"""`robocompose teams ...`: NSGA-II and the coverage cost of one allocation on one terrain chip.

Heavy modules (torch, pymoo) are imported inside the handlers so `robocompose --help` stays fast.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `teams` command (sub-commands `nsga2` and `coverage`) to the robocompose CLI."""
    teams = subparsers.add_parser("teams", help="multi-robot team formation on terrain chips (thesis 5.2)")
    commands = teams.add_subparsers(dest="teams_command", required=True)

    nsga2 = commands.add_parser("nsga2", help="NSGA-II allocations for one chip; prints hypervolume, "
                                "seconds and the front as JSON")
    _add_chip_arguments(nsga2)
    nsga2.add_argument("--pop", type=int, default=50, help="population size (thesis: 20 or 50)")
    nsga2.add_argument("--generations", type=int, default=50, help="generations (thesis: 50)")
    nsga2.add_argument("--seed", type=int, default=0, help="seed of NSGA-II and of the robots' starts")
    nsga2.add_argument("--address", default="",
                       help="a running Dask scheduler (tcp://host:8786) to run on instead of this process")
    nsga2.set_defaults(handler=_nsga2)

    coverage = commands.add_parser("coverage", help="coverage and deployment cost of one allocation")
    _add_chip_arguments(coverage)
    coverage.add_argument("--allocation", required=True,
                          help="K rows 'f_ground,f_aerial,f_aquatic' separated by ';': the fraction of "
                          "each species' robots sent to each region")
    coverage.add_argument("--seed", type=int, default=0, help="seed of the robots' starts")
    coverage.set_defaults(handler=_coverage)


def _add_chip_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--chip", type=Path, help="a DroneDeploy label PNG (its first 300 x 300 chip)")
    source.add_argument("--synthetic-seed", type=int, help="use synthetic chip 0 of this generator seed")
    parser.add_argument("--regions", type=int, default=8, help="regions K (terrain-driven decomposition)")


def _chip(args: argparse.Namespace):
    """The chip named by --chip / --synthetic-seed and its --regions decomposition."""
    import torch

    from robocompose.teams.chips import chips_in_file, synthetic_chip
    from robocompose.teams.decompose import DecomposeConfig, decompose_chip

    torch.set_num_threads(1)
    if args.chip is not None:
        if not args.chip.is_file():
            raise SystemExit(f"--chip {args.chip}: no such file (expected a label PNG)")
        chip = next(chips_in_file(args.chip), None)
        if chip is None:
            raise SystemExit(f"--chip {args.chip}: no 300 x 300 window without IGNORE pixels")
    else:
        chip = synthetic_chip(args.synthetic_seed)
    return chip, decompose_chip(chip, DecomposeConfig(n_regions=args.regions))


def _setup(args: argparse.Namespace):
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage

    chip, decomposition = _chip(args)
    coverage = chip_coverage(chip, decomposition, CoverageConfig())
    return AllocationEvaluator(coverage, chip.chip_id, args.seed)


def _nsga2(args: argparse.Namespace) -> None:
    from robocompose.evaluation.executor import Executor
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.experiments import _nsga2_run
    from robocompose.teams.nsga2 import NSGA2Config

    chip, decomposition = _chip(args)
    config = NSGA2Config(population=args.pop, generations=args.generations, seed=args.seed)
    # The run is one executor task (the experiments stage's own), here or on a Dask worker: same result.
    with Executor(workers=1, address=args.address or None) as executor:
        result, _ = executor.map(_nsga2_run, [(chip, decomposition, CoverageConfig(), config, 1)])[0]
    print(json.dumps({"hypervolume": result.hypervolume, "seconds": result.seconds,
                      "front": [[float(c), int(d)] for c, d in result.front]}))


def _coverage(args: argparse.Namespace) -> None:
    from robocompose.teams.species import allocation_to_counts, parse_allocation

    evaluate = _setup(args)
    try:
        fractions = parse_allocation(args.allocation)
        if len(fractions) != args.regions:
            raise ValueError(f"--allocation has {len(fractions)} rows, expected one per region "
                             f"(--regions {args.regions})")
        counts = allocation_to_counts(fractions, evaluate.coverage.config.robots_per_species)
    except ValueError as err:
        raise SystemExit(str(err)) from None
    coverage_cost, deployment_cost = evaluate(counts[None])[0]
    print(json.dumps({"coverage_cost": float(coverage_cost), "deployment_cost": int(deployment_cost),
                      "counts": counts.tolist()}))
