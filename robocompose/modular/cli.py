"""`robocompose modular ...`: evaluate one modular design on a block terrain; run a GA baseline on one terrain;
measure one terrain's exhaustive table; probe candidate terrain distributions; the terrain criterion of a
directory of exhaustive tables; probe a terrain family (or the perturbed block world); the gate of a probe; train
a Table 5.1 learner at a further training seed.

Settings come from the `modular:` and `compute:` sections of `--params` (default: params.yaml if there is one,
else the dataclass defaults: the default profile's episode on the reference's course); a file named with
`--params` must exist. pybullet and the search code are imported inside the handlers.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robocompose.arguments import (
    add_compute_arguments,
    input_file,
    int_at_least,
    non_negative_int,
    output_directory,
    output_file,
)

VARIANTS = ("ga20", "ga50", "crowding", "random")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the `modular ...` commands to the robocompose CLI."""
    modular = subparsers.add_parser("modular", help="modular robots on block terrains (thesis 5.1)")
    commands = modular.add_subparsers(dest="modular_command", required=True)

    evaluate = commands.add_parser("evaluate", help="simulate one design; prints distance, status, seconds as JSON")
    evaluate.add_argument("--design", required=True,
                          help="6 letters n/l/w/b (none/leg/wheel/leg-wheel), ports front-left, mid-left, "
                          "back-left, back-right, mid-right, front-right")
    evaluate.add_argument("--terrain-seed", type=non_negative_int, required=True, help="seed of the block terrain")
    evaluate.add_argument("--mcap", type=output_file(".mcap", "MCAP"),
                          help="write the rollout as MCAP (Foxglove schemas)")
    evaluate.add_argument("--gif", type=output_file(".gif", "GIF"), help="write the rollout as an animated GIF")
    _add_params_argument(evaluate)
    evaluate.set_defaults(handler=_evaluate)

    ga = commands.add_parser("ga", help="an evolutionary baseline on one terrain; prints the best design as JSON")
    ga.add_argument("--variant", choices=VARIANTS, required=True,
                    help="ga20 / ga50 (uniform crossover + mutation), crowding (deterministic crowding, "
                    "population 50), random (random sampling)")
    ga.add_argument("--terrain-seed", type=non_negative_int, required=True)
    ga.add_argument("--seed", type=non_negative_int, default=0, help="seed of the search")
    _add_evaluation_arguments(ga)
    ga.set_defaults(handler=_ga)

    exhaustive = commands.add_parser(
        "exhaustive", help="every design on each terrain, a table per terrain kept under "
        "measured/modular/exhaustive/ (resumes: terrains whose table is there are skipped, a terrain half done "
        "resumes from the cache)")
    exhaustive.add_argument("--terrain-seed", type=non_negative_int, nargs="+", required=True,
                            help="one or more terrain seeds, measured in this order")
    exhaustive.add_argument("--out-dir", type=output_directory, default=None,
                            help="where the table and its provenance record go (default measured/modular/exhaustive)")
    exhaustive.add_argument("--design-set", choices=("balanced", "top", "all"), default=None,
                            help="a partial test table of this design set only (balanced: 400 designs that keep "
                            "the block test optimum; family-probe's sets), kept under measured/modular/test_partial "
                            "(default: every design, an exhaustive table)")
    exhaustive.add_argument("--candidates", type=input_file("candidates YAML"),
                            help="with --distribution: a YAML of candidate terrain distributions (as for probe)")
    exhaustive.add_argument("--distribution", help="measure under this candidate of --candidates instead of the "
                            "params' terrain")
    _add_evaluation_arguments(exhaustive)
    exhaustive.set_defaults(handler=_exhaustive)

    probe = commands.add_parser(
        "probe", help="a fixed set of designs on seeded terrains under candidate terrain distributions; writes "
        "the rows and the terrain criterion per candidate as CSV (resumes through the cache)")
    probe.add_argument("--candidates", type=input_file("candidates YAML"), required=True,
                       help="YAML mapping: distribution name -> overrides of the params' eval.terrain fields")
    probe.add_argument("--terrain-seed", type=non_negative_int, nargs="+", required=True,
                       help="the terrain seeds, probed in this order")
    probe.add_argument("--out", type=output_file(".csv", "CSV", beside=("_criterion.csv",)), required=True,
                       help="the probe's rows; the criterion per candidate goes beside it (<name>_criterion.csv)")
    probe.add_argument("--designs", nargs="+", default=None,
                       help="port strings to probe (default: terrain_study.PROBE_DESIGNS, 20 designs)")
    _add_evaluation_arguments(probe)
    probe.set_defaults(handler=_probe)

    verify = commands.add_parser(
        "verify-committed", help="re-simulate a random sample of each committed exhaustive table under its own "
        "settings and compare bit for bit; with --rekey, a table whose sample all agrees takes the current physics "
        "digest (the proof that a code change left its numbers as they were); prints JSON per table")
    verify.add_argument("--dir", type=Path, default=None,
                        help="a directory of blocks-<seed>.parquet tables (default measured/modular/exhaustive)")
    verify.add_argument("--sample", type=int_at_least(1), default=20, help="designs re-simulated per table")
    verify.add_argument("--seed", type=non_negative_int, default=0, help="seed of the sample")
    verify.add_argument("--rekey", action="store_true", help="re-key the tables whose sample agrees exactly")
    _add_evaluation_arguments(verify)
    verify.set_defaults(handler=_verify)

    criterion = commands.add_parser(
        "criterion", help="the terrain criterion (distinct optima up to mirror, regret of the best-on-average "
        "design) of the exhaustive tables in a directory; prints JSON")
    criterion.add_argument("--dir", type=Path, default=None,
                           help="a directory of blocks-<seed>.parquet tables (default measured/modular/exhaustive)")
    criterion.set_defaults(handler=_criterion)

    family_probe = commands.add_parser(
        "family-probe", help="a design set on seeded terrains of one terrain family (or the block world, perturbed), "
        "a table per terrain under measured/modular/families/ (resumes: kept tables are skipped, a terrain half "
        "done resumes from the cache); prints JSON per terrain")
    family_probe.add_argument("--family", required=True, help="a terrain family (walls, steps, rubble, ice, "
                              "mixed: robocompose/modular/families.py) or blocks (the params' block world)")
    family_probe.add_argument("--terrain-seed", type=non_negative_int, nargs="+", required=True,
                              help="terrain seeds, measured in this order")
    family_probe.add_argument("--design-set", choices=("balanced", "top", "all"), default="balanced",
                              help="balanced (default): the 25 best on the block pool's mean per composition class, "
                              "then the best on that mean, 400 in all; top: the pool's 400 best; all: 1296 valid")
    family_probe.add_argument("--perturbations", type=non_negative_int, default=0,
                              help="fitness = mean distance over this many perturbed terrains (boxes moved <= 2 cm); "
                              "0 (default): the terrain itself")
    family_probe.add_argument("--family-settings", type=input_file("family settings YAML"),
                              help="YAML mapping of the family's settings to override (field -> value)")
    family_probe.add_argument("--out-dir", type=output_directory, default=None,
                              help="where the tables go (default measured/modular/families/<family>[_p<P>])")
    _add_evaluation_arguments(family_probe)
    family_probe.set_defaults(handler=_family_probe)

    gate = commands.add_parser(
        "gate", help="does the terrain decide? leave one terrain out: predict-the-table top-k (k-NN, ridge) against "
        "the greedy portfolio at k = 1, 3, 10 on the tables of one world; prints JSON")
    gate.add_argument("--dir", type=Path, nargs="+", required=True,
                      help="directories of one world's tables (a family probe's, or e.g. measured/modular/pool "
                      "measured/modular/exhaustive)")
    gate.add_argument("--neighbours", type=int_at_least(1), default=3, help="k-NN: terrains averaged (default 3)")
    gate.add_argument("--scores", type=output_file(".csv", "CSV"),
                      help="write the per-terrain scores (terrain, k, method, score) as CSV")
    gate.set_defaults(handler=_gate)

    seeded = commands.add_parser(
        "train-seed", help="train one Table 5.1 learner at another training seed with the params' eggan_modular "
        "settings (pool tables, budget), into a directory of its own (resumes from its checkpoint); prints its "
        "metrics as JSON. The stage trains each learner at its configured seed; further seeds are measurements")
    seeded.add_argument("--method", required=True, help="crowding, ga, fit2form, dqn or molgan")
    seeded.add_argument("--seed", type=non_negative_int, required=True, help="the training seed")
    seeded.add_argument("--out-dir", type=output_directory, required=True,
                        help="where the model, its checkpoint and curve go (e.g. measured/modular/seeds/seed-1)")
    _add_params_argument(seeded)
    seeded.set_defaults(handler=_train_seed)


