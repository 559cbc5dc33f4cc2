"""The evaluator fidelity ladder: how well a cheap MPPI setting ranks designs like the thesis's setting.

One fixed design set (`measured/fidelity/designs.csv`) is scored under a ladder of MPPI settings (`LADDER`),
from cheaper than the default profile up to the thesis's (512 first / 64 samples, horizon 16, 128 control
steps). Every (task, rung, design) score is one line of a CSV piece `measured/fidelity/scores/<task>__<rung>.csv`,
appended as soon as it is measured, so a measurement of many CPU hours resumes where it stopped.
`summarise` turns the pieces into one row per (task, rung): physics steps and seconds per evaluation,
Spearman rank correlation with the thesis rung's scores, and whether the thesis rung's best design is in
the rung's top 3 (the stage writes it to `reports/fidelity/summary.csv`: an output, not a measurement).
`choose_default` picks the cheapest rung that ranks like the thesis on every task.

    robocompose evaluator-fidelity build-set    # once, after `dvc repro enumerate`: the design set (committed)
    robocompose fidelity-search                 # hours: searches at cheap rungs; their best designs join the set
    robocompose evaluator-fidelity measure      # hours: resumable, skips rows already in the pieces
    robocompose evaluator-fidelity summarise    # the table

The design set spans the score range: the two RoboGrammar reference designs, the first `n_random` designs of
the dataset table (data/designs.parquet: the enumeration's valid candidates in candidate order), and the best
`n_screened` of the next `n_screen` dataset designs scored at the cheap `SCREEN` setting (a quick random search). Scores
use the optimisers' objective (`objective`: an invalid result gets its penalty score) with controller
seed 0, the settings of the default profile.

What a search finds is what the evaluator must rank: the designs of kind `search` are the best designs of
searches run at cheap rungs (`robocompose.glso.fidelity_search`). The thesis rung repeated with
controller seed 1 (`thesis_seed1`) gives the noise ceiling: the seed-to-seed Spearman of the thesis setting.
The selection rule (`choose_default`) ranks rungs on the search-found designs alone.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.evaluate import OK, EvaluationConfig, evaluate, objective, simulation_digest
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree
from robocompose.io import atomic_write_text
from robocompose.io.errors import ArtifactError, InputError, check_field, check_number, shown
from robocompose.tasks.terrains import TASKS

THESIS = "thesis"
# The ladder, by name: (samples, first_samples, horizon, episode); interval 16 and every other field as
# the thesis. Each rung changes one or two knobs of a neighbour so the table shows which knob matters.
LADDER: dict[str, tuple[int, int, int, int]] = {
    THESIS: (64, 512, 16, 128),  # RoboGrammar / the thesis: 2.23 M sim steps (flat)
    "s8_h8_e48": (8, 64, 8, 48),  # half the default's samples
    "s16_h8_e48": (16, 64, 8, 48),  # the default profile before this ladder
    "s16_h16_e48": (16, 64, 16, 48),  # default, thesis horizon
    "s32_h8_e48": (32, 128, 8, 48),  # default, twice the samples
    "s16_h8_e128": (16, 64, 8, 128),  # default, thesis episode length
    "s32_h16_e64": (32, 128, 16, 64),  # the intermediate measurement
    "s32_h16_e128": (32, 256, 16, 128),  # half the thesis's samples
}
# Rungs that repeat another rung with a further controller seed (rung name -> (rung, seed offset)).
REPEATS: dict[str, tuple[str, int]] = {"thesis_seed1": (THESIS, 1)}
NOISE_RUNG = "thesis_seed1"  # its Spearman against the thesis rung is the noise ceiling
SCREEN = MPPIConfig(samples=8, first_samples=32, horizon=8, episode=24)  # the quick search's cheap setting
DESIGN_COLUMNS = ("name", "kind", "design_id", "rules", "screen_reward")
SCORE_COLUMNS = ("task", "rung", "name", "design_id", "reward", "status", "objective", "sim_steps", "seconds",
                 "evaluator")  # evaluator: `simulation_digest(task)` of the code that measured the row
MEASURE_ORDER = ("reference", "search", "screened", "random")  # kinds of design, in `measure_order`
DESIGNS_FILE, SUMMARY_FILE = "designs.csv", "summary.csv"
SUMMARY_DIR = "reports/fidelity"  # the summary is the stage's output; the design set and pieces are measured/
SCORES_DIR = "scores"
SEARCH = "search"  # the kind of a design found by a search


def base_rung(name: str) -> str:
    """The ladder rung whose MPPI settings rung `name` runs (itself, or the rung a repeat repeats)."""
    return REPEATS[name][0] if name in REPEATS else name


def rung_seed(name: str, seed: int) -> int:
    """The controller seed of rung `name` when the ladder's seed is `seed`."""
    return seed + (REPEATS[name][1] if name in REPEATS else 0)


