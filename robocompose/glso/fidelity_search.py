"""Designs found by searches, for the evaluator fidelity set: what a search finds is what the evaluator must rank.

Each of `evaluator_fidelity.search_methods` searches each task at each of `search_rungs` (`search_budget`
objective calls, run seed and controller seed `evaluator_fidelity.seed`, GLSO with `search_init` random
points first); the `search_top` best distinct simulated designs of every search join the design set
(`measured/fidelity/designs.csv`) as kind `search`. Each search's step table is committed under
`measured/fidelity/searches/` as the record of where its designs came from.

    robocompose fidelity-search      # hours: resumable (a checkpoint per search); then adds the designs
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from robocompose.evaluation.evaluate import OK, EvaluationConfig
from robocompose.evaluation.fidelity import DESIGN_COLUMNS, SEARCH, FidelityConfig, rung_config
from robocompose.io import read_table
from robocompose.io.errors import InputError

SEARCHES_DIR = "searches"


def search_path(directory: str | Path, task: str, rung: str, method: str) -> Path:
    return Path(directory) / SEARCHES_DIR / f"{task}__{rung}__{method}.parquet"


def search_specs(config: FidelityConfig) -> list[tuple[str, str, str]]:
    """(task, rung, method) of every search, in the order they run and their designs join the set."""
    return [(task, rung, method) for task in config.tasks for rung in config.search_rungs
            for method in config.search_methods]


def run_searches(config: FidelityConfig, glso: Any, checkpoints: str | Path) -> list[Path]:
    """Run every search whose step table (`search_path`, committed) is missing or short: `glso` (a GLSOConfig,
    the `glso:` section) with budget `search_budget` and GLSO's init `search_init`, run seed `config.seed`, at
    the search's rung with controller seed `config.seed`. Resumable (a checkpoint per search under
    `checkpoints`); the step tables."""
    from robocompose.glso.registry import METHODS
    from robocompose.glso.runs import RunSpec, run_search

    unknown = [m for m in config.search_methods if m not in METHODS]
    if unknown:
        raise InputError(f"evaluator_fidelity.search_methods: unknown method {unknown[0]!r}; "
                         f"expected some of {list(METHODS)}")
    settings = dataclasses.replace(glso, budget=config.search_budget,
                                   bo=dataclasses.replace(glso.bo, init=config.search_init))
    tables = []
    for task, rung, method in tqdm(search_specs(config), desc="fidelity searches", unit="search"):
        table = search_path(config.directory, task, rung, method)
        tables.append(table)
        if table.exists() and len(read_table(table, "glso_steps")) >= config.search_budget:
            continue
        table.parent.mkdir(parents=True, exist_ok=True)
        run_search(RunSpec(task, method, config.seed), settings,
                   EvaluationConfig(mppi=rung_config(rung), seed=config.seed),
                   checkpoint=Path(checkpoints) / f"{table.stem}.ckpt", table=table)
    return tables


def add_search_designs(config: FidelityConfig, designs: pd.DataFrame) -> pd.DataFrame:
    """`designs` with the `search_top` best distinct simulated designs of every search added (kind `search`,
    `screen_reward` = the search's reward at its rung): best designs of every search first, then the second
    best, so that a partial measurement spans the searches. A design of the base set is not added, nor one
    added before (so a second call adds nothing); a search whose step table is missing is an InputError (run
    `search` first)."""
    picks: list[list[dict]] = []
    for task, rung, method in search_specs(config):
        path = search_path(config.directory, task, rung, method)
        if not path.exists():
            raise InputError(f"{path}: search step table not found (run `robocompose fidelity-search`)")
        steps = read_table(path, "glso_steps")
        ok = steps[(steps["status"] == OK) & (steps["rules"].map(len) > 0)]
        best = ok.sort_values(["reward", "step"], ascending=[False, True], kind="stable").drop_duplicates("design_id")
        picks.append([{"name": f"search_{task}_{method}_{rung}_{rank}", "kind": SEARCH, "design_id": row.design_id,
                       "rules": ",".join(str(int(r)) for r in row.rules), "screen_reward": float(row.reward)}
                      for rank, row in enumerate(best.itertuples())])
    known, added = set(designs.loc[designs["kind"] != SEARCH, "design_id"]), []
    for _rank in range(config.search_top):  # each search's best first, then its second best, ...
        for search in picks:
            fresh = [pick for pick in search if pick["design_id"] not in known]
            if fresh:
                added.append(fresh[0])
                known.add(fresh[0]["design_id"])
    added = [pick for pick in added if pick["design_id"] not in set(designs["design_id"])]  # added before
    if not added:
        return designs
    return pd.concat([designs, pd.DataFrame(added, columns=list(DESIGN_COLUMNS))], ignore_index=True)
