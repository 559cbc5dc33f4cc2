"""The GLSO campaign (thesis 8, Figs. 8.1 and 8.2 at a budget that can test the thesis): every (task, method,
seed) run of `budget` objective calls at the campaign's evaluator rung, each run's final best re-scored at the
thesis setting with controller seeds the search never used, and the statistics a reviewer asks for.

    robocompose glso-campaign run [--address tcp://SCHEDULER:8786]   # hours: resumable, a table per finished run
    robocompose glso-campaign summarise                              # the statistics (stage glso_campaign)

Runs: GLSO's loop as the thesis's (`init` random points, then BO steps), the GA at the thesis's population,
every method under the accounting rule of `runs.py`. A finished run's step table is written to
`<directory>/<task>_<method>_seed<k>.parquet` (committed, so that a campaign of many core-hours is
summarised by the default pipeline and survives the machine); a run in progress lives in its checkpoint under
`checkpoints` and resumes there. Runs go seed-major (every method's seed 0 first), so a partial campaign
already compares every method. Each finished run's best simulated design is then re-scored at the thesis
setting once per `rescore_seeds` into `<directory>/rescores.csv` (one appended line per score), and
`<directory>/campaign.json` records the evaluator every run used (rung and settings hash per task: a campaign
does not mix evaluators). The directory holds nothing else: it is the summarising stage's one dependency.

Statistics (`summarise`), per task, on two axes. A call that sends a design the run sent before (a repeat) is
served from the cache: a call all the same, but no new design, and methods differ widely in how many calls they
spend so. So best so far is measured against distinct designs evaluated (the primary axis) beside objective
calls (the thesis's): best-so-far curves on both axes as median and interquartile range over seeds; the
distinct designs each run evaluated; the best so far at K distinct designs, K the fewest any run of the task
reached (so every run has a value: the matched comparison, at the search rung, as re-scores exist only for the
final bests); the final best at the search rung and re-scored (mean over the re-score seeds; NaN when a
re-score cannot be simulated). On each of the matched, final and re-scored bests: one-sided Mann-Whitney U of
GLSO > each other method, Holm-corrected within a family (the baselines of Fig. 8.1; the ablations of Fig.
8.2); the median difference GLSO - method with a percentile bootstrap 95% interval. With n seeds per side the
smallest one-sided p is 1 / C(n + m, n) (5 vs 5: 0.004; 3 vs 5: 0.018), so small campaigns cannot reach
significance after correction; the summary says so.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robocompose.evaluation.evaluate import OK, EvaluationConfig, evaluate, objective
from robocompose.evaluation.fidelity import THESIS, append_row, read_rows, rung_config
from robocompose.evaluation.manifest import claim_directory, read_manifest
from robocompose.fanout.cache import EvaluationCache
from robocompose.glso import GROUPS, best_designs, best_so_far_curves, draw_curves, group_titles
from robocompose.glso.registry import METHODS, describe, family
from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
from robocompose.grammar.tree import DesignTree
from robocompose.io import read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import InputError, check_field, check_number
from robocompose.search.significance import holm
from robocompose.tasks.terrains import TASKS

RESCORE_COLUMNS = ("task", "method", "seed", "design_id", "rescore_seed", "reward", "status", "objective")
RESCORES_FILE = "rescores.csv"
CACHE_FILE = "eval_cache.parquet"  # under `checkpoints`: not committed, it only saves time
RUN = ["task", "method", "seed"]  # the columns that name a run in step and summary tables
# The two axes of best so far: what a point counts (title, axis label); summaries key their curves by them.
AXES = {"calls": ("call", "objective calls"), "distinct": ("distinct design", "distinct designs evaluated")}


@dataclass(frozen=True)
class CampaignConfig:
    """The `glso_campaign:` section of params.yaml."""

    directory: str = "measured/glso_campaign"  # finished runs and re-scores (committed measurements)
    checkpoints: str = "data/glso_campaign"  # runs in progress (not committed)
    tasks: list[str] = field(default_factory=lambda: ["flat"])  # ridged after flat if time allows
    seeds: dict[str, int] = field(default_factory=lambda: {  # run seeds per method: 0 .. n-1
        "glso": 5, "random": 5, "mcts": 5, "ghs": 5, "ga": 5, "glso_nopred": 3, "glso_nogram": 3})
    budget: int = 200  # objective calls per run
    init: int = 50  # GLSO's random initial points, then budget - init BO steps (the thesis's loop)
    population: int = 50  # the GA's (thesis)
    ghs_eps_end: float = 0.1  # GHS's rule- and sample-epsilon ends (the original's; the default profile's smoke
    #                           run uses 0.5 because over 16 calls 0.1 sends its greedy rollouts to the depth limit)
    rung: str = ""  # the fidelity rung of the runs; "" = the one `evaluator_fidelity` chose by the search rule
    rescore_seeds: list[int] = field(default_factory=lambda: [101, 102])  # controller seeds of the re-scores ...
    rescore_rung: str = THESIS  # ... at this fidelity rung (the thesis setting)
    run: bool = False  # stage: False summarises the committed runs; True first runs what is missing
    bootstrap: int = 2000  # resamples of each median-difference interval
    alpha: float = 0.05

    def __post_init__(self) -> None:
        check_field(bool(self.tasks), "tasks", f"at least one task of {list(TASKS)}", self.tasks)
        unknown = [t for t in self.tasks if t not in TASKS]
        check_field(not unknown, "tasks", f"tasks of {list(TASKS)}", unknown[:1])
        unknown = [m for m in self.seeds if m not in METHODS]
        check_field(not unknown, "seeds", f"methods of {list(METHODS)}", unknown[:1])
        for method, seeds in self.seeds.items():
            check_field(isinstance(seeds, int) and not isinstance(seeds, bool) and seeds >= 0, f"seeds.{method}",
                        "an integer >= 0 (run seeds 0 .. n-1)", seeds)
        check_field(self.budget > self.init >= 1, "init", f"1 .. budget - 1 = {self.budget - 1}", self.init)
        check_field(0.0 <= self.ghs_eps_end <= 1.0, "ghs_eps_end", "a probability in [0, 1]", self.ghs_eps_end)
        check_field(bool(self.rescore_seeds), "rescore_seeds", "at least one controller seed", self.rescore_seeds)
        check_field(min(self.rescore_seeds) >= 0, "rescore_seeds", "controller seeds >= 0", self.rescore_seeds)
        check_field(self.population >= 2, "population", "an integer >= 2 (the GA's)", self.population)
        check_field(self.bootstrap >= 1, "bootstrap", "an integer >= 1 (resamples per interval)", self.bootstrap)
        check_number(self.alpha, "alpha", 0.0, 1.0, "()")
        for rung in filter(None, (self.rung, self.rescore_rung)):
            rung_config(rung)


def campaign_rung(config: CampaignConfig, choice_file: str | Path = "reports/metrics/evaluator_fidelity.json") -> str:
    """The rung the runs use: `config.rung`, else the fidelity stage's choice, which must be the search rule's
    (a provisional choice would make the campaign a smoke run)."""
    if config.rung:
        return config.rung
    path = Path(choice_file)
    if not path.exists():
        raise InputError(f"{path}: not found; run `dvc repro evaluator_fidelity` or set glso_campaign.rung")
    choice = read_json(path)
    if choice.get("rule") != "search" or not choice.get("rung"):
        raise InputError(f"{path}: the evaluator rung is not chosen by the search rule yet ({choice.get('reason')}); "
                         "measure the search-found designs first (README, evaluator fidelity) or set "
                         "glso_campaign.rung to run a labelled trial")
    return choice["rung"]


def run_specs(config: CampaignConfig) -> list[RunSpec]:
    """Every run, seed-major: all methods' seed 0 first, so a partial campaign compares every method."""
    most = max(config.seeds.values())
    return [RunSpec(task, method, seed) for task in config.tasks for seed in range(most)
            for method in METHODS if seed < config.seeds.get(method, 0)]


