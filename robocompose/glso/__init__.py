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


def best_so_far_curves(steps):  # (pd.DataFrame) -> pd.DataFrame
    """Best reward so far after each objective call, over a method's seeds, per (task, method, calls): median,
    interquartile range (the campaign's bands), mean, min and max (the smoke run's, whose 2 seeds have no
    quartiles), and the number of runs."""
    grouped = steps.assign(calls=steps["step"] + 1).groupby(["task", "method", "calls"])["best_so_far"]
    return grouped.agg(median="median", q25=lambda s: s.quantile(0.25), q75=lambda s: s.quantile(0.75),
                       mean="mean", min="min", max="max", runs="size").reset_index()


def draw_curves(ax, stats, task: str, methods, centre: str, low: str, high: str) -> None:
    """One panel of Figs. 8.1/8.2: each method's `centre` curve of `best_so_far_curves` with a `low`-`high` band."""
    for method in methods:
        s = stats[(stats["task"] == task) & (stats["method"] == method)] if len(stats) else stats
        if len(s):
            line, = ax.plot(s["calls"], s[centre], label=LABELS[method])
            ax.fill_between(s["calls"], s[low], s[high], color=line.get_color(), alpha=0.2)