def _add_evaluation_arguments(parser: argparse.ArgumentParser) -> None:
    """--workers, --address and --params of the commands that evaluate many designs."""
    add_compute_arguments(parser)
    _add_params_argument(parser)


def _add_params_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--params", type=Path, help="params file with modular: and compute: sections (default: "
                        "params.yaml if there is one, else the defaults); a file named here must exist")


def _params_file(path: Path | None) -> Path | None:
    """The params file a command reads: `path` if given (it must exist), else params.yaml if there is one."""
    return path if path is not None or not Path("params.yaml").exists() else Path("params.yaml")


def params_source(path: Path | None) -> str:
    """Where the `modular:` section of a command's params comes from, as its fields' error messages name it."""
    file = _params_file(path)
    return "the built-in defaults: modular" if file is None else f"{file}: modular"


def _params(path: Path | None):
    from robocompose.modular.params import ModularParams
    from robocompose.params import load_command_section

    return load_command_section(ModularParams, "modular", path)


def _evaluate(args: argparse.Namespace) -> None:
    from robocompose.modular.evaluate import evaluate_designs
    from robocompose.modular.record import record_rollout
    from robocompose.modular.robot import parse_design

    design = parse_design(args.design)
    params = _params(args.params)
    if params.fitness.skips(design):
        result = evaluate_designs([design], args.terrain_seed, params.eval, params.fitness)[0]
    else:
        result = record_rollout(design, args.terrain_seed, params.eval, mcap=args.mcap, gif=args.gif)
    print(json.dumps({"design": design, "terrain_seed": args.terrain_seed, "distance": result.distance,
                      "fitness": params.fitness.fitness(result), "status": result.status,
                      "sim_steps": result.sim_steps, "seconds": round(result.seconds, 3),
                      "settings_hash": params.eval.settings_hash()}))