def run_path(config: CampaignConfig, spec: RunSpec) -> Path:
    return Path(config.directory) / f"{spec.name}.parquet"


def search_config(config: CampaignConfig, glso: GLSOConfig) -> GLSOConfig:
    """The `glso:` settings with the campaign's budget, GLSO init, GA population and GHS epsilon ends, and no
    `glso.rung` (the smoke run's): the campaign's jobs carry the evaluator at the campaign's own rung."""
    return dataclasses.replace(glso, budget=config.budget, rung="", bo=dataclasses.replace(glso.bo, init=config.init),
                               ga=dataclasses.replace(glso.ga, population=config.population),
                               ghs=dataclasses.replace(glso.ghs, eps_end=config.ghs_eps_end,
                                                       eps_sample_end=config.ghs_eps_end))


@dataclass(frozen=True)
class CampaignJob:
    """One run and its re-scores, as a picklable work item."""

    spec: RunSpec
    glso: GLSOConfig
    evaluation: EvaluationConfig
    table: str
    checkpoint: str
    cache: str  # the evaluation cache file every run of the campaign shares


def campaign_jobs(config: CampaignConfig, glso: GLSOConfig, evaluation: EvaluationConfig,
                  rung: str) -> list[CampaignJob]:
    """Every run of the campaign as a job, in `run_specs` order; `evaluation` gives the settings besides MPPI,
    the runs use `rung`'s MPPI. The directory's manifest records that evaluator (written by the first call): runs
    of one campaign are comparable only if they all used it, so another rung, other settings or other simulation
    code is an InputError that names both."""
    settings = search_config(config, glso)
    at_rung = dataclasses.replace(evaluation, mppi=rung_config(rung))
    hashes = {task: at_rung.settings_hash(task) for task in config.tasks}
    claim_directory(config.directory, {"rung": rung, "settings_hash": hashes})
    checkpoints = Path(config.checkpoints)
    return [CampaignJob(spec, settings, at_rung, str(run_path(config, spec)), str(checkpoints / f"{spec.name}.ckpt"),
                        str(checkpoints / CACHE_FILE)) for spec in run_specs(config)]


