"""The GLSO campaign (thesis 8, Figs. 8.1 and 8.2 at a budget that can test the thesis): every (task, method,
seed) run of `budget` objective calls at the campaign's evaluator rung, each run's final best re-scored at the
thesis setting with controller seeds the search never used, and the statistics a reviewer asks for.

    robocompose glso-campaign run [--address tcp://SCHEDULER:8786]       # hours: resumable, a table per finished run
    robocompose glso-campaign heldout [--address tcp://SCHEDULER:8786]   # the held-out pieces only (resumable)
    robocompose glso-campaign summarise                                  # the statistics (stage glso_campaign)

Runs: GLSO's loop as the thesis's (`init` random points, then BO steps), the GA at the thesis's population, every
method under the accounting rule of `runs.py`. A finished run's step table is written to
`<directory>/<task>_<method>_seed<k>.parquet` (committed, so that a campaign of many core-hours is summarised by the
default pipeline and survives the machine); a run in progress lives in its checkpoint under `checkpoints` (its step
rows as plain JSON, keyed by settings and code, not by the machine under the pinned dispatch: a folder to commit, so
a campaign of many sessions resumes a run on the next machine where it stopped) and resumes there; the checkpoint is
removed once the run's table is written. Runs go seed-major (every method's seed 0 first), so a partial campaign
already compares every method. Each finished run's best simulated design is then re-scored at the thesis setting
once per `rescore_seeds` into `<directory>/rescores.csv` (one appended line per score), and
`<directory>/campaign.json` records the evaluator every run used (rung and settings hash per task: a campaign does
not mix evaluators).

Held-out scoring. A run scores every call once, with one controller seed (`evaluation.seed`), and its best is
the maximum over those noisy scores: inflated by the winner's curse (the seed-to-seed sd at the campaign rung,
~0.10, exceeds the gaps between methods). So each finished run's `heldout_top` best distinct designs by search
score (`top_designs`: rank 1 is the run's best; equal scores rank by first call) are re-measured at the runs'
rung (the manifest's) with each of `heldout_seeds`, controller seeds no run searched with and no re-score uses
(the config refuses an overlap with `rescore_seeds`, the measurement one with `evaluation.seed`): one line per
(run, design, seed) in `<directory>/heldout.csv`, appended as each evaluation finishes, so a killed measurement
resumes where it stopped. A run's held-out best is the design of the highest held-out mean (`heldout_bests`;
once all its pieces are there, NaN before), re-scored at the thesis setting like the search best (rescores.csv
lines are per run and design). `run` measures the pieces after the runs; `heldout` measures only them. The
directory holds nothing else: it is the summarising stage's one dependency.

Statistics (`summarise`), per task, on two axes. A call that sends a design the run sent before (a repeat) is
served from the cache: a call all the same, but no new design, and methods differ widely in how many calls they
spend so. So best so far is measured against distinct designs evaluated (the primary axis) beside objective
calls (the thesis's): best-so-far curves on both axes as median and interquartile range over seeds; the
distinct designs each run evaluated; the best so far at K distinct designs, K the fewest any run of the task
reached (so every run has a value: the matched comparison, at the search rung, as re-scores exist only for the
final bests); the final best at the search rung and re-scored (mean over the re-score seeds; NaN when a
re-score cannot be simulated); per run, the held-out mean of its search best, the inflation (search best less
that) and the held-out best, per method the median inflation beside the evaluator's seed-to-seed sd on the
measured designs. On each of the matched, final, re-scored and held-out bests: one-sided Mann-Whitney U of
GLSO > each other method, Holm-corrected within a family (the baselines of Fig. 8.1; the ablations of Fig.
8.2); the median difference GLSO - method with a percentile bootstrap 95% interval; beside them the
Kruskal-Wallis omnibus test over GLSO and the baselines (`omnibus`). GLSO's arms with runs
(`challengers`: the thesis-protocol arm `glso_thesis`, the improved GLSO the pilot picks, that GLSO on the
thesis-scale VAE) are tested the same way against the baselines, and an arm with ablations of its own (the
thesis-scale GLSO_nopred) against those, each family apart. A thesis-scale VAE is searched only once it has passed
its gate (`check_thesis_gate`). With n seeds per side the
smallest one-sided p is 1 / C(n + m, n) (5 vs 5: 0.004; 3 vs 5: 0.018), so small campaigns cannot reach
significance after correction; the summary says so.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robocompose.evaluation.evaluate import OK, EvaluationConfig, evaluate, objective
from robocompose.evaluation.fidelity import THESIS, append_row, read_rows, rung_config
from robocompose.evaluation.manifest import MANIFEST_FILE, claim_directory, read_manifest, record_reproduction
from robocompose.fanout.cache import EvaluationCache
from robocompose.glso import GROUPS, REFERENCE, best_designs, best_so_far_curves, draw_curves, group_titles
from robocompose.glso.registry import METHODS, describe, family, settings_sections
from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
from robocompose.grammar.tree import DesignTree
from robocompose.io import read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import InputError, check_field, check_number
from robocompose.latent import thesis_scale
from robocompose.search.significance import holm
from robocompose.tasks.terrains import TASKS

RESCORE_COLUMNS = ("task", "method", "seed", "design_id", "rescore_seed", "reward", "status", "objective")
RESCORES_FILE = "rescores.csv"
# A held-out line: a design of a run's top `heldout_top` (`rank` 1 = the run's best) at one held-out seed
HELDOUT_COLUMNS = ("task", "method", "seed", "rank", "design_id", "heldout_seed", "reward", "status", "objective")
HELDOUT_FILE = "heldout.csv"
LOGS = {RESCORES_FILE: (RESCORE_COLUMNS, "rescore_seed"), HELDOUT_FILE: (HELDOUT_COLUMNS, "heldout_seed")}
# At the campaign rung one controller seed's noise (sd ~0.10) exceeds the gaps between a run's top designs; a
# mean over 4 seeds halves it
MIN_HELDOUT_SEEDS = 4
RUN = ["task", "method", "seed"]  # the columns that name a run in step and summary tables
# The two axes of best so far: what a point counts (title, axis label); summaries key their curves by them.
AXES = {"calls": ("call", "objective calls"), "distinct": ("distinct design", "distinct designs evaluated")}
# The columns of `heldout_bests` the statistics test, in the report's order: the best so far at K distinct designs,
# the final best at the search rung (the reported one), re-scored at the thesis setting, the held-out best
COMPARED = ("matched", "search", "rescored", "heldout")


@dataclass(frozen=True)
class CampaignConfig:
    """The `glso_campaign:` section of params.yaml."""

    directory: str = "measured/glso_campaign"  # finished runs and re-scores (committed measurements)
    checkpoints: str = "measured/glso_campaign_progress"  # runs in progress, one checkpoint each (committed)
    cache: str = "data/glso_campaign/eval_cache.parquet"  # every run's evaluations (not committed: saves time)
    tasks: list[str] = field(default_factory=lambda: ["flat"])  # ridged after flat if time allows
    seeds: dict[str, int] = field(default_factory=lambda: {  # run seeds per method: 0 .. n-1
        "glso": 5, "random": 10, "mcts": 5, "ghs": 5, "ga": 5, "glso_nopred": 3, "glso_nogram": 3, "glso_thesis": 5,
        "glso_turbo": 10})
    budget: int = 200  # objective calls per run
    init: int = 50  # GLSO's random initial points, then budget - init BO steps (the thesis's loop)
    population: int = 50  # the GA's (thesis)
    ghs_eps_end: float = 0.1  # GHS's rule- and sample-epsilon ends (the original's; the default profile's smoke
    #                           run uses 0.5 because over 16 calls 0.1 sends its greedy rollouts to the depth limit)
    rung: str = ""  # the fidelity rung of the runs; "" = the one `evaluator_fidelity` chose by the search rule
    rescore_seeds: list[int] = field(default_factory=lambda: [101, 102])  # controller seeds of the re-scores ...
    rescore_rung: str = THESIS  # ... at this fidelity rung (the thesis setting)
    heldout_seeds: list[int] = field(default_factory=lambda: [201, 202, 203, 204])  # controller seeds that
    #                          re-measure at the runs' own rung ...
    heldout_top: int = 3  # ... each run's this many best distinct designs by search score
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
        check_field(min(self.rescore_seeds, default=0) >= 0, "rescore_seeds",
                    "controller seeds >= 0 ([] = no thesis re-scores: the pilot's)", self.rescore_seeds)
        check_field(len(set(self.heldout_seeds)) == len(self.heldout_seeds) >= MIN_HELDOUT_SEEDS, "heldout_seeds",
                    f"at least {MIN_HELDOUT_SEEDS} distinct controller seeds", self.heldout_seeds)
        check_field(min(self.heldout_seeds) >= 0, "heldout_seeds", "controller seeds >= 0", self.heldout_seeds)
        check_field(not set(self.heldout_seeds) & set(self.rescore_seeds), "heldout_seeds",
                    f"controller seeds disjoint from rescore_seeds {self.rescore_seeds}", self.heldout_seeds)
        check_field(self.heldout_top >= 1, "heldout_top", "an integer >= 1 (designs per run)", self.heldout_top)
        check_field(self.population >= 2, "population", "an integer >= 2 (the GA's)", self.population)
        check_field(self.bootstrap >= 1, "bootstrap", "an integer >= 1 (resamples per interval)", self.bootstrap)
        check_number(self.alpha, "alpha", 0.0, 1.0, "()")
        for rung in filter(None, (self.rung, self.rescore_rung)):
            rung_config(rung)


GATE_FILE = "reports/metrics/vae_landscape.json"  # stage vae_landscape's gate of the thesis-scale VAE


def check_thesis_gate(config: CampaignConfig, glso: GLSOConfig, rung: str, gate_file: str | Path = GATE_FILE) -> None:
    """Refuse (one line, before any run) to search a thesis-scale VAE (issue 42, item 6) unless stage
    vae_landscape gated this very file of GLSO's (full) thesis-scale VAE and it passed on every task of the
    campaign at `rung`; nothing to check when no planned run searches one."""
    methods = [m for m, seeds in config.seeds.items() if seeds and METHODS[m].thesis_vae]
    if not methods:
        return
    for method in methods:
        if not glso.model_path(method).exists():
            raise InputError(f"{glso.model_path(method)}: the thesis-scale VAE of method {method} is missing "
                             "(robocompose glso-campaign vae, with its variant in vae_thesis.variants)")
    path, gated = Path(gate_file), Path(glso.thesis_models.format(variant="full"))
    if not path.exists():
        raise InputError(f"{path}: not found; the thesis-scale VAE is gated by stage vae_landscape before a "
                         "campaign searches it (dvc repro vae_landscape)")
    metrics = read_json(path)
    sha = metrics.get("thesis_scale", {}).get("trained", {}).get("full", {}).get("sha256")
    if sha != hashlib.sha256(gated.read_bytes()).hexdigest():
        raise InputError(f"{path}: thesis_scale.trained.full.sha256: {sha!r} is not the SHA-256 of {gated}; "
                         "expected the gate of this model (dvc repro vae_landscape)")
    for task in config.tasks:
        key = f"{thesis_scale.VARIANT}/{task}/{rung}"
        row = metrics["gate"].get(key)
        if row is None or not row["passes"]:
            found = "no gate" if row is None else (
                f"margin {row['margin']:+.3f} (needs >= {row['gate_margin']:g}), "
                f"window {row['window_distinct']:g} (needs >= {row['gate_distinct']})")
            raise InputError(f"{path}: gate.{key}: {found}; expected a passed gate before a campaign searches the "
                             f"thesis-scale VAE (methods {', '.join(methods)})")


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
    """The `glso:` settings with the campaign's budget, GLSO init (on every section with an `init`: GLSO, its
    variants and the trust-region BO), GA population and GHS epsilon ends, and no `glso.rung` (the smoke run's): the
    campaign's jobs carry the evaluator at the campaign's own rung."""
    latent = {section: dataclasses.replace(getattr(glso, section), init=config.init)
              for section, cls in settings_sections().items() if "init" in {f.name for f in dataclasses.fields(cls)}}
    return dataclasses.replace(glso, budget=config.budget, rung="", **latent,
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
                        config.cache) for spec in run_specs(config)]


def run_job(job: CampaignJob) -> str:
    """Run (or resume) one search; its step table appears at `job.table` only once complete, and then its
    checkpoint goes (the checkpoints folder holds only runs in progress).

    Runs share one evaluation cache: a design that another run (of any method or seed) already sent to the
    evaluator at the same settings costs this run its call but no simulation (evaluations are deterministic,
    so the table is the same with an empty cache). A progress bar on stderr counts the run's calls (a resumed
    run jumps to its checkpoint's count at its first new call)."""
    from tqdm import tqdm

    table = Path(job.table)
    partial = Path(job.cache).parent / f"{job.spec.name}.parquet"  # the steps so far, to look at (not committed)
    for folder in (Path(job.checkpoint).parent, partial.parent):
        folder.mkdir(parents=True, exist_ok=True)
    with tqdm(total=job.glso.budget, desc=job.spec.name, unit="call", leave=False) as bar:
        steps = run_search(job.spec, job.glso, job.evaluation, checkpoint=Path(job.checkpoint), table=partial,
                           cache=EvaluationCache(job.cache), on_step=lambda row: bar.update(row["step"] + 1 - bar.n))
    write_table(steps, table, "glso_steps")
    partial.unlink(missing_ok=True)
    Path(job.checkpoint).unlink(missing_ok=True)
    return str(table)


def best_design(steps: pd.DataFrame) -> pd.Series | None:
    """A run's best simulated design (the first of equal rewards), or None if nothing was simulated."""
    best = best_designs(steps)
    return None if best.empty else best.iloc[0]


def top_designs(steps: pd.DataFrame, top: int) -> pd.DataFrame:
    """Each run's `top` best distinct simulated designs by the score the run saw (one step row each, the call
    that scored it highest: every call of a design scores the same unless the run draws a controller seed per
    call, the thesis protocol), `rank` 1 (the run's best: `best_design`'s) to `top`, equal scores ranked by first
    call; runs in the order of `steps`."""
    ok = (steps[steps["status"] == OK].sort_values(["score", "step"], ascending=[False, True], kind="stable")
          .drop_duplicates([*RUN, "design_id"]))
    ok = ok.assign(run_order=ok.groupby(RUN, sort=False).ngroup())
    ranked = (ok.sort_values(["run_order", "score", "step"], ascending=[True, False, True])
              .groupby(RUN, sort=False).head(top))
    return ranked.assign(rank=ranked.groupby(RUN, sort=False).cumcount() + 1).drop(columns="run_order")


def read_scores(directory: str | Path, log: str) -> pd.DataFrame:
    """Every complete line of the score log `log` (`RESCORES_FILE`, `HELDOUT_FILE`) of `directory` (a line cut off
    by a crash mid-write is ignored); a score recorded twice (two workers measured one piece at once) keeps one
    row, two different ones are an ArtifactError."""
    columns, seed = LOGS[log]
    key = (*RUN, "design_id", seed)
    rows = read_rows(Path(directory) / log, columns, key=key, results=[c for c in columns if c not in key])
    table = pd.DataFrame(rows, columns=list(columns))
    for column in [c for c in ("seed", seed, "rank") if c in columns]:
        table[column] = table[column].astype(int)
    for column in ("reward", "objective"):  # an empty reward is a result without one (not ok)
        table[column] = pd.to_numeric(table[column].replace("", np.nan))
    return table


@dataclass(frozen=True)
class ScoreJob:
    """One evaluation of a committed run's design at one controller seed (`evaluation.seed`) as a picklable work
    item, and the line of the score log `log` it becomes (`line`: the line's columns besides the result)."""

    tree: DesignTree
    task: str
    evaluation: EvaluationConfig
    log: str
    line: dict


def score_job(job: ScoreJob) -> dict:
    """The log line of `job`, evaluated (module level, so that it pickles to a worker)."""
    row = evaluate(job.tree, job.task, job.evaluation, job.evaluation.seed)
    return {**job.line, "reward": row["reward"], "status": row["status"], "objective": objective(row)}


def score_jobs(config: CampaignConfig, designs: pd.DataFrame, seeds: list[int], evaluation: EvaluationConfig,
               log: str, columns: tuple[str, ...] = ()) -> list[ScoreJob]:
    """Each of `designs` (rows of runs' step tables, with `columns`: the log's further columns) at each of
    `seeds` with `evaluation`'s settings, but for the lines `log` already holds."""
    seed_column = LOGS[log][1]
    key = [*RUN, "design_id"]
    done = set(read_scores(config.directory, log)[[*key, seed_column]].itertuples(index=False, name=None))
    jobs = []
    for design in designs.to_dict("records"):
        tree = DesignTree(tuple(design["parents"]), tuple(design["tokens"]))
        line = {column: design[column] for column in (*key, *columns)}
        jobs += [ScoreJob(tree, design["task"], dataclasses.replace(evaluation, seed=seed), log,
                          {**line, seed_column: seed})
                 for seed in seeds if (*(line[c] for c in key), seed) not in done]
    return jobs


def measure(config: CampaignConfig, jobs: list[ScoreJob], executor: Any, desc: str) -> int:
    """Evaluate `jobs` over `executor`, each line appended to its log as its evaluation finishes, by this process
    (so a Dask worker needs no share of the directory, and a killed measurement loses only the evaluations in
    flight); the number of lines appended."""
    from tqdm import tqdm

    from robocompose.fanout.executor import Executor

    executor = executor or Executor(workers=1)
    for index, line in tqdm(executor.as_completed(score_job, jobs), total=len(jobs), desc=desc, unit="evaluation"):
        log = jobs[index].log
        append_row(Path(config.directory) / log, LOGS[log][0], line)
    return len(jobs)


def rescore(config: CampaignConfig, designs: pd.DataFrame, executor: Any = None) -> int:
    """Re-score `designs` (rows of runs' step tables) at `rescore_rung` (the thesis setting), once per re-score
    seed not yet recorded for the run's design; the number of new scores."""
    thesis = EvaluationConfig(mppi=rung_config(config.rescore_rung))
    return measure(config, score_jobs(config, designs, config.rescore_seeds, thesis, RESCORES_FILE), executor,
                   "thesis re-scores")


def check_heldout_seeds(config: CampaignConfig, selection_seed: int) -> None:
    """An InputError if a held-out seed is `selection_seed`, the controller seed the runs selected their designs
    with (`evaluation.seed`; the config itself refuses one of its `rescore_seeds`)."""
    check_field(selection_seed not in config.heldout_seeds, "glso_campaign.heldout_seeds",
                f"controller seeds other than evaluation.seed = {selection_seed}, the one the runs searched with",
                config.heldout_seeds)


def measure_heldout(config: CampaignConfig, evaluation: EvaluationConfig, executor: Any = None) -> dict[str, int]:
    """Measure what the held-out protocol lacks for the committed runs (resumable, lines already logged are
    skipped): each run's `heldout_top` designs (`top_designs`) at every held-out seed, at the rung of the runs'
    manifest, then the thesis-setting re-scores of each complete run's held-out best. `evaluation` gives the
    settings besides MPPI and the runs' controller seed. The numbers of new held-out scores and re-scores."""
    check_heldout_seeds(config, evaluation.seed)
    steps = read_runs(config)
    if steps.empty:
        return {"heldout": 0, "rescores": 0}
    rung = read_manifest(config.directory).get("rung")
    if not rung:
        raise InputError(f"{Path(config.directory) / MANIFEST_FILE}: missing; the committed runs do not say their rung")
    at_rung = dataclasses.replace(evaluation, mppi=rung_config(rung))
    # The runs' evaluator or an InputError: a held-out score of other simulation code is no score of the run's rung
    claim_directory(config.directory, {"rung": rung, "settings_hash": {
        task: at_rung.settings_hash(task) for task in dict.fromkeys(steps["task"])}})
    top = top_designs(steps, config.heldout_top)
    jobs = score_jobs(config, top, config.heldout_seeds, at_rung, HELDOUT_FILE, ("rank",))
    new = measure(config, jobs, executor, "held-out scores")
    scored = heldout_scores(top, read_scores(config.directory, HELDOUT_FILE), config.heldout_seeds)
    return {"heldout": new, "rescores": rescore(config, scored[scored["pick"]], executor)}


def verify_evaluator(config: CampaignConfig, evaluation: EvaluationConfig, per_method: int = 1,
                     executor: Any = None) -> dict[str, list[str]]:
    """Prove that today's code is the committed runs' evaluator although its settings hash differs (the hash
    covers the simulation code's definitions, so a refactor that moves no number changes it): re-simulate the
    first `per_method` simulated designs of each method's first run on each task, at the runs' rung and
    controller seed. If every reward equals the committed one bit for bit, the manifest records today's hash as
    reproducing them (`record_reproduction`) and held-out scoring and further runs may go on; otherwise an
    InputError names the designs that differ. Task -> the designs re-simulated."""
    from robocompose.fanout.executor import Executor

    steps = read_runs(config)
    rung = read_manifest(config.directory).get("rung")
    if steps.empty or not rung:
        raise InputError(f"{Path(config.directory) / MANIFEST_FILE}: no committed runs to verify the evaluator on")
    at_rung = dataclasses.replace(evaluation, mppi=rung_config(rung))
    simulated = steps[~steps["repeat"] & (steps["status"] == OK)].sort_values([*RUN, "step"], kind="stable")
    first_run = simulated[simulated["seed"] == simulated.groupby(["task", "method"])["seed"].transform("min")]
    picks = first_run.groupby(["task", "method"], sort=False).head(per_method).to_dict("records")
    jobs = [ScoreJob(DesignTree(tuple(p["parents"]), tuple(p["tokens"])), p["task"], at_rung, "",
                     {"design_id": p["design_id"]}) for p in picks]
    executor = executor or Executor(workers=1)
    again = {index: line["reward"] for index, line in executor.as_completed(score_job, jobs)}
    differ = [f"{p['task']}_{p['method']}_seed{p['seed']} {p['design_id']}: {p['reward']!r} then, {again[i]!r} now"
              for i, p in enumerate(picks) if again[i] != p["reward"]]
    if differ:
        raise InputError(f"{Path(config.directory) / MANIFEST_FILE}: today's evaluator does not reproduce the "
                         f"committed runs ({'; '.join(differ)}): a new campaign, not a continued one")
    checked: dict[str, list[str]] = {}
    for p in picks:
        checked.setdefault(p["task"], []).append(p["design_id"])
    for task, designs in checked.items():
        record_reproduction(config.directory, task, at_rung.settings_hash(task), designs)
    return checked


def run_campaign(config: CampaignConfig, glso: GLSOConfig, evaluation: EvaluationConfig, rung: str,
                 executor: Any = None) -> list[Path]:
    """Run every run whose table is missing (fanned out over `executor`), then re-score every finished run's best
    and measure its held-out pieces (`measure_heldout`); the finished tables. `evaluation` gives the settings
    besides MPPI; the runs use `rung`'s MPPI."""
    from tqdm import tqdm

    from robocompose.fanout.executor import Executor

    check_heldout_seeds(config, evaluation.seed)  # before hours of runs
    check_thesis_gate(config, glso, rung)
    for method in (m for m, seeds in config.seeds.items() if seeds):
        path = glso.model_path(method)
        if path is not None and not path.exists():
            raise InputError(f"{path}: the VAE of method {method} is missing (dvc repro train_vae)")
    specs = run_specs(config)
    jobs = [job for job in campaign_jobs(config, glso, evaluation, rung) if not Path(job.table).exists()]
    executor = executor or Executor(workers=1)
    list(tqdm(executor.imap(run_job, jobs), total=len(jobs), desc="campaign runs", unit="run"))
    steps = read_runs(config)
    if len(steps):
        rescore(config, top_designs(steps, 1), executor)
        measure_heldout(config, evaluation, executor)
    return [run_path(config, spec) for spec in specs if run_path(config, spec).exists()]


PILOT_RUNG = "s8_h8_e48"  # the ladder's cheapest rung: a pilot compares GLSO's variants with one another
PILOT_SEEDS = 3
# What the improved GLSO must reach (issue 42): distinct designs per 200 objective calls, median over its runs
DISTINCT_TARGET = 150


def pilot_config(config: CampaignConfig) -> CampaignConfig:
    """The pilot of GLSO's variants (issue 42, item 3): GLSO and every registered method that searches its VAE
    at the campaign's fixed controller seed (`variant` "full": no domain reduction, the wider floor, re-asking),
    `PILOT_SEEDS` seeds each, run exactly as the campaign runs them (budget, init, accounting) but at
    `PILOT_RUNG`, held-out scored the same way, with no thesis re-scores; in its own folder beside the
    campaign's (`glso_pilot`), committed the same way, its runs in progress in `checkpoints`/pilot (the evaluation
    cache is shared: it is keyed by the evaluator's settings). (The thesis-protocol arm is no fix, and the thesis-scale
    VAE another VAE: neither is piloted.)"""
    seeds = {name: PILOT_SEEDS for name, method in METHODS.items()
             if method.variant == "full" and not method.fresh_seeds and not method.thesis_vae}
    return dataclasses.replace(config, directory=str(Path(config.directory).parent / "glso_pilot"),
                               checkpoints=str(Path(config.checkpoints) / "pilot"), seeds=seeds,
                               rung=PILOT_RUNG, rescore_seeds=[])


def pilot_table(summary: dict, budget: int) -> pd.DataFrame:
    """Per method of a pilot's summary: its finished runs and the medians over them of the distinct designs
    evaluated, the search best (at the pilot rung, the winner's curse included), the best at K distinct designs,
    the held-out mean of the search best and the held-out best; `reaches`: its median distinct designs reach
    `DISTINCT_TARGET` per 200 of the `budget` calls. Order: the variants that reach the target first (a fix for
    the collapse must stop it: a variant that still burns its calls on repeats is no improved GLSO however its
    few designs score), then the best held-out best, then more distinct designs. The first row goes on to the
    campaign rung. (The rule was fixed before any pilot run had held-out scores.)"""
    finals = pd.DataFrame(summary.get("finals", []))
    if finals.empty:
        return pd.DataFrame(columns=["method", "runs", "distinct", "search", "matched", "reported_heldout",
                                     "heldout", "reaches"])
    table = finals.groupby("method", sort=False).agg(
        runs=("seed", "size"), distinct=("distinct", "median"), search=("search", "median"),
        matched=("matched", "median"), reported_heldout=("reported_heldout", "median"),
        heldout=("heldout", "median")).reset_index()
    table["reaches"] = table["distinct"] >= DISTINCT_TARGET * budget / 200
    return table.sort_values(["reaches", "heldout", "distinct"], ascending=False, kind="stable").reset_index(
        drop=True)


def pilot_summary(config: CampaignConfig) -> dict | None:
    """The pilot of `config`'s campaign (`pilot_config`) as the stage records it, None while its folder does not
    exist: its rung, budget, runs finished of those planned, held-out progress and `pilot_table`'s rows."""
    pilot = pilot_config(config)
    if not Path(pilot.directory).is_dir():
        return None
    summary = summarise(pilot)
    return {"directory": pilot.directory, "rung": pilot.rung, "budget": pilot.budget,
            "distinct_target": DISTINCT_TARGET, "runs": summary["runs"],
            "planned": summary["planned"], "heldout_progress": summary.get("heldout_progress"),
            "methods": pilot_table(summary, pilot.budget).to_dict("records")}


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


def seed_means(scores: pd.DataFrame, seed: str) -> pd.DataFrame:
    """Per run and design of a score log (`read_scores`; `seed` names its controller seed column): the `mean` and
    `sd` of its rewards over the seeds (NaN if one could not be simulated: such a design has no result) and the
    number of seeds `measured`."""
    rewards = scores.assign(reward=np.where(scores["status"] == OK, scores["reward"], np.nan))
    return rewards.groupby([*RUN, "design_id"]).agg(
        mean=("reward", lambda r: r.mean(skipna=False)), sd=("reward", lambda r: r.std(skipna=False)),
        measured=(seed, "nunique")).reset_index()


def pooled_sd(sds: pd.Series) -> float:
    """The root mean square of the standard deviations `sds` (NaN ignored): the evaluator's seed-to-seed sd over
    designs measured at equally many seeds."""
    return float(np.sqrt((sds ** 2).mean()))


def final_bests(steps: pd.DataFrame, rescores: pd.DataFrame) -> pd.DataFrame:
    """One row per run: its final best at the search rung (`search`, and that design's `design_id`), its
    re-scored best (mean over the re-score lines of that run and design; NaN if one could not be simulated or
    there are none), its spend (`calls`; `distinct`: the designs it evaluated, its calls less its repeats), and
    the matched comparison's point: `k`, the fewest distinct designs any run of its task evaluated, its best so
    far after k distinct designs (`matched`) and the calls that took it (`calls_at_k`)."""
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
    rescored = seed_means(rescores, "rescore_seed").rename(columns={"mean": "rescored"})
    return final.merge(rescored[[*RUN, "design_id", "rescored"]], on=[*RUN, "design_id"], how="left")


def heldout_scores(top: pd.DataFrame, heldout: pd.DataFrame, seeds: list[int]) -> pd.DataFrame:
    """`top` (`top_designs`) with each design's held-out `mean` and `sd` over `seeds` (`seed_means` of the held-out
    log; lines of other seeds left out), the seeds `measured`, whether its run is `complete` (every design at every
    seed) and whether it is the run's `pick`, its held-out best: of a complete run, the design of the highest
    held-out mean (of equal means the better rank)."""
    means = seed_means(heldout[heldout["heldout_seed"].isin(seeds)], "heldout_seed")
    scored = top.reset_index(drop=True).merge(means, on=[*RUN, "design_id"], how="left")
    scored["measured"] = scored["measured"].fillna(0).astype(int)
    scored["complete"] = scored.groupby(RUN)["measured"].transform("min") == len(seeds)
    picks = (scored[scored["complete"]].dropna(subset=["mean"]).sort_values(["mean", "rank"], ascending=[False, True])
             .groupby(RUN).head(1))
    return scored.assign(pick=scored.index.isin(picks.index))


def heldout_bests(final: pd.DataFrame, steps: pd.DataFrame, heldout: pd.DataFrame, rescores: pd.DataFrame,
                  config: CampaignConfig) -> pd.DataFrame:
    """`final` (`final_bests` of `steps`) with each run's held-out protocol: whether its pieces (`heldout` lines of
    its top designs) are `heldout_complete` (`heldout_measured` of `heldout_planned` evaluations; a run that
    simulated nothing has none to measure) and, once they are (NaN before): the held-out mean of its search best
    (`reported_heldout`) and its `inflation` (search best less that), the evaluator's seed-to-seed sd on its top
    designs (`seed_sd`, pooled), its held-out best (`heldout_design`, of rank `heldout_rank`; `heldout` and
    `heldout_sd`: its mean and sd over the held-out seeds) and that design's thesis re-score (`heldout_rescored`:
    the mean over its `heldout_rescores` re-score lines)."""
    scored = heldout_scores(top_designs(steps, config.heldout_top), heldout, config.heldout_seeds)
    runs = scored.assign(sd=scored["sd"].where(scored["complete"])).groupby(RUN, sort=False)
    progress = runs.agg(heldout_complete=("complete", "first"), heldout_measured=("measured", "sum"),
                        heldout_planned=("rank", "size"), seed_sd=("sd", pooled_sd)).reset_index()
    progress["heldout_planned"] *= len(config.heldout_seeds)
    reported = scored[(scored["rank"] == 1) & scored["complete"]]
    reported = reported.assign(reported_heldout=reported["mean"], inflation=reported["score"] - reported["mean"])
    picks = scored[scored["pick"]].rename(columns={"design_id": "heldout_design", "rank": "heldout_rank",
                                                   "mean": "heldout", "sd": "heldout_sd"})
    rescored = seed_means(rescores, "rescore_seed").rename(columns={
        "design_id": "heldout_design", "mean": "heldout_rescored", "measured": "heldout_rescores"})
    final = (final.merge(progress, on=RUN, how="left")
             .merge(reported[[*RUN, "reported_heldout", "inflation"]], on=RUN, how="left")
             .merge(picks[[*RUN, "heldout_design", "heldout_rank", "heldout", "heldout_sd"]], on=RUN, how="left")
             .merge(rescored[[*RUN, "heldout_design", "heldout_rescored", "heldout_rescores"]],
                    on=[*RUN, "heldout_design"], how="left"))
    final = final.fillna({"heldout_complete": True, "heldout_measured": 0, "heldout_planned": 0,
                          "heldout_design": "", "heldout_rescores": 0})
    return final.astype({"heldout_complete": bool, "heldout_measured": int, "heldout_planned": int,
                         "heldout_rescores": int})


def heldout_summary(final: pd.DataFrame) -> pd.DataFrame:
    """Per task and method (in the order of `final`: `heldout_bests`): its runs, those with their held-out
    pieces `complete`, and over these the median `inflation` and the evaluator's seed-to-seed sd on their top
    designs (`seed_sd`, pooled)."""
    runs = final.groupby(["task", "method"], sort=False)
    return runs.agg(runs=("seed", "size"), complete=("heldout_complete", "sum"), inflation=("inflation", "median"),
                    seed_sd=("seed_sd", pooled_sd)).reset_index()


def spend(final: pd.DataFrame) -> pd.DataFrame:
    """Per task and method (in the order of `final`), what its runs spent, median over them: objective calls,
    distinct designs (with their interquartile range) and the calls that reached the task's `k` distinct
    designs."""
    runs = final.groupby(["task", "method"], sort=False)
    return runs.agg(runs=("seed", "size"), calls=("calls", "median"), distinct=("distinct", "median"),
                    distinct_q25=("distinct", lambda d: d.quantile(0.25)),
                    distinct_q75=("distinct", lambda d: d.quantile(0.75)), k=("k", "first"),
                    calls_at_k=("calls_at_k", "median")).reset_index()


def challengers(final: pd.DataFrame) -> list[str]:
    """The methods whose claim the campaign tests, in registry order: GLSO, then each of its arms that has runs
    in `final` (a registered method searching GLSO's VAE in no figure group: the thesis-protocol arm, the
    improved GLSO the pilot picked)."""
    ran = set(final["method"])
    return [REFERENCE, *(name for name, method in METHODS.items() if name in ran and name != REFERENCE
                         and method.variant == METHODS[REFERENCE].variant and not method.groups)]


def compare(final: pd.DataFrame, column: str, bootstrap: int, alpha: float, seed: int = 0,
            reference: str = REFERENCE) -> list[dict]:
    """`reference` (GLSO or one of its arms) against each other method of a figure group on `column`, per task:
    one-sided Mann-Whitney U (`reference` greater), Holm-adjusted within its family, the median difference
    reference - method with a bootstrap 95% interval. GLSO meets both families; an arm, the baselines and its own
    ablations (`registry.family`)."""
    from scipy.stats import mannwhitneyu

    rng = np.random.default_rng(seed)
    rows = []
    for task, group in final.groupby("task", sort=False):
        ours = group.loc[group["method"] == reference, column].dropna().to_numpy()
        for name in GROUPS:
            raw, found = {}, {}
            for method in family(name, reference):
                other = group.loc[group["method"] == method, column].dropna().to_numpy()
                if len(ours) and len(other):
                    raw[method] = float(mannwhitneyu(ours, other, alternative="greater").pvalue)
                    found[method] = other
            floors = {m: 1 / math.comb(len(ours) + len(found[m]), len(ours)) for m in raw}  # all ours above all
            # With every method at its floor the family's largest Holm-adjusted p is as small as the seed counts
            # allow: at or above alpha, no outcome of this campaign can show the family's claim.
            holm_floor = max(holm(floors).values(), default=1.0)
            for method, p_holm in holm(raw).items():
                other = found[method]
                diff, low, high = bootstrap_median_difference(ours, other, bootstrap, rng)
                rows.append({"task": task, "on": column, "reference": reference, "family": name,
                             "method": method, "n_reference": len(ours), "n_other": len(other), "p": raw[method],
                             "p_holm": p_holm, "p_floor": floors[method], "holm_floor": holm_floor,
                             "median_difference": diff, "ci_low": low, "ci_high": high,
                             "better": bool(p_holm < alpha)})
    return rows


def omnibus(final: pd.DataFrame, column: str) -> list[dict]:
    """Per task, the Kruskal-Wallis test of `column` over GLSO and the baselines of Fig. 8.1 (the methods with
    values there, at least two): are any of them distinguishable at all? Beside the pairwise tests, which ask
    whether GLSO is better than each."""
    from scipy.stats import kruskal

    rows = []
    for task, group in final.groupby("task", sort=False):
        samples = {m: group.loc[group["method"] == m, column].dropna().to_numpy()
                   for m in (REFERENCE, *family("baselines"))}
        samples = {m: v for m, v in samples.items() if len(v)}
        if len(samples) < 2 or len(set(np.concatenate(list(samples.values())))) < 2:  # no ranks to compare
            continue
        h, p = kruskal(*samples.values())
        rows.append({"task": task, "on": column, "methods": list(samples), "n": [len(v) for v in samples.values()],
                     "h": float(h), "p": float(p)})
    return rows


def summarise(config: CampaignConfig) -> dict:
    """The campaign's statistics from the committed runs, re-scores and held-out scores (as far as they go; see
    the module docstring). Never simulates."""
    if not Path(config.directory).is_dir():  # a typo would report 0 runs
        raise InputError(f"{config.directory}: not a directory (glso_campaign.directory: expected the folder of "
                         "the committed runs)")
    steps = read_runs(config)
    planned = len(run_specs(config))
    if steps.empty:
        return {"runs": 0, "planned": planned, "finals": [], "spend": [], "k": {}, "tests": [], "omnibus": [],
                "curves": {axis: [] for axis in AXES}, "methods": describe()}
    return {"planned": planned, "rung": read_manifest(config.directory).get("rung", ""),
            **statistics(steps, read_scores(config.directory, RESCORES_FILE),
                         read_scores(config.directory, HELDOUT_FILE), config)}


def statistics(steps: pd.DataFrame, rescores: pd.DataFrame, heldout: pd.DataFrame, config: CampaignConfig) -> dict:
    """The summary's statistics of the runs `steps` (at least one), their `rescores` and `heldout` scores (score
    logs, `read_scores`): everything but the plan and the rung, which `summarise` reads from the campaign's
    directory. `heldout_progress` counts the runs whose held-out pieces are complete, the held-out evaluations
    measured of those planned, and the thesis re-scores of held-out bests still missing."""
    final = heldout_bests(final_bests(steps, rescores), steps, heldout, rescores, config)
    tests = [row for reference in challengers(final) for seed, column in enumerate(COMPARED)
             for row in compare(final, column, config.bootstrap, config.alpha, seed, reference)]
    curves = {"calls": best_so_far_curves(steps), "distinct": distinct_curves(steps)}
    picked = final["heldout_design"] != ""
    missing = (len(config.rescore_seeds) - final.loc[picked, "heldout_rescores"]).clip(lower=0)
    return {"runs": int(len(final)), "budget": int(steps["step"].max() + 1),
            "rescore_seeds": list(config.rescore_seeds), "alpha": config.alpha, "finals": final.to_dict("records"),
            "spend": spend(final).to_dict("records"), "k": final.groupby("task", sort=False)["k"].first().to_dict(),
            "heldout_seeds": list(config.heldout_seeds), "heldout_top": config.heldout_top,
            "heldout": heldout_summary(final).to_dict("records"),
            "heldout_progress": {"runs": int(len(final)), "complete": int(final["heldout_complete"].sum()),
                                 "evaluations": int(final["heldout_measured"].sum()),
                                 "planned": int(final["heldout_planned"].sum()),
                                 "rescores_missing": int(missing.sum())},
            "tests": tests, "omnibus": [row for column in COMPARED for row in omnibus(final, column)],
            "curves": {axis: table[["task", "method", axis, "median", "q25", "q75", "runs"]].to_dict("records")
                       for axis, table in curves.items()},
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
