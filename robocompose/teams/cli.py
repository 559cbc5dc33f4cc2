"""`robocompose teams ...`: NSGA-II and the coverage cost of one allocation on one terrain chip; one more generator
(a training seed) or a chip-count study's generator as a committed piece.

Heavy modules (torch, pymoo) are imported inside the handlers so `robocompose --help` stays fast.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robocompose.arguments import (
    add_compute_arguments,
    add_params_argument,
    dask_address,
    input_file,
    int_at_least,
    non_negative_int,
    positive_int,
)
from robocompose.io.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `teams` command (sub-commands `nsga2`, `coverage`, `baselines`, `generator`, `chip-count`) to the
    robocompose CLI."""
    teams = subparsers.add_parser("teams", help="multi-robot team formation on terrain chips (thesis 5.2)")
    commands = teams.add_subparsers(dest="teams_command", required=True)

    nsga2 = commands.add_parser("nsga2", help="NSGA-II allocations for one chip; prints hypervolume, "
                                "seconds and the front as JSON")
    _add_chip_arguments(nsga2)
    nsga2.add_argument("--pop", type=int_at_least(2), default=50, help="population size (thesis: 20 or 50)")
    nsga2.add_argument("--generations", type=positive_int, default=50, help="generations (thesis: 50)")
    nsga2.add_argument("--seed", type=non_negative_int, default=0, help="seed of NSGA-II and of the robots' starts")
    nsga2.add_argument("--genome", type=_genome, default="fractions",
                       help="what NSGA-II evolves: fractions (the thesis's K x O fractions) or share_split (per "
                       "species a deployed share and its split over the regions)")
    nsga2.add_argument("--address", type=dask_address, default=None,
                       help="a running Dask scheduler (tcp://host:8786) to run on instead of this process (default: "
                            "compute.address of params.yaml if there is one; \"\" = here)")
    nsga2.set_defaults(handler=_nsga2)

    coverage = commands.add_parser("coverage", help="coverage and deployment cost of one allocation")
    _add_chip_arguments(coverage)
    coverage.add_argument("--allocation", required=True,
                          help="K rows 'f_ground,f_aerial,f_aquatic' separated by ';': the fraction of "
                          "each species' robots sent to each region")
    coverage.add_argument("--seed", type=non_negative_int, default=0, help="seed of the robots' starts")
    coverage.set_defaults(handler=_coverage)

    baselines = commands.add_parser(
        "baselines", help="measure Tables 5.4 and 5.5's baselines (every NSGA-II run, the coverage baselines, the "
        "random fronts) as stage teams_baselines does and write the committed piece measured/teams/baselines/ "
        "(params.yaml's teams section; stage decompose's regions); ~12 min on 2 cores")
    add_params_argument(baselines)
    baselines.add_argument("--check", action="store_true",
                           help="measure and compare with the committed piece instead of writing it: exit 1 unless "
                                "every table is the same bytes")
    add_compute_arguments(baselines)
    baselines.set_defaults(handler=_baselines)

    generator = commands.add_parser(
        "generator", help="train one more EG-GAN generator (a training seed) as stage teams_eggan does, query it on "
        "the test chips and write the committed piece measured/teams/generators/seed-K/ (params.yaml's teams "
        "section; stage decompose's regions)")
    generator.add_argument("--seed", type=non_negative_int, required=True, help="the generator's training seed")
    add_params_argument(generator)
    generator.set_defaults(handler=_generator)

    chip_count = commands.add_parser(
        "chip-count", help="train a generator on N training chips (extra synthetic chips past the set's own when N "
        "exceeds the training split's) and write its validation hypervolume to the committed piece "
        "measured/teams/chip_count/train-N-seed-K.json (params.yaml's teams section; stage decompose's regions)")
    chip_count.add_argument("--train-chips", type=positive_int, required=True, help="N, the training chips")
    chip_count.add_argument("--seed", type=non_negative_int, required=True, help="the generator's training seed")
    add_params_argument(chip_count)
    chip_count.set_defaults(handler=_chip_count)

    verify = commands.add_parser(
        "verify-pieces", help="after a code change: re-make one stale generator piece and one stale chip-count "
        "piece under today's code and compare every result; with --rekey, the stale pieces of a kind whose re-made "
        "piece agrees take today's key (each records the key it had and the proof); prints JSON per kind")
    verify.add_argument("--rekey", action="store_true", help="re-key the stale pieces of a kind that reproduced")
    add_params_argument(verify)
    verify.set_defaults(handler=_verify_pieces)



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
        chip = first_chip(args.chip)
    else:
        chip = synthetic_chip(args.synthetic_seed)
    return chip, decompose_chip(chip, DecomposeConfig(n_regions=args.regions))


def _setup(args: argparse.Namespace):
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage

    chip, decomposition = _chip(args)
    coverage = chip_coverage(chip, decomposition, CoverageConfig())
    return AllocationEvaluator(coverage, chip.chip_id, args.seed)


def _genome(name: str) -> str:
    """argparse type: a name of robocompose.teams.nsga2.GENOMES (imported only when the flag is given)."""
    from robocompose.teams.genomes import GENOMES

    if name not in GENOMES:
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(GENOMES)}, found {name!r}")
    return name