def run_job(job: CampaignJob) -> str:
    """Run (or resume) one search; its step table appears at `job.table` only once complete.

    Runs share one evaluation cache: a design that another run (of any method or seed) already sent to the
    evaluator at the same settings costs this run its call but no simulation (evaluations are deterministic,
    so the table is the same with an empty cache). A progress bar on stderr counts the run's calls (a resumed
    run jumps to its checkpoint's count at its first new call)."""
    from tqdm import tqdm

    table = Path(job.table)
    partial = Path(job.checkpoint).with_suffix(".parquet")
    Path(job.checkpoint).parent.mkdir(parents=True, exist_ok=True)
    with tqdm(total=job.glso.budget, desc=job.spec.name, unit="call", leave=False) as bar:
        steps = run_search(job.spec, job.glso, job.evaluation, checkpoint=Path(job.checkpoint), table=partial,
                           cache=EvaluationCache(job.cache), on_step=lambda row: bar.update(row["step"] + 1 - bar.n))
    write_table(steps, table, "glso_steps")
    partial.unlink(missing_ok=True)
    return str(table)


def best_design(steps: pd.DataFrame) -> pd.Series | None:
    """A run's best simulated design (the first of equal rewards), or None if nothing was simulated."""
    best = best_designs(steps)
    return None if best.empty else best.iloc[0]


def read_rescores(directory: str | Path) -> pd.DataFrame:
    """Every complete re-score row (a line cut off by a crash mid-write is ignored); a score recorded twice (two
    workers re-scored one run at once) keeps one row, two different ones are an ArtifactError."""
    rows = read_rows(Path(directory) / RESCORES_FILE, RESCORE_COLUMNS, key=RESCORE_COLUMNS[:3] + ("rescore_seed",),
                     results=("design_id", "reward", "status", "objective"))
    table = pd.DataFrame(rows, columns=list(RESCORE_COLUMNS))
    for column in ("seed", "rescore_seed"):
        table[column] = table[column].astype(int)
    for column in ("reward", "objective"):  # an empty reward is a result without one (not ok)
        table[column] = pd.to_numeric(table[column].replace("", np.nan))
    return table