def rung_config(name: str) -> MPPIConfig:
    """The MPPI config of ladder rung `name`."""
    if base_rung(name) not in LADDER:
        raise InputError(f"unknown fidelity rung {shown(name)}; known rungs: {list(LADDER) + list(REPEATS)}")
    samples, first_samples, horizon, episode = LADDER[base_rung(name)]
    return MPPIConfig(samples=samples, first_samples=first_samples, horizon=horizon, episode=episode)


@dataclass(frozen=True)
class FidelityConfig:
    """The `evaluator_fidelity:` section of params.yaml."""

    directory: str = "measured/fidelity"  # the design set and the score pieces (committed measurements)
    tasks: list[str] = field(default_factory=lambda: ["flat", "ridged"])  # measured in this order
    rungs: list[str] = field(default_factory=lambda: list(LADDER))  # measured in this order (thesis first)
    measure: bool = False  # False: summarise the committed pieces only; True: score what is missing first
    seed: int = 0  # controller seed of every evaluation
    n_random: int = 16  # dataset designs in the set
    n_screen: int = 100  # further dataset designs scored at SCREEN ...
    n_screened: int = 8  # ... of which the best join the set
    min_spearman: float = 0.8  # the provisional rule (before the search-found designs are measured) ...
    top: int = 3  # ... and the thesis-best design among this many of the rung's best
    search_methods: list[str] = field(default_factory=lambda: ["glso", "random", "mcts", "ghs"])
    search_rungs: list[str] = field(default_factory=lambda: ["s8_h8_e48", "s16_h8_e48"])
    search_budget: int = 40  # objective calls per search
    search_init: int = 16  # GLSO's random initial points in these searches (glso.bo.init)
    search_top: int = 2  # best distinct simulated designs of each search that join the set
    search_spearman: float = 0.7  # the rule: Spearman over the search-found designs at least this ...
    ceiling_share: float = 0.8  # ... or at least this share of the noise ceiling, on every task

    def __post_init__(self) -> None:
        check_field(bool(self.tasks), "tasks", f"at least one task of {list(TASKS)}", self.tasks)
        unknown = [task for task in self.tasks if task not in TASKS]
        check_field(not unknown, "tasks", f"tasks of {list(TASKS)}", unknown[:1])
        check_field(bool(self.rungs), "rungs", f"at least one rung of {list(LADDER)}", self.rungs)
        for name in ("rungs", "search_rungs"):
            for rung in getattr(self, name):
                try:
                    rung_config(rung)
                except InputError as err:
                    raise InputError(f"{name}: {err}") from None
        for name in ("n_screen", "n_screened", "top", "search_budget", "search_top", "search_init"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        for name in ("seed", "n_random"):
            check_field(getattr(self, name) >= 0, name, "an integer >= 0", getattr(self, name))
        # the rule's thresholds: a Spearman of 0 or less, or a share of the noise ceiling above 1, chooses nothing
        # right (every rung passes, or none)
        for name in ("min_spearman", "search_spearman", "ceiling_share"):
            check_number(getattr(self, name), name, 0.0, 1.0, "(]")


def build_design_set(config: FidelityConfig, dataset: pd.DataFrame, where: str = "the dataset") -> pd.DataFrame:
    """The fixed design set: references, the first `n_random` designs of `dataset` (a `designs` table, in
    candidate order), the best screened of the next `n_screen`."""
    needed = config.n_random + config.n_screen
    if len(dataset) < needed:
        raise InputError(f"{where}: {len(dataset)} designs, expected at least n_random + n_screen = {needed} "
                         "(evaluator_fidelity)")
    rows = [{"name": name, "kind": "reference", "rules": parse_rules(text), "screen_reward": np.nan}
            for name, text in REFERENCE_DESIGNS.items()]
    drawn = [(tuple(int(r) for r in row.rules), DesignTree(tuple(row.parents), tuple(row.tokens)))
             for row in dataset.iloc[:needed].itertuples()]
    for i, (rules, _) in enumerate(drawn[:config.n_random]):
        rows.append({"name": f"random_{i}", "kind": "random", "rules": rules, "screen_reward": np.nan})
    screened = []
    screen = EvaluationConfig(mppi=SCREEN)
    for rules, tree in tqdm(drawn[config.n_random:], desc="screen", unit="design"):
        row = evaluate(tree, "flat", screen, config.seed)
        if row["status"] == OK:  # an invalid design scores its penalty under every setting: nothing to rank
            screened.append({"kind": "screened", "rules": rules, "screen_reward": row["reward"]})
    screened.sort(key=lambda r: -r["screen_reward"])
    rows += [{"name": f"screened_{i}", **r} for i, r in enumerate(screened[:config.n_screened])]
    table = pd.DataFrame(rows)
    table["design_id"] = [derive(rules).tree.design_id for rules in table["rules"]]
    table["rules"] = [",".join(map(str, rules)) for rules in table["rules"]]
    return table[list(DESIGN_COLUMNS)]


def write_design_set(table: pd.DataFrame, directory: str | Path) -> Path:
    return atomic_write_text(Path(directory) / DESIGNS_FILE, table.to_csv(index=False, float_format="%.6f"))


def write_summary(summary: pd.DataFrame, directory: str | Path = SUMMARY_DIR) -> Path:
    return atomic_write_text(Path(directory) / SUMMARY_FILE, summary.to_csv(index=False, float_format="%.6g"))


def read_design_set(directory: str | Path) -> pd.DataFrame:
    path = Path(directory) / DESIGNS_FILE
    if not path.exists():
        raise InputError(f"{path}: fidelity design set not found (run `robocompose evaluator-fidelity "
                                "build-set`)")
    table = pd.read_csv(path, dtype={"rules": str})
    missing = [c for c in DESIGN_COLUMNS if c not in table.columns]
    if missing:
        raise InputError(f"{path}: missing column {missing[0]!r}; expected {list(DESIGN_COLUMNS)}")
    return table


# Append-only CSV logs (the score pieces, the campaign's re-scores): several processes extend them one row at a
# time. One row is one write() on an O_APPEND file followed by fsync, so a crash leaves whole lines and at most
# one line cut off at the end; readers keep complete rows only. Values never contain commas or line breaks
# (names, digests, numbers), which keeps a row's field count a completeness check.
def _field(value: object) -> str:
    text = "" if value is None else (repr(float(value)) if isinstance(value, float) else str(value))  # np.float64 too
    if "," in text or "\n" in text or "\r" in text:
        raise ValueError(f"csv log value {text!r} contains a comma or a line break")
    return text


def append_row(path: str | os.PathLike[str], columns: Sequence[str], row: dict) -> None:
    """Append `row` (its `columns`, in order; None is empty) to the log at `path`, creating it with a header."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    line = ",".join(_field(row[c]) for c in columns) + "\n"
    if not path.exists():
        try:
            with open(path, "x", encoding="utf-8") as f:
                f.write(",".join(columns) + "\n")
        except FileExistsError:  # another process created it first
            pass
    with open(path, "rb") as f:  # a line cut off by a crash: end it, so it stays one bad line, ignored
        f.seek(-1, os.SEEK_END)
        cut = f.read(1) != b"\n"
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    try:
        os.write(fd, (("\n" if cut else "") + line).encode())
        os.fsync(fd)
    finally:
        os.close(fd)


def read_rows(path: str | os.PathLike[str], columns: Sequence[str], key: Sequence[str] = (),
              results: Sequence[str] = ()) -> list[list[str]]:
    """The complete rows of the log at `path` as strings ([] if it does not exist); InputError on a wrong header.

    With `key` (column names), a row whose key an earlier row holds is dropped (two workers that measured one
    thing at once), but only if its `results` columns are the same: the evaluator is deterministic, so two
    different results for one key are an ArtifactError naming the log, the key and the results."""
    path = Path(path)
    if not path.exists():
        return []
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    if not lines or lines[0].strip() != ",".join(columns):
        raise InputError(f"{path}: expected the header {','.join(columns)}")
    complete = [line for line in lines[1:] if line.endswith("\n") and line.count(",") == len(columns) - 1]
    rows = list(csv.reader(complete))
    if not key:
        return rows
    keys, kept = [columns.index(c) for c in key], {}
    checked = [columns.index(c) for c in results]
    for row in rows:
        first = kept.setdefault(tuple(row[i] for i in keys), row)
        if any(first[i] != row[i] for i in checked):
            named = dict(zip(key, (row[i] for i in keys), strict=True))
            raise ArtifactError(f"{path}: {named} has rows with different results "
                                f"({', '.join(f'{columns[i]} {first[i]!r} / {row[i]!r}' for i in checked)}); "
                                "the evaluator is deterministic, so keep the row of the current code")
    return list(kept.values())


def piece_path(directory: str | Path, task: str, rung: str) -> Path:
    return Path(directory) / SCORES_DIR / f"{task}__{rung}.csv"


def read_piece(path: Path) -> pd.DataFrame:
    """The complete rows of a score piece (a line cut off by a crash mid-write is ignored).

    The pieces are a measurement record, not a cache: each row keeps the simulation digest of the code that
    measured it, and rows of an older digest stay (hours of CPU); that the current code gives the same
    scores is checked by re-measuring a sample (see docs/evaluation.md). A design measured twice (two workers
    that reached it at once) keeps its first row; two different results for one design are an ArtifactError.
    """
    rows = read_rows(path, SCORE_COLUMNS, key=("design_id",), results=("objective", "status"))
    table = pd.DataFrame(rows, columns=list(SCORE_COLUMNS))
    for column in ("reward", "objective", "seconds"):  # an empty reward is a result without one (not ok)
        table[column] = pd.to_numeric(table[column].replace("", np.nan))
    table["sim_steps"] = table["sim_steps"].astype(int)
    return table


def measure_order(designs: pd.DataFrame) -> pd.DataFrame:
    """The reference designs first, then the other kinds taken in turn (screened_0, random_0, screened_1, ...),
    so that the designs measured first span the score range, strong designs included."""
    turn = designs.groupby("kind", sort=False).cumcount() + (designs["kind"] != "reference") * len(designs)
    kind = designs["kind"].map(MEASURE_ORDER.index)
    return designs.assign(_turn=turn, _kind=kind).sort_values(["_turn", "_kind"], kind="stable").drop(
        columns=["_turn", "_kind"])


def measure(config: FidelityConfig, designs: pd.DataFrame) -> int:
    """Score every (task, rung, design) not yet in the pieces; the number scored by this call.

    Order: task, then design (`measure_order`), then rung (config order). Design-major order makes a partial
    run useful: every design measured so far has a score at every rung, so a Spearman over them exists.
    Several processes may share the pieces (say, one per task, or one per part of the design set): each job is
    checked against its piece again just before it runs, so what another process wrote meanwhile is skipped.
    """
    trees = {row.design_id: derive(parse_rules(row.rules)).tree for row in designs.itertuples()}
    designs = measure_order(designs)

    def done(task: str, rung: str) -> set[str]:
        return set(read_piece(piece_path(config.directory, task, rung))["design_id"])

    todo = {(task, rung): done(task, rung) for task in config.tasks for rung in config.rungs}
    jobs = [(task, rung, row.name, row.design_id) for task in config.tasks for row in designs.itertuples()
            for rung in config.rungs if row.design_id not in todo[task, rung]]
    scored = 0
    for task, rung, name, design_id in tqdm(jobs, desc="fidelity", unit="eval"):
        if design_id in done(task, rung):
            continue
        seed = rung_seed(rung, config.seed)
        row = evaluate(trees[design_id], task, EvaluationConfig(mppi=rung_config(rung), seed=seed), seed)
        append_row(piece_path(config.directory, task, rung), SCORE_COLUMNS,
                   {"task": task, "rung": rung, "name": name, "design_id": design_id, **row,
                    "objective": objective(row), "evaluator": simulation_digest(task)})
        scored += 1
    return scored


def read_scores(directory: str | Path) -> pd.DataFrame:
    """Every measured row of every piece."""
    pieces = sorted((Path(directory) / SCORES_DIR).glob("*__*.csv"))
    tables = [read_piece(p) for p in pieces]
    tables = [t for t in tables if len(t)]
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame(columns=list(SCORE_COLUMNS))


def spearman(a: pd.Series, b: pd.Series) -> float:
    """Spearman rank correlation (average ranks for ties); NaN for fewer than 3 pairs or a constant side."""
    if len(a) < 3:
        return float("nan")
    ra, rb = a.rank().to_numpy(), b.rank().to_numpy()
    if ra.std() == 0 or rb.std() == 0:
        return float("nan")
    return float(np.corrcoef(ra, rb)[0, 1])


def summarise(scores: pd.DataFrame, designs: pd.DataFrame, top: int = 3) -> pd.DataFrame:
    """One row per (task, rung) measured: cost, and rank agreement with the thesis rung (controller seed 0).

    Over the base set (every design but the search-found ones): `n_common` designs measured at both,
    `complete`, `spearman`, `thesis_best_in_top`. Over the search-found designs: `n_search_common` of
    `n_search`, `spearman_search`, and the task's `noise_ceiling` (the thesis rung against its repeat with
    controller seed 1, over the search-found designs measured at both).
    """
    kinds = dict(zip(designs["design_id"], designs["kind"], strict=True))
    names = dict(zip(designs["design_id"], designs["name"], strict=True))
    search_ids = set(designs.loc[designs["kind"] == SEARCH, "design_id"])
    n_base = len(designs) - len(search_ids)

    def by_rung(task: str, rung: str) -> pd.Series:
        rows = scores[(scores["task"] == task) & (scores["rung"] == rung)]
        return rows.set_index("design_id")["objective"]

    def search_common(a: pd.Series, b: pd.Series) -> pd.Index:
        return a.index.intersection(b.index).intersection(pd.Index(sorted(search_ids)))

    rows = []
    for (task, rung), group in scores.groupby(["task", "rung"], sort=False):
        thesis, noise, mine = by_rung(task, THESIS), by_rung(task, NOISE_RUNG), by_rung(task, rung)
        common = mine.index.intersection(thesis.index).difference(pd.Index(sorted(search_ids)))
        found = search_common(mine, thesis)
        ceiling = search_common(thesis, noise)
        thesis_best = thesis[common].idxmax() if len(common) else None
        ranked = mine[common].sort_values(ascending=False, kind="stable")
        random = group[group["design_id"].map(kinds) == "random"]["objective"]
        samples, first_samples, horizon, episode = LADDER[base_rung(rung)]
        rows.append({
            "task": task, "rung": rung, "samples": samples, "first_samples": first_samples, "horizon": horizon,
            "episode": episode, "n_designs": n_base, "n_scored": len(group), "n_common": len(common),
            "complete": len(common) == n_base,
            "sim_steps_per_eval": float(group["sim_steps"].mean()),
            "seconds_per_eval": float(group["seconds"].mean()),
            "spearman": spearman(mine[common], thesis[common]),
            "thesis_best": names[thesis_best] if thesis_best else "",
            "thesis_best_in_top": bool(thesis_best is not None and thesis_best in set(ranked.index[:top])),
            "best": names[ranked.index[0]] if len(ranked) else "",
            "best_score": float(ranked.iloc[0]) if len(ranked) else float("nan"),
            "random_min": float(random.min()) if len(random) else float("nan"),
            "random_max": float(random.max()) if len(random) else float("nan"),
            "n_search": len(search_ids), "n_search_common": len(found),
            "spearman_search": spearman(mine[found], thesis[found]),
            "noise_ceiling": spearman(thesis[ceiling], noise[ceiling]),
            "n_noise_common": len(ceiling),
        })
    table = pd.DataFrame(rows)
    if len(table):
        table = table.sort_values(["task", "sim_steps_per_eval"], kind="stable").reset_index(drop=True)
    return table


def choose_default(summary: pd.DataFrame, tasks: list[str], min_spearman: float = 0.8,
                   search_spearman: float = 0.7, ceiling_share: float = 0.8) -> dict:
    """The cheapest rung (by physics steps on the first task) that ranks what a search finds like the thesis.

    The rule, once the search-found designs have scores at the thesis rung, at its seed-1 repeat and at the
    rung, on every task in `tasks`: Spearman over them >= `search_spearman`, or >= `ceiling_share` x the
    task's noise ceiling. Until then the choice is provisional, by the earlier rule over the base set (whole
    set measured, Spearman >= `min_spearman`, the thesis-best design in the rung's top k), and says so.

    Returns {"rung": name or "", "rule": "search" | "provisional", "passing": [rungs], "reason": text}."""
    cheap = summary[(summary["rung"] != THESIS) & ~summary["rung"].isin(list(REPEATS))]
    per_task = {rung: group.set_index("task") for rung, group in cheap.groupby("rung", sort=False)}
    per_task = {rung: t for rung, t in per_task.items() if all(task in t.index for task in tasks)}

    def cost(rung: str) -> float:
        return float(per_task[rung].loc[tasks[0], "sim_steps_per_eval"])

    noise = summary[summary["rung"] == NOISE_RUNG].set_index("task")
    n_search = int(summary["n_search"].max()) if "n_search" in summary and len(summary) else 0
    search_done = n_search > 0 and all(t in noise.index and int(noise.loc[t, "n_search_common"]) == n_search
                                       for t in tasks)
    if search_done:
        def passes(t: pd.DataFrame, task: str) -> bool:
            value, ceiling = t.loc[task, "spearman_search"], noise.loc[task, "spearman_search"]
            return (int(t.loc[task, "n_search_common"]) == n_search
                    and (value >= search_spearman or value >= ceiling_share * ceiling))

        passing = sorted((r for r, t in per_task.items() if all(passes(t, task) for task in tasks)), key=cost)
        ceilings = ", ".join(f"{t} {noise.loc[t, 'spearman_search']:.2f}" for t in tasks)
        rule = (f"cheapest rung whose Spearman over the {n_search} search-found designs is >= {search_spearman} "
                f"or >= {ceiling_share} x the noise ceiling (thesis seed 0 vs seed 1: {ceilings}) on "
                f"{', '.join(tasks)}")
        if passing:
            return {"rung": passing[0], "rule": "search", "passing": passing, "reason": rule}
        return {"rung": "", "rule": "search", "passing": [], "reason": f"no rung passes the rule ({rule})"}

    measured = ", ".join(f"{t}: {int(noise.loc[t, 'n_search_common']) if t in noise.index else 0} of {n_search}"
                         for t in tasks)
    waiting = (f"provisional: the search-found designs are not all measured at the thesis setting's two seeds "
               f"({measured}), so the earlier rule over the base set decides")
    thesis = summary[summary["rung"] == THESIS].set_index("task")
    if not all(t in thesis.index and bool(thesis.loc[t, "complete"]) for t in tasks):
        counts = ", ".join(f"{t}: {int(thesis.loc[t, 'n_common']) if t in thesis.index else 0} of "
                           f"{int(summary['n_designs'].iloc[0]) if len(summary) else 0}" for t in tasks)
        return {"rung": "", "rule": "provisional", "passing": [],
                "reason": f"{waiting}; the base table is not complete (designs with a thesis-setting score, "
                          f"{counts})"}
    passing = sorted((r for r, t in per_task.items()
                      if all(bool(t.loc[task, "complete"]) and t.loc[task, "spearman"] >= min_spearman
                             and bool(t.loc[task, "thesis_best_in_top"]) for task in tasks)), key=cost)
    rule = (f"cheapest rung with Spearman >= {min_spearman} over the base set and the thesis-best design in its "
            f"top k on {', '.join(tasks)}")
    if passing:
        return {"rung": passing[0], "rule": "provisional", "passing": passing, "reason": f"{waiting}: {rule}"}
    return {"rung": "", "rule": "provisional", "passing": [], "reason": f"{waiting}: no rung passes ({rule})"}
