import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robocompose.evaluation import fidelity
from robocompose.evaluation.fidelity import FidelityConfig
from robocompose.glso import fidelity_search as search_designs


def _set(n: int) -> pd.DataFrame:
    return pd.DataFrame({"name": [f"d{i}" for i in range(n)], "kind": ["random"] * n,
                         "design_id": [f"id{i}" for i in range(n)], "rules": [""] * n, "screen_reward": np.nan})


def _search_table(path: Path, rows: list[tuple[str, str, float, list[int]]]) -> None:
    from robocompose.io import write_table

    frame = pd.DataFrame([{"step": i, "method": "random", "task": "flat", "seed": 0, "design_id": design_id,
                           "rules": rules, "parents": [-1], "tokens": [0], "latent": [], "score": reward,
                           "reward": reward if status == "ok" else None, "status": status, "repeat": False,
                           "rejected": 0, "best_so_far": reward}
                          for i, (design_id, status, reward, rules) in enumerate(rows)])
    path.parent.mkdir(parents=True, exist_ok=True)
    write_table(frame, path, "glso_steps")


def test_search_designs_join_the_set_best_first_across_searches(tmp_path):
    config = FidelityConfig(directory=str(tmp_path), tasks=["flat"], search_methods=["random", "mcts"],
                            search_rungs=["s8_h8_e48"], search_top=2)
    with pytest.raises(ValueError, match="search step table not found"):
        search_designs.add_search_designs(config, _set(1))
    _search_table(search_designs.search_path(tmp_path, "flat", "s8_h8_e48", "random"),
                  [("a", "ok", 4.0, [0, 1]), ("b", "ok", 5.0, [0, 2]), ("b", "ok", 5.0, [0, 2]),
                   ("x", "invalid", 9.0, [0, 3]), ("n", "ok", 8.0, []), ("c", "ok", 4.5, [0, 4])])
    _search_table(search_designs.search_path(tmp_path, "flat", "s8_h8_e48", "mcts"),
                  [("b", "ok", 5.5, [0, 2]), ("id0", "ok", 6.0, [0, 5]), ("d", "ok", 5.2, [0, 6])])
    table = search_designs.add_search_designs(config, _set(1))  # id0 is in the set already
    added = table[table["kind"] == "search"]
    # each search's best first (random: b; mcts: b is taken, id0 known, so d), then their second best (a)
    assert list(added["design_id"]) == ["b", "d", "c"]
    assert list(added["name"]) == ["search_flat_random_s8_h8_e48_0", "search_flat_mcts_s8_h8_e48_2",
                                   "search_flat_random_s8_h8_e48_1"]
    assert list(added["rules"]) == ["0,2", "0,6", "0,4"] and list(added["screen_reward"]) == [5.0, 5.2, 4.5]
    assert search_designs.add_search_designs(config, table).equals(table)  # run again: nothing new


def test_searches_run_once_and_their_tables_resume(tmp_path, monkeypatch):
    """A tiny random search and MCTS at a tiny rung: complete tables are not run again."""
    from robocompose.glso import runs
    from robocompose.glso.runs import GLSOConfig

    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    config = FidelityConfig(directory=str(tmp_path), tasks=["flat"], rungs=["tiny"], search_methods=["random", "mcts"],
                            search_rungs=["tiny"], search_budget=2, search_top=1)
    tables = search_designs.run_searches(config, GLSOConfig(), tmp_path / "checkpoints")
    from robocompose.io import read_table

    assert [len(read_table(t, "glso_steps")) for t in tables] == [2, 2]
    monkeypatch.setattr(runs, "run_search", lambda *a, **k: pytest.fail("a complete search ran again"))
    search_designs.run_searches(config, GLSOConfig(), tmp_path / "checkpoints")
    with pytest.raises(ValueError, match="search_methods: unknown method 'nosuch'"):
        search_designs.run_searches(dataclasses.replace(config, search_methods=["nosuch"]), GLSOConfig(), tmp_path)