def rescore(config: CampaignConfig, steps: pd.DataFrame, spec: RunSpec) -> int:
    """Re-score a finished run's best simulated design at `rescore_rung` (the thesis setting), once per
    re-score seed not yet recorded; the number of new scores."""
    directory = Path(config.directory)
    best = best_design(steps)
    if best is None:
        return 0
    done = read_rescores(directory)
    done = done[(done["task"] == spec.task) & (done["method"] == spec.method) & (done["seed"] == spec.seed)]
    tree = DesignTree(tuple(best["parents"]), tuple(best["tokens"]))
    added = 0
    for seed in config.rescore_seeds:
        if seed in set(done["rescore_seed"]):
            continue
        row = evaluate(tree, spec.task, EvaluationConfig(mppi=rung_config(config.rescore_rung), seed=seed), seed)
        append_row(directory / RESCORES_FILE, RESCORE_COLUMNS,
                   {"task": spec.task, "method": spec.method, "seed": spec.seed, "design_id": best["design_id"],
                    "rescore_seed": seed, "reward": row["reward"], "status": row["status"],
                    "objective": objective(row)})
        added += 1
    return added


def run_campaign(config: CampaignConfig, glso: GLSOConfig, evaluation: EvaluationConfig, rung: str,
                 executor: Any = None) -> list[Path]:
    """Run every run whose table is missing (fanned out over `executor`), then re-score every finished run;
    the finished tables. `evaluation` gives the settings besides MPPI; the runs use `rung`'s MPPI."""
    from tqdm import tqdm

    from robocompose.fanout.executor import Executor

    for method in config.seeds:
        path = glso.model_path(method)
        if path is not None and not path.exists():
            raise InputError(f"{path}: the VAE of method {method} is missing (dvc repro train_vae)")
    specs = run_specs(config)
    jobs = [job for job in campaign_jobs(config, glso, evaluation, rung) if not Path(job.table).exists()]
    executor = executor or Executor(workers=1)
    list(tqdm(executor.imap(run_job, jobs), total=len(jobs), desc="campaign runs", unit="run"))
    finished = [spec for spec in specs if run_path(config, spec).exists()]
    for spec in tqdm(finished, desc="re-scores", unit="run"):
        rescore(config, read_table(run_path(config, spec), "glso_steps"), spec)
    return [run_path(config, spec) for spec in finished]


def read_runs(config: CampaignConfig) -> pd.DataFrame:
    """Every finished run's steps (the committed tables)."""
    tables = [read_table(run_path(config, s), "glso_steps") for s in run_specs(config) if run_path(config, s).exists()]
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def bootstrap_median_difference(a: np.ndarray, b: np.ndarray, n: int, rng: np.random.Generator) -> tuple:
    """median(a) - median(b) and its percentile bootstrap 95% interval (each side resampled on its own)."""
    diffs = [np.median(rng.choice(a, len(a))) - np.median(rng.choice(b, len(b))) for _ in range(n)]
    return float(np.median(a) - np.median(b)), float(np.percentile(diffs, 2.5)), float(np.percentile(diffs, 97.5))


def by_distinct_designs(steps: pd.DataFrame) -> pd.DataFrame:
    """Each run's calls that sent a design new to the run (`repeat` False), numbered `distinct` = 1, 2, ... in
    call order: the row numbered k holds the run's best so far after k distinct designs. A repeat returns the
    score its design already had, so it cannot raise the best: this is the run's best so far against calls with
    the repeats dropped."""
    new = steps[~steps["repeat"].astype(bool)].sort_values("step", kind="stable")
    return new.assign(distinct=new.groupby(RUN, sort=False).cumcount() + 1)


