"""`robocompose teams ...` (NSGA-II and the coverage cost of one allocation on one terrain chip) and
`robocompose compose teams` (the front of a trained EG-GAN generator for a chip, in real time).

Heavy modules (torch, pymoo) are imported inside the handlers so `robocompose --help` stays fast.
"""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import input_file, int_at_least, non_negative_int, positive_int
from robocompose.io.errors import InputError

SHIPPED_MODEL = "models/shipped/teams_generator.pt"  # the default profile's generator, in the repository


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `teams` command (sub-commands `nsga2` and `coverage`) to the robocompose CLI."""
    teams = subparsers.add_parser("teams", help="multi-robot team formation on terrain chips (thesis 5.2)")
    commands = teams.add_subparsers(dest="teams_command", required=True)

    nsga2 = commands.add_parser("nsga2", help="NSGA-II allocations for one chip; prints hypervolume, "
                                "seconds and the front as JSON")
    _add_chip_arguments(nsga2)
    nsga2.add_argument("--pop", type=int_at_least(2), default=50, help="population size (thesis: 20 or 50)")
    nsga2.add_argument("--generations", type=positive_int, default=50, help="generations (thesis: 50)")
    nsga2.add_argument("--seed", type=non_negative_int, default=0, help="seed of NSGA-II and of the robots' starts")
    nsga2.add_argument("--address", default="",
                       help="a running Dask scheduler (tcp://host:8786) to run on instead of this process")
    nsga2.set_defaults(handler=_nsga2)

    coverage = commands.add_parser("coverage", help="coverage and deployment cost of one allocation")
    _add_chip_arguments(coverage)
    coverage.add_argument("--allocation", required=True,
                          help="K rows 'f_ground,f_aerial,f_aquatic' separated by ';': the fraction of "
                          "each species' robots sent to each region")
    coverage.add_argument("--seed", type=non_negative_int, default=0, help="seed of the robots' starts")
    coverage.set_defaults(handler=_coverage)

    compose = _compose_targets(subparsers).add_parser(
        "teams", help="allocations for a label chip from the trained EG-GAN generator: the front (or the best "
        "allocation within --budget) as JSON, every cost measured by the ergodic optimiser")
    compose.add_argument("--chip", type=input_file("a DroneDeploy label PNG"), required=True,
                         help="a DroneDeploy-format label PNG (its first 300 x 300 chip without IGNORE pixels)")
    compose.add_argument("--regions", type=positive_int, default=None, help="regions K (default and only choice: the "
                         "generator's K)")
    compose.add_argument("--budget", type=positive_int, default=None,
                         help="deployment budget (robots, 1..60): print the front's best allocation within it")
    compose.add_argument("--model", type=input_file("a teams generator (.pt)"), default=None,
                         help=f"a generator file of the teams_eggan stage (default: the shipped {SHIPPED_MODEL})")
    compose.add_argument("--seed", type=non_negative_int, default=0, help="seed of the noise and of the robots' starts")
    compose.set_defaults(handler=_compose)


def _compose_targets(subparsers: argparse._SubParsersAction) -> argparse._SubParsersAction:
    """The sub-commands of `robocompose compose` (created by the first world that registers one)."""
    compose = subparsers.choices.get("compose")
    if compose is None:
        compose = subparsers.add_parser("compose", help="real-time composition with a trained generator")
        compose.set_defaults(targets=compose.add_subparsers(dest="compose_target", required=True))
    return compose.get_default("targets")


def _add_chip_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--chip", type=input_file("a DroneDeploy label PNG"),
                        help="a DroneDeploy label PNG (its first 300 x 300 chip)")
    source.add_argument("--synthetic-seed", type=non_negative_int, help="use synthetic chip 0 of this generator seed")
    parser.add_argument("--regions", type=positive_int, default=8,
                        help="regions K (terrain-driven decomposition; at most 64)")


def _chip(args: argparse.Namespace):
    """The chip named by --chip / --synthetic-seed and its --regions decomposition."""
    import torch

    from robocompose.teams.chips import synthetic_chip
    from robocompose.teams.decompose import MAX_REGIONS, DecomposeConfig, decompose_chip

    if args.regions > MAX_REGIONS:
        raise InputError(f"--regions: expected an integer in 1..{MAX_REGIONS}, found {args.regions}")
    torch.set_num_threads(1)
    if args.chip is not None:
        chip = _first_chip(args.chip)
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

    fractions = parse_allocation(args.allocation)
    if len(fractions) != args.regions:
        raise InputError(f"--allocation has {len(fractions)} rows, expected one per region (--regions {args.regions})")
    evaluate = _setup(args)
    counts = allocation_to_counts(fractions, evaluate.coverage.config.robots_per_species)
    coverage_cost, deployment_cost = evaluate(counts[None])[0]
    print(json.dumps({"coverage_cost": float(coverage_cost), "deployment_cost": int(deployment_cost),
                      "counts": counts.tolist()}))


def _first_chip(path):
    """The first 300 x 300 chip of a label PNG; the project's input error naming --chip if there is none."""
    from robocompose.teams.chips import chips_in_file

    if not path.is_file():
        raise InputError(f"--chip {path}: no such file (expected a DroneDeploy-format label PNG)")
    chip = next(chips_in_file(path), None)  # an unreadable image: chips_in_file names the file
    if chip is None:
        raise InputError(f"--chip {path}: no 300 x 300 window without IGNORE pixels (expected a label PNG of "
                         "at least 300 x 300 pixels)")
    return chip


def _compose(args: argparse.Namespace) -> None:
    import time

    import torch

    from robocompose.io.provenance import ROOT
    from robocompose.teams.decompose import DecomposeConfig, decompose_chip
    from robocompose.teams.eggan_problem import query_front
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.generative import load_generator

    torch.set_num_threads(1)
    generator, saved = load_generator(args.model or ROOT / SHIPPED_MODEL)
    k = saved["n_regions"]
    if args.regions is not None and args.regions != k:
        raise ValueError(f"--regions {args.regions}: the generator was trained for K = {k} regions (its task "
                         f"is the K x 4 feature matrix); use --regions {k} or another --model")
    coverage = CoverageConfig(**saved["params"]["coverage"])
    bank = coverage.robots_per_species * 3
    if args.budget is not None and not 1 <= args.budget <= bank:
        raise ValueError(f"--budget {args.budget}: expected a number of robots in 1..{bank} (the bank)")
    chip = _first_chip(args.chip)
    started = time.perf_counter()
    decomposition = decompose_chip(chip, DecomposeConfig(**{**saved["params"]["decompose"], "n_regions": k}))
    decomposition_ms = 1000 * (time.perf_counter() - started)
    query = query_front(generator, chip, decomposition, coverage, saved["params"]["eggan"]["samples"], args.seed)
    front = [{"deployment_cost": int(deploy), "coverage_cost": float(cost), "counts": counts.tolist()}
             for (cost, deploy), counts in zip(query.front, query.counts, strict=True)]
    out = {"chip": chip.chip_id, "regions": k, "hypervolume": query.hypervolume,
           "generator_ms": round(1000 * query.generator_seconds, 3), "decomposition_ms": round(decomposition_ms, 1)}
    if args.budget is None:
        out["front"] = front
    else:
        within = [point for point in front if point["deployment_cost"] <= args.budget]
        if not within:
            raise ValueError(f"--budget {args.budget}: no allocation of the front deploys that few robots "
                             f"(fewest: {front[0]['deployment_cost']})")
        out["budget"] = args.budget
        out["allocation"] = min(within, key=lambda point: point["coverage_cost"])
    print(json.dumps(out))