def _ga(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.modular.experiments.baselines import run_method

    params = _params(args.params)
    compute = command_compute(args, args.params)
    with compute.executor() as executor:
        run = run_method(args.variant, args.terrain_seed, args.seed, params, compute.open_cache(), executor)
    print(json.dumps({"variant": args.variant, "terrain_seed": args.terrain_seed, "seed": args.seed,
                      "best_design": run.best_design, "best_fitness": run.best_fitness,
                      "distinct": run.distinct, "evaluations": run.evaluations,
                      "seconds": round(run.seconds, 3), "sim_seconds": round(run.sim_seconds, 3)}))


def _exhaustive(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.io import read_table
    from robocompose.io.errors import InputError
    from robocompose.modular.experiments.held_out import PARTIAL_DIR, design_set_record, read_partial
    from robocompose.modular.experiments.terrain_study import candidate_settings
    from robocompose.modular.family_truth import design_set
    from robocompose.modular.truth import COMMITTED_DIR, committed_path, measure_committed, truth_summary
    from robocompose.params import read_params

    params = _params(args.params)
    compute = command_compute(args, args.params)
    settings = params.eval
    if (args.candidates is None) != (args.distribution is None):
        raise InputError("--candidates and --distribution: expected both (a candidate terrain) or neither")
    if args.distribution is not None:
        document = read_params(args.candidates)
        if args.distribution not in document:
            raise InputError(f"--distribution {args.distribution!r}: not in {args.candidates} (expected one of "
                             f"{sorted(document)})")
        settings = candidate_settings(settings, {args.distribution: document[args.distribution]},
                                      str(args.candidates))[args.distribution]
    designs, extra, directory = None, None, args.out_dir or COMMITTED_DIR
    if args.design_set is not None:
        designs = design_set(args.design_set)
        extra, directory = design_set_record(args.design_set, designs), args.out_dir or PARTIAL_DIR
        if directory.resolve() == COMMITTED_DIR.resolve():  # the stages would read it as an exhaustive table
            raise InputError(f"--out-dir {directory}: expected a directory for partial tables (default "
                             f"{PARTIAL_DIR}), not that of the exhaustive ones")
    # every committed record is checked before the first rollout
    kept_seeds = {seed for seed in args.terrain_seed
                  if read_partial(seed, settings, params.fitness, directory, extra) is not None}
    cache = compute.open_cache()
    with compute.executor() as executor:
        for seed in args.terrain_seed:
            kept = seed in kept_seeds
            path = (committed_path(seed, directory) if kept
                    else measure_committed(seed, settings, params.fitness, cache, executor, directory, designs,
                                           extra))
            best = truth_summary(read_table(path, "modular_exhaustive"), params.experiments.near_optimal).iloc[0]
            print(json.dumps({"terrain_seed": seed, "table": str(path), "source": "kept" if kept else "measured",
                              "optimum": best.optimum, "best_design": best.best_design,
                              "near_optimal": int(best.near_optimal)}), flush=True)

def _probe(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.io import atomic_write_text
    from robocompose.modular.experiments.terrain_study import (
        PROBE_DESIGNS,
        candidate_settings,
        criteria,
        probe_table,
        rounded,
    )
    from robocompose.modular.robot import parse_design
    from robocompose.params import read_params

    params = _params(args.params)
    compute = command_compute(args, args.params)
    candidates = candidate_settings(params.eval, read_params(args.candidates), str(args.candidates))
    designs = [parse_design(d) for d in args.designs] if args.designs else list(PROBE_DESIGNS)
    cache = compute.open_cache()

    def write(table) -> None:
        rows = table.drop(columns="seconds")  # wall time of each rollout: not reproducible
        atomic_write_text(args.out, rounded(rows).to_csv(index=False))
        atomic_write_text(args.out.with_name(f"{args.out.stem}_criterion.csv"),
                          rounded(criteria(table)).to_csv(index=False))

    with compute.executor() as executor:
        table = probe_table(candidates, args.terrain_seed, params.fitness, cache, executor, designs,
                            on_piece=write)
    for row in criteria(table).to_dict("records"):
        print(json.dumps(row))


def _verify(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.io.errors import InputError
    from robocompose.modular.truth import COMMITTED_DIR, read_record, verify_committed

    directory = args.dir or COMMITTED_DIR
    tables = sorted(Path(directory).glob("blocks-*.parquet"))
    if not tables:
        raise InputError(f"--dir {directory}: no blocks-<seed>.parquet tables there")
    for path in tables:  # every record checked before the first rollout
        read_record(path)
    with command_compute(args, args.params).executor() as executor:
        for path in tables:
            print(json.dumps(verify_committed(path, args.sample, args.seed, executor, args.rekey)), flush=True)


def _criterion(args: argparse.Namespace) -> None:
    from robocompose.modular.experiments.terrain_study import directory_criterion
    from robocompose.modular.truth import COMMITTED_DIR

    per_terrain, totals = directory_criterion(args.dir or COMMITTED_DIR)
    print(json.dumps({**totals, "per_terrain": per_terrain.to_dict("records")}))


def _family_probe(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.io.errors import InputError
    from robocompose.modular.family_truth import default_directory, design_set, make_world, probe
    from robocompose.modular.params import course_reach
    from robocompose.params import read_params

    params = _params(args.params)
    overrides = read_params(args.family_settings) if args.family_settings else None
    world = make_world(args.family, params.eval, overrides, str(args.family_settings or "family settings"))
    reach = course_reach(params.eval)
    if world.config.x_range[1] < reach:  # as the block world's check_course: no design may run off the course
        raise InputError(f"{args.family_settings or args.family}: x_range: the course ends at "
                         f"x = {world.config.x_range[1]:g} m, but the fastest design reaches x = {reach:.2f} m within "
                         f"the episode; expected x_range[1] >= {reach:.2f}")
    designs = design_set(args.design_set)
    directory = args.out_dir or default_directory(args.family, args.perturbations)
    compute = command_compute(args, args.params)
    with compute.executor() as executor:
        probe(world, args.terrain_seed, params.fitness, args.perturbations, args.design_set, designs,
              compute.open_cache(), executor, directory, on_terrain=lambda row: print(json.dumps(row), flush=True))


def _gate(args: argparse.Namespace) -> None:
    from robocompose.modular.family_truth import gate_directories
    from robocompose.modular.gate import GateConfig

    result = gate_directories(args.dir, GateConfig(neighbours=args.neighbours))
    if args.scores is not None:
        from robocompose.io import atomic_write_text

        atomic_write_text(args.scores, result.scores.round(4).to_csv(index=False))
    print(json.dumps(result.summary))


def _train_seed(args: argparse.Namespace) -> None:
    from robocompose.modular.eggan_params import EgganModularParams
    from robocompose.modular.experiments.generative import train_seed
    from robocompose.params import load_command_section

    params = load_command_section(EgganModularParams, "eggan_modular", args.params)
    metrics = train_seed(args.method, args.seed, _params(args.params), params, args.out_dir)
    print(json.dumps(metrics, default=float))
