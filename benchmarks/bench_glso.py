"""Benchmark: what a GLSO search step costs besides its evaluation, against one evaluation measured in this run.

glso.suggest_seconds: mean BO overhead per step of a GLSO run at the default budget (bayes_opt suggest or
    random point, register, domain reduction, greedy decoding with the default profile's VAE size,
    untrained), on a synthetic objective so that only the optimiser is timed.
glso.evaluation_seconds: one default-profile evaluation of RoboGrammar's flat design on flat (one core), the
    mean of one before and one after the methods (the machine's load drifts).
glso.suggest_share: suggest_seconds / evaluation_seconds (target < 0.05).
glso.ghs_step_seconds: mean GHS overhead per step (16-sample rollouts through the heuristic + 25 Adam steps).
glso.ghs_share: ghs_step_seconds / evaluation_seconds.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import torch
from threadpoolctl import threadpool_limits

from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
from robocompose.glso.bo import LatentBO
from robocompose.glso.ghs import GraphHeuristicSearch
from robocompose.glso.method import SearchEnv
from robocompose.glso.runs import GLSOConfig
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.params import load_section, read_params


def _method_seconds(method, env: SearchEnv, budget: int, score) -> float:
    total = 0.0
    for _ in range(budget):
        started = time.perf_counter()
        proposal = method.propose(env)
        method.tell(proposal, score(proposal))
        total += time.perf_counter() - started
    return total / budget


def run() -> dict[str, float]:
    torch.set_num_threads(1)
    threadpool_limits(1)
    config = load_section(GLSOConfig, "glso")
    model_settings = {k: v for k, v in read_params()["train_vae"]["model"].items()
                      if k in {f.name for f in dataclasses.fields(VAEConfig)}}
    torch.manual_seed(0)
    env = SearchEnv("flat", GraphVAE(VAEConfig(**model_settings)).eval())

    def synthetic(proposal) -> float:  # a smooth landscape over latent points (BO), link counts (GHS)
        if proposal.z is None:
            return 4.0 + 0.01 * proposal.tree.n_links
        return 4.0 + float(np.sin(proposal.z[:3]).sum())

    tree = derive(parse_rules(REFERENCE_DESIGNS["robogrammar_flat"])).tree
    evaluation_config = load_section(EvaluationConfig, "evaluation")
    before = evaluate(tree, "flat", evaluation_config, seed=0)["seconds"]
    bo = _method_seconds(LatentBO(config.bo, 0, config.budget, env), env, config.budget, synthetic)
    ghs = _method_seconds(GraphHeuristicSearch(config.ghs, 0, config.budget, env), env, config.budget, synthetic)
    evaluation = (before + evaluate(tree, "flat", evaluation_config, seed=0)["seconds"]) / 2  # around the methods
    return {"glso.suggest_seconds": bo, "glso.evaluation_seconds": evaluation, "glso.suggest_share": bo / evaluation,
            "glso.ghs_step_seconds": ghs, "glso.ghs_share": ghs / evaluation}
