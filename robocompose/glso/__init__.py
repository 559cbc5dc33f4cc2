"""The GLSO experiment on grammar designs (thesis 8): latent BO on the three VAEs against random search, a graph
GA, MCTS and GHS, all on one objective and one budget. A method implements `method.SearchMethod` and is named
in `registry.METHODS`; runs become step tables (`runs.py`); `robocompose glso` runs one."""

REFERENCE = "glso"  # the method under test: every claim compares it with the others of a figure group
GROUPS = {"baselines": "Fig. 8.1", "ablations": "Fig. 8.2"}  # a method's figure group -> the thesis's figure


def group_titles(methods: list[dict], group: str | None = None) -> dict[str, str]:
    """Method -> title, in registry order, of the methods of figure group `group` (None: all), from the record of
    the registry a stage wrote (`registry.describe`): the report reads methods there, not from the registry."""
    return {m["name"]: m["title"] for m in methods if group is None or group in m["groups"]}


def best_designs(steps):  # (pd.DataFrame) -> pd.DataFrame; no pandas import here: the CLI imports this package
    """The best-scoring simulated row of each task of a step table (the first found wins ties)."""
    ok = steps[steps["status"] == "ok"]
    return ok.loc[ok.groupby("task", sort=False)["score"].idxmax()]


def best_so_far_curves(steps, axis: str = "calls"):  # (pd.DataFrame, str) -> pd.DataFrame
    """Best reward so far over a method's seeds at each point of `axis`, per (task, method, axis): median,
    interquartile range (the campaign's bands), mean, min and max (the smoke run's, whose 2 seeds have no
    quartiles), and the number of runs. `axis` "calls" counts objective calls (step + 1); any other axis is a
    column of `steps` (the campaign's "distinct": designs new to the run)."""
    if axis == "calls":
        steps = steps.assign(calls=steps["step"] + 1)
    grouped = steps.groupby(["task", "method", axis])["best_so_far"]
    return grouped.agg(median="median", q25=lambda s: s.quantile(0.25), q75=lambda s: s.quantile(0.75),
                       mean="mean", min="min", max="max", runs="size").reset_index()


def draw_curves(ax, stats, task: str, titles: dict[str, str], centre: str, low: str, high: str,
                axis: str = "calls") -> None:
    """One panel of Figs. 8.1/8.2: each method's (`titles`: method -> legend name, in legend order) `centre` curve
    of `best_so_far_curves` on `axis` with a `low`-`high` band."""
    for method, title in titles.items():
        s = stats[(stats["task"] == task) & (stats["method"] == method)] if len(stats) else stats
        if len(s):
            line, = ax.plot(s[axis], s[centre], label=title)
            ax.fill_between(s[axis], s[low], s[high], color=line.get_color(), alpha=0.2)
