"""`robocompose glso`: one search run (task, method, seed) with a budget of objective calls; a JSON line per step."""

from __future__ import annotations

import argparse
import json

from robocompose.arguments import dask_address
from robocompose.glso import LATENT_METHODS, METHODS


def register(subparsers: argparse._SubParsersAction) -> None:
    glso = subparsers.add_parser("glso", help="search a task for the best design with one method; JSON per step")
    glso.add_argument("--task", default="flat", help="flat, frozen_lake, ridged or wall")
    glso.add_argument("--method", default="glso", help=f"one of {', '.join(METHODS)}")
    glso.add_argument("--budget", type=int, default=None, help="objective calls (default: glso.budget)")
    glso.add_argument("--seed", type=int, default=0, help="run seed")
    glso.add_argument("--model", default=None, help="the VAE of a latent method (default: glso.models)")
    glso.add_argument("--params", default="params.yaml", help="params file (sections glso, evaluation, compute)")
    glso.add_argument("--checkpoint", default=None, help="resume from / save to this checkpoint file")
    glso.add_argument("--out", default=None, help="write the step table (parquet) here")
    glso.add_argument("--address", type=dask_address, default=None,
                      help="run the search on a worker of this Dask scheduler (tcp://host:8786; default: params' "
                           "compute.address; \"\" = here); its lines print when it finishes")
    glso.set_defaults(handler=_glso)


def _remote_search(job: tuple) -> object:
    """One search run on a Dask worker (module level, so that it pickles): its step table."""
    from robocompose.fanout.cache import EvaluationCache
    from robocompose.glso.runs import run_search

    spec, config, evaluation, checkpoint, model, cache = job
    return run_search(spec, config, evaluation, checkpoint=checkpoint, model_path=model,
                      cache=EvaluationCache(cache or None))


def _glso(args: argparse.Namespace) -> int:
    import dataclasses
    from pathlib import Path

    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.fanout.compute import ComputeConfig
    from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
    from robocompose.io.errors import InputError
    from robocompose.params import load_section
    from robocompose.tasks.terrains import get_task

    get_task(args.task)
    if args.method not in METHODS:
        raise InputError(f"--method: unknown method {args.method!r}; expected one of {', '.join(METHODS)}")
    if args.model is not None and args.method not in LATENT_METHODS:
        raise InputError(f"--model: method {args.method} does not use a VAE")
    config = load_section(GLSOConfig, "glso", args.params)
    if args.budget is not None:
        if args.budget < 1:
            raise InputError(f"--budget: expected a positive number of objective calls, found {args.budget}")
        config = dataclasses.replace(config, budget=args.budget)
    evaluation = load_section(EvaluationConfig, "evaluation", args.params)
    compute = load_section(ComputeConfig, "compute", args.params).overridden(args)
    model = None if args.model is None else Path(args.model)
    if model is not None and not model.exists():
        raise InputError(f"--model: {model}: no such file")

    def show(row: dict) -> None:
        print(json.dumps({k: row[k] for k in ("step", "design_id", "rules", "score", "status", "best_so_far")}),
              flush=True)

    spec = RunSpec(args.task, args.method, args.seed)
    checkpoint = None if args.checkpoint is None else Path(args.checkpoint)
    if compute.address:
        from robocompose.io import write_table

        with compute.executor() as executor:
            steps = next(executor.imap(_remote_search, [(spec, config, evaluation, checkpoint, model, compute.cache)]))
        for row in steps.to_dict("records"):
            show(row)
        if args.out is not None:
            write_table(steps, Path(args.out), "glso_steps")
    else:
        steps = run_search(spec, config, evaluation, on_step=show, checkpoint=checkpoint,
                           table=None if args.out is None else Path(args.out), model_path=model,
                           cache=compute.open_cache())
    best = steps.loc[steps["score"].idxmax()]
    print(json.dumps({"best": {"design_id": best.design_id, "rules": list(best.rules), "score": best.score,
                               "status": best.status, "step": int(best.step), "parents": list(best.parents),
                               "tokens": list(best.tokens)}}))
    return 0
