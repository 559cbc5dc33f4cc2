"""Fixtures of the GLSO search tests: tiny untrained VAEs and a cheap deterministic objective.

The fake objective stands in for MPPI where a test is about the search algorithm (budget, resumption,
bookkeeping), not physics; one test in test_runs.py goes through the real evaluator at a tiny setting."""

from pathlib import Path

import pandas as pd
import pytest
import torch

from robocompose.glso.runs import GLSOConfig
from robocompose.grammar.tree import DesignTree
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import save_model
from robocompose.params import build_config


def fake_objective(tree) -> dict:
    """A deterministic score that prefers many joints on few links; a quarter of the designs (by id)
    "self-collide" so that the invalid score is exercised."""
    if tree.design_id[-1] in "0123":
        return {"reward": None, "status": "self_collision", "sim_steps": 0, "seconds": 0.0}
    return {"reward": 4.0 + 0.05 * tree.n_joints - 0.01 * tree.n_links, "status": "ok", "sim_steps": 1,
            "seconds": 0.0}


def hand_steps(runs: dict[tuple[str, int], list[tuple[str, float]]]) -> pd.DataFrame:
    """A step table (every `glso_steps` column) of hand-made runs on flat: (method, seed) -> each call's (design
    id, reward), every design simulated; a design the run sent before is a repeat, and best so far as `runs.py`
    records it. Each design id is a one-link tree of its own token (`tree_designs` maps the trees back)."""
    rows, tokens = [], {}
    for (method, seed), calls in runs.items():
        seen, best = set(), float("-inf")
        for step, (design, reward) in enumerate(calls):
            best = max(best, reward)
            rows.append({"task": "flat", "method": method, "seed": seed, "step": step, "design_id": design,
                         "rules": [], "parents": [-1], "tokens": [tokens.setdefault(design, len(tokens))],
                         "latent": [], "score": reward, "reward": reward, "status": "ok", "repeat": design in seen,
                         "rejected": 0, "best_so_far": best})
            seen.add(design)
    return pd.DataFrame(rows)


def tree_designs(steps: pd.DataFrame) -> dict:
    """The design id of each tree of a `hand_steps` table."""
    return {DesignTree(tuple(r.parents), tuple(r.tokens)): r.design_id for r in steps.itertuples()}


@pytest.fixture(scope="session")
def tiny_models(tmp_path_factory) -> str:
    """models/vae_{variant}.pt for the three variants: untrained tiny VAEs (decoding still gives complete designs)."""
    root = tmp_path_factory.mktemp("models")
    for seed, (variant, predictor, constraints) in enumerate(
            [("full", True, "grammar"), ("nopred", False, "grammar"), ("nogram", True, "tree")]):
        torch.manual_seed(seed)
        save_model(GraphVAE(VAEConfig(hidden=8, latent=3, predictor=predictor, constraints=constraints,
                                      max_nodes=20)), root / f"vae_{variant}.pt")
    return str(Path(root) / "vae_{variant}.pt")


@pytest.fixture
def small_config(tiny_models) -> GLSOConfig:
    values = {"tasks": ["flat"], "seeds": [0], "budget": 9, "models": tiny_models, "thesis_models": tiny_models,
              "bo": {"init": 3},
              **{section: {"init": 3} for section in ("bo_nodr", "bo_floor", "bo_reask")},
              "bo_turbo": {"init": 3, "candidates": 256},
              "ga": {"population": 4}, "ghs": {"num_samples": 3, "opt_iter": 2, "eps_end": 0.5, "eps_sample_end": 0.5}}
    return build_config(GLSOConfig, values, "glso")