def distinct_curves(steps: pd.DataFrame) -> pd.DataFrame:
    """Best so far against distinct designs evaluated over a method's seeds (`best_so_far_curves` on the axis
    "distinct"), up to the fewest distinct designs any of its runs evaluated: past that the median would be over
    fewer seeds, the ones that repeated least, where every point of the calls curve counts every run."""
    curves = best_so_far_curves(by_distinct_designs(steps), "distinct")
    return curves[curves["runs"] == curves.groupby(["task", "method"])["runs"].transform("max")]


def final_bests(steps: pd.DataFrame, rescores: pd.DataFrame) -> pd.DataFrame:
    """One row per run: its final best at the search rung (`search`, and that design's `design_id`), its
    re-scored best (mean over re-score seeds; NaN if a re-score could not be simulated or is missing), its
    spend (`calls`; `distinct`: the designs it evaluated, its calls less its repeats), and the matched
    comparison's point: `k`, the fewest distinct designs any run of its task evaluated, its best so far after
    k distinct designs (`matched`) and the calls that took it (`calls_at_k`)."""
    runs = steps.sort_values("step", kind="stable").groupby(RUN, sort=False)
    final = runs.agg(search=("best_so_far", "last"), calls=("step", "size")).reset_index()
    best = [best_design(group) for _, group in runs]
    final.insert(4, "design_id", ["" if b is None else b["design_id"] for b in best])
    new = by_distinct_designs(steps)
    final = final.merge(new.groupby(RUN)["distinct"].max().reset_index(), on=RUN)
    final["k"] = final.groupby("task")["distinct"].transform("min")
    at_k = new.merge(final[[*RUN, "k"]], on=RUN).query("distinct == k")
    at_k = at_k.assign(matched=at_k["best_so_far"], calls_at_k=at_k["step"] + 1)
    final = final.merge(at_k[[*RUN, "matched", "calls_at_k"]], on=RUN)
    if len(rescores):
        scored = rescores.assign(reward=np.where(rescores["status"] == OK, rescores["reward"], np.nan))
        mean = scored.groupby(RUN)["reward"].agg(lambda r: r.mean(skipna=False))
        final = final.merge(mean.rename("rescored").reset_index(), on=RUN, how="left")
    else:
        final["rescored"] = np.nan
    return final


def spend(final: pd.DataFrame) -> pd.DataFrame:
    """Per task and method (in the order of `final`), what its runs spent, median over them: objective calls,
    distinct designs (with their interquartile range) and the calls that reached the task's `k` distinct
    designs."""
    runs = final.groupby(["task", "method"], sort=False)
    return runs.agg(runs=("seed", "size"), calls=("calls", "median"), distinct=("distinct", "median"),
                    distinct_q25=("distinct", lambda d: d.quantile(0.25)),
                    distinct_q75=("distinct", lambda d: d.quantile(0.75)), k=("k", "first"),
                    calls_at_k=("calls_at_k", "median")).reset_index()


def compare(final: pd.DataFrame, column: str, bootstrap: int, alpha: float, seed: int = 0) -> list[dict]:
    """GLSO against each other method on `column`, per task: one-sided Mann-Whitney U (GLSO greater),
    Holm-adjusted within its family, the median difference with a bootstrap 95% interval."""
    from scipy.stats import mannwhitneyu

    rng = np.random.default_rng(seed)
    rows = []
    for task, group in final.groupby("task", sort=False):
        glso = group.loc[group["method"] == "glso", column].dropna().to_numpy()
        for name in GROUPS:
            raw, found = {}, {}
            for method in family(name):
                other = group.loc[group["method"] == method, column].dropna().to_numpy()
                if len(glso) and len(other):
                    raw[method] = float(mannwhitneyu(glso, other, alternative="greater").pvalue)
                    found[method] = other
            floors = {m: 1 / math.comb(len(glso) + len(found[m]), len(glso)) for m in raw}  # all GLSO above all
            # With every method at its floor the family's largest Holm-adjusted p is as small as the seed counts
            # allow: at or above alpha, no outcome of this campaign can show the family's claim.
            holm_floor = max(holm(floors).values(), default=1.0)
            for method, p_holm in holm(raw).items():
                other = found[method]
                diff, low, high = bootstrap_median_difference(glso, other, bootstrap, rng)
                rows.append({"task": task, "on": column, "family": name,
                             "method": method, "n_glso": len(glso), "n_other": len(other), "p": raw[method],
                             "p_holm": p_holm, "p_floor": floors[method], "holm_floor": holm_floor,
                             "median_difference": diff, "ci_low": low, "ci_high": high,
                             "glso_better": bool(p_holm < alpha)})
    return rows