def _nsga2(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.fanout.executor import Executor
    from robocompose.search.nsga2 import NSGA2Config
    from robocompose.teams.ergodic import CoverageConfig
    from robocompose.teams.experiments import _nsga2_run

    # The run is one executor task (the experiments stage's own), here or on a Dask worker: same result. The
    # executor connects first, so a scheduler that does not answer fails before the chip is decomposed.
    with Executor(workers=1, address=command_compute(args).address) as executor:
        chip, decomposition = _chip(args)
        config = NSGA2Config(population=args.pop, generations=args.generations, seed=args.seed)
        result, evaluator = executor.map(_nsga2_run, [(chip, decomposition, CoverageConfig(), config, args.genome, 1,
                                                       None)])[0]
    print(json.dumps({"hypervolume": result.hypervolume, "seconds": result.seconds,
                      "distinct_teams": len(evaluator.asked),
                      "front": [[float(c), int(d)] for c, d in result.front]}))


def _baselines(args: argparse.Namespace) -> None:
    import tempfile

    import torch

    from robocompose.arguments import command_compute
    from robocompose.io import read_table
    from robocompose.params import load_section
    from robocompose.teams.baseline_runs import PIECE, TABLES, measure, piece_key, piece_matches, write_piece
    from robocompose.teams.experiments import decomposed_chips
    from robocompose.teams.params import TeamsParams

    params = load_section(TeamsParams, "teams", path=args.params)
    compute = command_compute(args, args.params)
    chips = decomposed_chips(read_table("data/regions.parquet", "regions"), "test")  # stage decompose's
    key = piece_key(params, chips)
    if args.check and not piece_matches(key):
        raise InputError(f"{PIECE}/piece.json: key: expected {key} (these settings, chips and code), found another "
                         "or none: nothing to check against")
    torch.set_num_threads(params.threads)
    with compute.executor("teams baselines") as executor:
        runs = measure(chips, params, executor)
    if not args.check:
        write_piece(runs, key)
        print(json.dumps({"piece": str(PIECE), "key": key, "seconds": runs.timings["measured_seconds"]}))
        return
    with tempfile.TemporaryDirectory() as scratch:
        write_piece(runs, key, Path(scratch))
        differ = [stem for stem in TABLES if (Path(scratch) / f"{stem}.parquet").read_bytes() !=
                  (PIECE / f"{stem}.parquet").read_bytes()]
    print(json.dumps({"piece": str(PIECE), "key": key, "identical": not differ, "differ": differ}))
    if differ:
        raise SystemExit(1)


def _generator(args: argparse.Namespace) -> None:
    import torch

    from robocompose.io import read_table
    from robocompose.params import load_section
    from robocompose.teams.experiments import decomposed_chips
    from robocompose.teams.generators import PIECES, train_and_query, write_piece
    from robocompose.teams.params import TeamsParams

    params = load_section(TeamsParams, "teams", path=args.params)
    regions = read_table("data/regions.parquet", "regions")  # stage decompose's: the same chips and split
    torch.set_num_threads(params.threads)
    generated = train_and_query(params, args.seed, decomposed_chips(regions, "train"),
                                decomposed_chips(regions, "test"),
                                Path(f"models/checkpoints/teams_generator_seed{args.seed}.pt"))
    directory = write_piece(generated, params, args.seed)
    print(json.dumps({"piece": str(directory), "root": str(PIECES), "seed": args.seed,
                      "mean_hypervolume": round(float(generated.queries.hypervolume.mean()), 4),
                      "training_seconds": round(generated.training_seconds, 1)}))


def _chip_count(args: argparse.Namespace) -> None:
    import torch

    from robocompose.io import read_table
    from robocompose.params import load_section
    from robocompose.teams.chip_count import PIECES, measure, write_piece
    from robocompose.teams.experiments import decomposed_chips
    from robocompose.teams.params import TeamsParams

    params = load_section(TeamsParams, "teams", path=args.params)
    regions = read_table("data/regions.parquet", "regions")  # stage decompose's: the same chips and split
    torch.set_num_threads(params.threads)
    piece = measure(params, decomposed_chips(regions, "train"), args.train_chips, args.seed,
                    Path(f"models/checkpoints/teams_chip_count_{args.train_chips}_seed{args.seed}.pt"))
    path = write_piece(piece, params)
    print(json.dumps({"piece": str(path), "root": str(PIECES),
                      **{name: piece[name] for name in ("train_chips", "seed", "validation_hypervolume",
                                                        "training_seconds")}}))


def _verify_pieces(args: argparse.Namespace) -> None:
    import torch

    from robocompose.io import read_table
    from robocompose.params import load_section
    from robocompose.teams.experiments import decomposed_chips
    from robocompose.teams.params import TeamsParams
    from robocompose.teams.pieces import verify_chip_count, verify_generators

    params = load_section(TeamsParams, "teams", path=args.params)
    regions = read_table("data/regions.parquet", "regions")  # stage decompose's: the same chips and split
    torch.set_num_threads(params.threads)
    train, test = decomposed_chips(regions, "train"), decomposed_chips(regions, "test")
    print(json.dumps(verify_generators(params, train, test, args.rekey)), flush=True)
    print(json.dumps(verify_chip_count(params, train, args.rekey)), flush=True)


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


def first_chip(path):
    """The first 300 x 300 chip of a label PNG; the project's input error naming --chip if there is none."""
    from robocompose.teams.chips import chips_in_file

    if not path.is_file():
        raise InputError(f"--chip {path}: no such file (expected a DroneDeploy-format label PNG)")
    chip = next(chips_in_file(path), None)  # an unreadable image: chips_in_file names the file
    if chip is None:
        raise InputError(f"--chip {path}: no 300 x 300 window without IGNORE pixels (expected a label PNG of "
                         "at least 300 x 300 pixels)")
    return chip
