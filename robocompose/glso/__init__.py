"""The GLSO experiment on grammar designs (thesis 8): latent BO on the three VAEs against random search, a graph
GA, MCTS and GHS, all on one objective and one budget. A method implements `method.SearchMethod` and is named
in `registry.METHODS`; runs become step tables (`runs.py`); `robocompose glso` runs one."""

FIG_8_1 = ("random", "ga", "mcts", "ghs", "glso")  # the thesis's comparison with baselines
FIG_8_2 = ("glso", "glso_nopred", "glso_nogram")  # the thesis's ablations
LABELS = {"glso": "GLSO", "glso_nopred": "GLSO_nopred", "glso_nogram": "GLSO_nogram", "random": "Random",
          "ga": "GA", "mcts": "MCTS", "ghs": "GHS"}  # method -> the thesis's legend name


def best_designs(steps):  # (pd.DataFrame) -> pd.DataFrame; no pandas import here: the CLI imports this package
    """The best-scoring simulated row of each task of a step table (the first found wins ties)."""
    ok = steps[steps["status"] == "ok"]
    return ok.loc[ok.groupby("task", sort=False)["score"].idxmax()]
