"""`robocompose glso`: one search run (task, method, seed) with a budget of objective calls; a JSON line per step."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from robocompose.arguments import add_compute_arguments, dask_address


def register(subparsers: argparse._SubParsersAction) -> None:
    glso = subparsers.add_parser("glso", help="search a task for the best design with one method; JSON per step")
    glso.add_argument("--task", default="flat",
                      help="a terrain of robocompose.tasks.terrains.TASKS (an unknown one is refused with the list)")
    glso.add_argument("--method", default="glso",
                      help="a method of robocompose/glso/registry.py: glso (and its ablations), random, ga, mcts, ...")
    glso.add_argument("--budget", type=int, default=None, help="objective calls (default: glso.budget)")
    glso.add_argument("--seed", type=int, default=0, help="run seed")
    glso.add_argument("--model", default=None, help="the VAE of a latent method (default: glso.models)")
    glso.add_argument("--params", default="params.yaml",
                      help="params file (sections glso, evaluation, compute; the run scores at glso.rung's MPPI "
                           "settings if one is named)")
    glso.add_argument("--checkpoint", default=None,
                      help="save to this checkpoint file, or resume from it if it holds this run's checkpoint")
    glso.add_argument("--out", default=None, help="write the step table here (a .parquet file)")
    glso.add_argument("--address", type=dask_address, default=None,
                      help="run the search on a worker of this Dask scheduler (tcp://host:8786; default: params' "
                           "compute.address; \"\" = here); its lines print when it finishes")
    glso.set_defaults(handler=_glso)
    campaign = subparsers.add_parser("glso-campaign", help="the seeded GLSO campaign: run what is missing (hours, "
                                     "resumable) or summarise the committed runs")
    campaign.add_argument("action", choices=("run", "heldout", "verify", "summarise", "pilot", "vae"),
                          help="run: every missing run, then the re-scores and held-out pieces; pilot: the same for "
                               "the pilot of GLSO's variants (3 seeds each at rung s8_h8_e48, measured/glso_pilot/; "
                               "~2 core-hours), then its table; heldout: only the "
                               "held-out pieces of the committed runs (each run's top designs at fresh seeds, the "
                               "thesis re-scores of its held-out best); verify: re-simulate a design of each "
                               "method and, if today's code scores it bit for bit as committed, record its settings "
                               "hash as the runs' evaluator; summarise: the statistics as JSON; vae: the VAE at "
                               "the thesis's scale in committed pieces (vae_thesis: >= 100k designs, then >= 100k "
                               "steps at hidden 450, ~8 core-hours per VAE of vae_thesis.variants, resumable; "
                               "Ctrl-C keeps the last checkpoint)")
    campaign.add_argument("--params", default="params.yaml",
                          help="params file (sections glso_campaign, glso, evaluation, compute; vae: vae_thesis, "
                               "enumerate, compute)")
    campaign.add_argument("--rung", default=None, help="the fidelity rung of the runs (default: glso_campaign.rung, "
                                                       "else the one the evaluator fidelity rule chose; heldout "
                                                       "measures at the committed runs' rung, campaign.json's)")
    add_compute_arguments(campaign)
    campaign.set_defaults(handler=_campaign)
    search = subparsers.add_parser("fidelity-search", help="searches at cheap fidelity rungs whose best designs join "
                                   "the evaluator fidelity set (hours, resumable)")
    search.add_argument("--params", default="params.yaml", help="params file (sections evaluator_fidelity, glso)")
    search.add_argument("--checkpoints", default="data/fidelity_searches",
                        help="where each search's checkpoint is kept (default: data/fidelity_searches)")
    search.set_defaults(handler=_fidelity_search)


def _fidelity_search(args: argparse.Namespace) -> int:
    from robocompose.evaluation import fidelity
    from robocompose.glso import fidelity_search
    from robocompose.glso.runs import GLSOConfig
    from robocompose.params import load_section

    config = load_section(fidelity.FidelityConfig, "evaluator_fidelity", args.params)
    designs = fidelity.read_design_set(config.directory)
    fidelity_search.run_searches(config, load_section(GLSOConfig, "glso", args.params), args.checkpoints)
    designs = fidelity_search.add_search_designs(config, designs)
    print(json.dumps({"designs": str(fidelity.write_design_set(designs, config.directory)),
                      "search_designs": int((designs["kind"] == fidelity.SEARCH).sum())}))
    return 0


def _thesis_scale_vae(args: argparse.Namespace) -> int:
    from robocompose.arguments import command_compute
    from robocompose.dataset.enumerate import EnumerateConfig
    from robocompose.latent import thesis_scale
    from robocompose.params import load_section

    config = load_section(thesis_scale.ThesisScaleConfig, "vae_thesis", args.params)
    enumeration = load_section(EnumerateConfig, "enumerate", args.params)
    with command_compute(args, args.params).executor() as executor:
        thesis_scale.enumerate_pieces(config, enumeration, executor)
    for variant in config.variants:
        thesis_scale.train_thesis_scale(config, variant)
    print(json.dumps(thesis_scale.progress(config)))
    return 0


def _campaign(args: argparse.Namespace) -> int:
    import dataclasses

    from robocompose.arguments import command_compute
    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.glso import campaign
    from robocompose.glso.runs import GLSOConfig
    from robocompose.io.errors import InputError
    from robocompose.params import load_section

    if args.action == "vae":
        return _thesis_scale_vae(args)
    config = load_section(campaign.CampaignConfig, "glso_campaign", args.params)
    if args.rung is not None:
        try:
            config = dataclasses.replace(config, rung=args.rung)  # re-checked by __post_init__
        except InputError as err:
            raise InputError(f"argument --rung: {err}") from None
    if args.action == "pilot":
        pilot = campaign.pilot_config(config)
        glso = load_section(GLSOConfig, "glso", args.params)
        evaluation = load_section(EvaluationConfig, "evaluation", args.params)
        with command_compute(args, args.params).executor() as executor:
            campaign.run_campaign(pilot, glso, evaluation, pilot.rung, executor)
        print(json.dumps(campaign.pilot_summary(config), default=float))
        return 0
    if args.action == "run":
        rung = campaign.campaign_rung(config)
        glso = load_section(GLSOConfig, "glso", args.params)
        evaluation = load_section(EvaluationConfig, "evaluation", args.params)
        with command_compute(args, args.params).executor() as executor:
            tables = campaign.run_campaign(config, glso, evaluation, rung, executor)
        print(json.dumps({"rung": rung, "finished": len(tables), "planned": len(campaign.run_specs(config))}))
        return 0
    if args.action == "verify":
        evaluation = load_section(EvaluationConfig, "evaluation", args.params)
        with command_compute(args, args.params).executor() as executor:
            print(json.dumps({"reproduced": campaign.verify_evaluator(config, evaluation, executor=executor)}))
        return 0
    if args.action == "heldout":
        evaluation = load_section(EvaluationConfig, "evaluation", args.params)
        with command_compute(args, args.params).executor() as executor:
            measured = campaign.measure_heldout(config, evaluation, executor)
        print(json.dumps({"measured": measured, "progress": campaign.summarise(config).get("heldout_progress")}))
        return 0
    summary = campaign.summarise(config)
    print(json.dumps({k: summary[k] for k in ("runs", "planned")} | {"tests": summary["tests"]}, default=float))
    return 0


def _remote_search(job: tuple) -> object:
    """One search run on a Dask worker (module level, so that it pickles): its step table."""
    from robocompose.fanout.cache import EvaluationCache
    from robocompose.glso.runs import run_search

    spec, config, evaluation, checkpoint, model, cache = job
    return run_search(spec, config, evaluation, checkpoint=checkpoint, model_path=model, named_checkpoint=True,
                      cache=EvaluationCache(cache or None))


def check_checkpoint_path(path: Path) -> Path:
    """`path` if a checkpoint can be read or written there (a file or a new name, in a location this process can
    write in); else InputError.

    Whether an existing file holds this run's checkpoint is checked by its header when the run starts."""
    import os

    from robocompose.arguments import check_names, check_writable
    from robocompose.io.errors import InputError

    try:
        check_names(path)
    except InputError as err:
        raise InputError(f"--checkpoint {err}") from None
    if os.path.isdir(path):
        raise InputError(f"--checkpoint {path}: is a directory, expected a checkpoint file name")
    blocking = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise InputError(f"--checkpoint {path}: {blocking} is a file, expected a directory")
    try:
        return check_writable(path)
    except InputError as err:
        raise InputError(f"--checkpoint {err}") from None


