"""`robocompose evaluate`: score one design on one task with the MPPI evaluator; prints JSON. `robocompose
evaluator-fidelity` (the fidelity ladder) and `robocompose reference-evals` (the reference designs' committed
evaluations)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robocompose.arguments import add_compute_arguments, add_params_argument, input_file, non_negative_int, output_file


def register(subparsers: argparse._SubParsersAction) -> None:
    evaluate = subparsers.add_parser("evaluate", help="score a design on a task (MPPI in pybullet); prints JSON")
    evaluate.add_argument("--rules", required=True, help="comma-separated rule indices, e.g. 0,7,1,13,...")
    evaluate.add_argument("--task", default="flat",
                          help="a terrain of robocompose.tasks.terrains.TASKS (unknown: refused with the list)")
    evaluate.add_argument("--seed", type=non_negative_int, default=None,
                          help="controller seed (default: evaluation.seed)")
    evaluate.add_argument("--params", type=Path, default=Path("params.yaml"),
                          help="params file whose `evaluation` section is used")
    evaluate.add_argument("--mcap", type=output_file(".mcap", "MCAP"), help="write the trajectory as an MCAP log "
                          "(Foxglove)")
    evaluate.add_argument("--gif", type=output_file(".gif", "GIF"), help="write the trajectory as an animated GIF")
    evaluate.set_defaults(handler=_evaluate)
    register_fidelity(subparsers)
    register_references(subparsers)


def _evaluate(args: argparse.Namespace) -> int:
    from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
    from robocompose.evaluation.rollout_log import RolloutRecorder
    from robocompose.grammar.derivation import derive, parse_rules
    from robocompose.params import load_section
    from robocompose.sim.physics import PhysicsSettings
    from robocompose.tasks.terrains import get_task

    tree = derive(parse_rules(args.rules, "--rules")).tree  # the command line first: no params file needed to reject it
    task = get_task(args.task).name
    config = load_section(EvaluationConfig, "evaluation", args.params)
    seed = config.seed if args.seed is None else args.seed
    recorder = None
    if args.mcap or args.gif:
        recorder = RolloutRecorder(config.mppi.interval * PhysicsSettings().time_step, images=bool(args.gif))
    row = evaluate(tree, task, config, seed, observer=recorder, visual=bool(args.gif))
    written = {}
    if recorder is not None and recorder.times:  # nothing to write for a design that was not simulated
        if args.mcap:
            written["mcap"] = str(recorder.write_mcap(args.mcap))
        if args.gif:
            written["gif"] = str(recorder.write_gif(args.gif))
    print(json.dumps({"design_id": tree.design_id, "task": task, "seed": seed,
                      "settings_hash": config.settings_hash(task), **row, **written}))
    return 0


def register_fidelity(subparsers: argparse._SubParsersAction) -> None:
    fidelity = subparsers.add_parser("evaluator-fidelity",
                                     help="score a fixed design set under a ladder of MPPI settings (hours)")
    fidelity.add_argument("action", choices=("build-set", "measure", "summarise"),
                          help="build-set: the design set; measure: score what the pieces lack; summarise: the "
                               "table (the search-found designs: `robocompose fidelity-search`)")
    fidelity.add_argument("--params", default="params.yaml", help="params file whose `evaluator_fidelity` is used")
    fidelity.add_argument("--tasks", help="comma-separated tasks instead of evaluator_fidelity.tasks")
    fidelity.add_argument("--rungs", help="comma-separated ladder rungs instead of evaluator_fidelity.rungs")
    fidelity.add_argument("--designs", help="measure: comma-separated design names, only these (for a second "
                                            "process on another part of the set)")
    fidelity.add_argument("--kinds", help="measure: comma-separated kinds of design (reference, search, screened, "
                                          "random), only these")
    fidelity.add_argument("--dataset", type=input_file("a designs table (parquet)"),
                          default=Path("data/designs.parquet"),
                          help="build-set: the dataset whose first designs are drawn (default: data/designs.parquet)")
    fidelity.set_defaults(handler=_fidelity)


def name_list(text: str | None, flag: str, what: str) -> list[str] | None:
    """A comma-separated list flag: None if not given; an empty list or an empty item is an error (an empty
    --rungs is not "every rung")."""
    from robocompose.io.errors import InputError

    if text is None:
        return None
    names = [name.strip() for name in text.split(",")]
    if not any(names):
        raise InputError(f"{flag} {text!r}: expected one or more comma-separated {what}, found none "
                         f"(leave {flag} out for the params' list)")
    if not all(names):
        raise InputError(f"{flag} {text!r}: expected comma-separated {what}, found an empty item")
    return names


def _fidelity(args: argparse.Namespace) -> int:
    import dataclasses

    from robocompose.evaluation import fidelity
    from robocompose.io.errors import InputError
    from robocompose.params import load_section

    lists = {"tasks": name_list(args.tasks, "--tasks", "task names"),
             "rungs": name_list(args.rungs, "--rungs", "ladder rungs"),
             "kinds": name_list(args.kinds, "--kinds", "kinds of design"),
             "designs": name_list(args.designs, "--designs", "design names")}  # checked before the params
    config = load_section(fidelity.FidelityConfig, "evaluator_fidelity", args.params)
    changes = {name: lists[name] for name in ("tasks", "rungs") if lists[name] is not None}
    try:
        config = dataclasses.replace(config, **changes)  # re-checked by __post_init__: "tasks: ..." or "rungs: ..."
    except InputError as err:
        raise InputError(f"argument --{err}") from None
    if args.action == "build-set":
        from robocompose.io import read_table

        table = fidelity.build_design_set(config, read_table(args.dataset, "designs"), str(args.dataset))
        print(json.dumps({"designs": str(fidelity.write_design_set(table, config.directory))}))
        return 0
    designs = fidelity.read_design_set(config.directory)
    if args.action == "measure":
        chosen = designs
        if lists["kinds"] is not None:
            kinds = lists["kinds"]
            unknown = sorted(set(kinds) - set(fidelity.MEASURE_ORDER))
            if unknown:
                raise InputError(f"--kinds: unknown kind {unknown[0]!r}; "
                                 f"expected some of {list(fidelity.MEASURE_ORDER)}")
            chosen = chosen[chosen["kind"].isin(kinds)]
        if lists["designs"] is not None:
            names = lists["designs"]
            unknown = sorted(set(names) - set(designs["name"]))
            if unknown:
                raise InputError(f"--designs: unknown design {unknown[0]!r}; "
                                 f"{Path(config.directory) / fidelity.DESIGNS_FILE} has {list(designs['name'])}")
            chosen = chosen[chosen["name"].isin(names)]
        print(json.dumps({"scored": fidelity.measure(config, chosen)}))
    summary = fidelity.summarise(fidelity.read_scores(config.directory), designs, config.top)
    print(summary.to_string(index=False))
    return 0


def register_references(subparsers: argparse._SubParsersAction) -> None:
    references = subparsers.add_parser(
        "reference-evals", help="evaluate the reference and random designs on every task as stage "
        "evaluate_references does and commit the evaluations to measured/references/eval_cache.parquet, which the "
        "stage then serves (params.yaml's evaluation and evaluate_references sections; data/designs.parquet)")
    add_params_argument(references)
    add_compute_arguments(references)
    references.set_defaults(handler=_reference_evals)


def _reference_evals(args: argparse.Namespace) -> None:
    from robocompose.arguments import command_compute
    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.evaluation.references import ReferencesConfig, commit_evaluations, evaluate_references
    from robocompose.io import read_table
    from robocompose.params import load_section

    evaluation = load_section(EvaluationConfig, "evaluation", args.params)
    config = load_section(ReferencesConfig, "evaluate_references", args.params)
    compute = command_compute(args, args.params)
    designs = read_table("data/designs.parquet", "designs")  # stage enumerate's
    cache = compute.open_cache()
    with compute.executor("reference evaluations") as executor:
        table = evaluate_references(designs, config, evaluation, cache, executor)
    path = commit_evaluations(table, cache)
    print(json.dumps({"committed": str(path), "evaluations": len(table)}))