def summarise(config: CampaignConfig) -> dict:
    """The campaign's statistics from the committed runs and re-scores (see the module docstring)."""
    if not Path(config.directory).is_dir():  # a typo would report 0 runs
        raise InputError(f"{config.directory}: not a directory (glso_campaign.directory: expected the folder of "
                         "the committed runs)")
    steps = read_runs(config)
    planned = len(run_specs(config))
    if steps.empty:
        return {"runs": 0, "planned": planned, "finals": [], "spend": [], "k": {}, "tests": [],
                "curves": {axis: [] for axis in AXES}, "methods": describe()}
    return {"planned": planned, "rung": read_manifest(config.directory).get("rung", ""),
            **statistics(steps, read_rescores(config.directory), config)}


def statistics(steps: pd.DataFrame, rescores: pd.DataFrame, config: CampaignConfig) -> dict:
    """The summary's statistics of the runs `steps` (at least one) and their `rescores`: everything but the
    plan and the rung, which `summarise` reads from the campaign's directory."""
    final = final_bests(steps, rescores)
    tests = (compare(final, "matched", config.bootstrap, config.alpha, seed=2)
             + compare(final, "search", config.bootstrap, config.alpha)
             + compare(final, "rescored", config.bootstrap, config.alpha, seed=1))
    curves = {"calls": best_so_far_curves(steps), "distinct": distinct_curves(steps)}
    return {"runs": int(len(final)), "budget": int(steps["step"].max() + 1),
            "rescore_seeds": list(config.rescore_seeds), "alpha": config.alpha, "finals": final.to_dict("records"),
            "spend": spend(final).to_dict("records"), "k": final.groupby("task", sort=False)["k"].first().to_dict(),
            "tests": tests, "curves": {axis: table[["task", "method", axis, "median", "q25", "q75", "runs"]]
                                       .to_dict("records") for axis, table in curves.items()},
            "methods": describe()}


def plot(summary: dict, path: str | Path) -> Path:
    """Figs. 8.1 and 8.2 of the campaign, each task on both axes (against objective calls, the thesis's, and
    against distinct designs evaluated, where the dotted line is the matched comparison's K): median best so far
    over seeds, band = interquartile range. A method's distinct-design curve ends at its shortest run."""
    import matplotlib.pyplot as plt

    curves = {axis: pd.DataFrame(records) for axis, records in summary["curves"].items()}
    tasks = list(dict.fromkeys(curves["calls"]["task"])) if len(curves["calls"]) else ["flat"]
    panels = [(task, axis) for task in tasks for axis in AXES]
    fig, axes = plt.subplots(len(GROUPS), len(panels), figsize=(4.5 * len(panels), 3.2 * len(GROUPS)),
                             squeeze=False)
    for row, (group, title) in enumerate(GROUPS.items()):
        for ax, (task, axis) in zip(axes[row], panels, strict=True):
            draw_curves(ax, curves[axis], task, group_titles(summary["methods"], group), "median", "q25", "q75",
                        axis)
            if axis == "distinct" and task in summary["k"]:
                ax.axvline(summary["k"][task], color="grey", linestyle=":", label=f"K = {summary['k'][task]}")
            unit, label = AXES[axis]
            ax.set_title(f"{title}: {task}, per {unit}")
            ax.set_xlabel(label)
            ax.set_ylabel("best reward so far")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