def check_table_path(path: Path) -> Path:
    """`path` if the step table (parquet) can be written there; else InputError naming --out."""
    from robocompose.arguments import check_output_file
    from robocompose.io.errors import InputError

    try:
        return check_output_file(path, ".parquet", "a parquet step table")
    except InputError as err:
        raise InputError(f"--out {err}") from None


def _glso(args: argparse.Namespace) -> int:
    import dataclasses

    from robocompose.io.errors import InputError

    out = None if args.out is None else check_table_path(Path(args.out))
    checkpoint = None if args.checkpoint is None else check_checkpoint_path(Path(args.checkpoint))

    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.fanout.compute import ComputeConfig
    from robocompose.glso.registry import METHODS
    from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
    from robocompose.params import load_section
    from robocompose.tasks.terrains import get_task

    get_task(args.task)
    if args.method not in METHODS:
        raise InputError(f"--method: unknown method {args.method!r}; expected one of {', '.join(METHODS)}")
    if args.model is not None and METHODS[args.method].variant is None:
        raise InputError(f"--model: method {args.method} does not use a VAE")
    config = load_section(GLSOConfig, "glso", args.params)
    if args.budget is not None:
        if args.budget < 1:
            raise InputError(f"--budget: expected a positive number of objective calls, found {args.budget}")
        config = dataclasses.replace(config, budget=args.budget)
    evaluation = config.evaluator(load_section(EvaluationConfig, "evaluation", args.params))
    compute = load_section(ComputeConfig, "compute", args.params).overridden(args)
    model = None if args.model is None else Path(args.model)
    if model is not None and not model.exists():
        raise InputError(f"--model: {model}: no such file")

    def show(row: dict) -> None:
        print(json.dumps({k: row[k] for k in ("step", "design_id", "rules", "score", "status", "best_so_far")}),
              flush=True)

    spec = RunSpec(args.task, args.method, args.seed)
    if compute.address:
        from robocompose.io import write_table

        with compute.executor() as executor:
            steps = next(executor.imap(_remote_search, [(spec, config, evaluation, checkpoint, model, compute.cache)]))
        for row in steps.to_dict("records"):
            show(row)
        if out is not None:
            write_table(steps, out, "glso_steps")
    else:
        steps = run_search(spec, config, evaluation, on_step=show, checkpoint=checkpoint, table=out, model_path=model,
                           named_checkpoint=True, cache=compute.open_cache())
    from robocompose.glso import best_designs

    found = best_designs(steps)  # the best simulated design: an invalid score is never a result
    best = None if found.empty else found.iloc[0]
    print(json.dumps({"best": None if best is None else {
        "design_id": best.design_id, "rules": list(best.rules), "score": best.score, "status": best.status,
        "step": int(best.step), "parents": list(best.parents), "tokens": list(best.tokens)}}))
    return 0
