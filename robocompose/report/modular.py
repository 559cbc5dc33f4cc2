"""Report section for modular robot design (thesis 5.1): the terrain criterion (does the best design depend on the
terrain?), Table 5.2's GA rows and Table 5.1's random-sampling row beside the thesis's, the exhaustive optimum of
every test terrain with each method's regret, and a picture of the terrains with their best designs.

Built from the outputs of the `modular_exhaustive` stage (its metrics: each terrain's optimum and the terrain
criterion; its picture, reports/plots/modular_terrains.png) and the `modular_baselines` stage. A run's runtime is its
simulation steps (every evaluation it asked for, repeats included: its cost without a cache; the runs themselves
read each fitness from the exhaustive table) at the single-core rate `make bench` measures. Penalties are never
averaged as distances: runs whose best design carries no distance, and emergency answers without one, are counted
as failures.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from robocompose.io import read_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import ArtifactError
from robocompose.report.tables import markdown_table
from robocompose.report.verdicts import held, verdict

# Thesis Table 5.2 (learned modular controller): max distance (m), distinct solutions, runtime (min), each mean +- std.
THESIS_TABLE_5_2 = {"ga20": ("4.21 ± 1.43", "1.8 ± 0.8", "25.4 ± 0.7"),
                    "ga50": ("5.63 ± 0.34", "2.0 ± 1.4", "71.9 ± 1.3"),
                    "crowding": ("5.33 ± 0.25", "6.4 ± 1.3", "97.6 ± 2.1")}
# Thesis Table 5.1, random sampling: max distance, max distance under emergency constraints (learned controller);
# and random sampling with the hand-crafted controller ("effect of the controller").
THESIS_RANDOM = ("0.72 ± 0.64", "0.63 ± 0.69")
THESIS_RANDOM_HANDCRAFTED = "0.86 ± 0.81"


def _titles(baselines: dict, runs: pd.DataFrame, where: Path) -> dict[str, str]:
    """Each method that ran -> its title, in the order the runs list them (the stage's registry order), as
    `modular_baselines` recorded them; ArtifactError naming the file if one has none."""
    methods = list(pd.unique(runs.method))
    untitled = [m for m in methods if "title" not in baselines.get(m, {})]
    if untitled:
        raise ArtifactError(f"{where}: no title for methods {untitled} (rerun stage `modular_baselines`)")
    return {method: baselines[method]["title"] for method in methods}


def _mean_std(values: pd.Series, digits: int = 2) -> str:
    values = values.dropna()
    if values.empty:
        return "n/a"
    return f"{values.mean():.{digits}f} ± {values.std(ddof=0):.{digits}f}"


def _steps_per_second(reports_dir: Path) -> float | None:
    path = Path(reports_dir) / "benchmarks.json"
    if not path.exists():
        return None
    return read_json(path).get("modular.steps_per_s")


def _failures(group: pd.DataFrame) -> str:
    failed = int(group.best_distance.isna().sum())
    return f"{failed} of {len(group)}"


def section(reports_dir: Path, data_dir: Path, modular: dict) -> str:
    """Markdown for the modular-robot section; `modular`: the `modular:` params the stages ran with."""
    paths = {"metrics": Path(reports_dir) / "metrics" / "modular_exhaustive.json",
             "runs": Path(data_dir) / "modular" / "runs.parquet",
             "baselines": Path(reports_dir) / "metrics" / "modular_baselines.json"}
    missing = [str(p) for p in paths.values() if not p.exists()]
    if missing:
        return ("## Modular robot design (thesis 5.1)\n\nNot run yet: missing " + ", ".join(missing)
                + " (stages `modular_exhaustive` and `modular_baselines`).\n")
    truth = read_json(paths["metrics"])
    runs = read_table(paths["runs"], "modular_runs")
    runs["regret"] = runs.optimum - runs.best_distance
    names = _titles(read_json(paths["baselines"]), runs, paths["baselines"])
    summary = pd.DataFrame([{"terrain_seed": int(seed), "optimum": optimum, "best_design": truth["best_design"][seed],
                             "near_optimal": truth["near_optimal"][seed], "simulated": truth["simulated"][seed]}
                            for seed, optimum in truth["optimum"].items()])
    n_terrains, n_seeds = runs.terrain_seed.nunique(), runs.seed.nunique()
    e, terrain = modular["eval"], modular["eval"]["terrain"]
    seconds = e["control_steps"] * e["sim_steps_per_control"] * e["time_step"]
    episode = (f"{e['control_steps']} control steps x {e['sim_steps_per_control']} sim steps ({seconds:.1f} s) on "
               f"a course x in [{terrain['x_range'][0]:g}, {terrain['x_range'][1]:g}] m, blocks up to "
               f"H ~ U({terrain['max_height_range'][0]:g}, {terrain['max_height_range'][1]:g}) m high")

    lines = [
        "## Modular robot design (thesis 5.1)",
        "",
        "Evaluator: pybullet rollouts of the 6-port chassis with leg / wheel / leg-wheel modules on seeded block "
        f"terrains, driven by the hand-crafted alternating-tripod controller; episode {episode}; fitness = distance "
        "travelled in x with the reference's early stops; designs the original called invalid (more than two empty "
        "ports, or an empty corner port) score -10 unsimulated. The thesis's Table 5.1/5.2 used a learned modular "
        "policy; its hand-crafted-controller experiment reports random sampling at "
        f"{THESIS_RANDOM_HANDCRAFTED} m. Ours: {n_terrains} test terrains x {n_seeds} runs per method (thesis: "
        "10 terrains x 20 runs). Block heights are widened from the reference's H ~ U(0, 0.08) m (there one wheeled "
        "design wins every terrain); the episode is shorter than the thesis's 250 steps in the default profile.",
        "",
    ]
    lines += _criterion_lines(truth)
    rate = _steps_per_second(reports_dir)
    rows = [(names[method], _mean_std(group.best_distance), _mean_std(group.distinct, 1), _mean_std(group.regret),
             _failures(group), int(group.evaluations.mean()),
             _mean_std(group.sim_steps / rate / 60, 1) if rate else "n/a (run `make bench`)",
             _mean_std(group.sim_seconds / 60, 1), *THESIS_TABLE_5_2[method])
            for method, group in ((m, runs[runs.method == m]) for m in ("ga20", "ga50", "crowding")) if len(group)]
    lines += [
        "### Evolutionary baselines (Table 5.2)",
        "",
        *markdown_table(["method", "max distance (m)", "distinct solutions", "regret to the optimum (m)", "failed runs",
                         "evaluations", "runtime (min, one quiet core)", "measured simulation time (min)",
                         "thesis distance", "thesis distinct", "thesis runtime (min)"], rows),
        "",
        "A run's cost is every evaluation it asked for, repeats included (what it costs without a cache): runtime = "
        f"its simulation steps at {f'{rate:,.0f}' if rate else 'the benchmark'} steps/s (one quiet core, "
        "`modular.steps_per_s` of `make bench`); measured simulation time = the wall seconds its rollouts took "
        "when the exhaustive tables were measured (2 cores shared with other jobs: an upper bound). The runs read "
        "every fitness from the test terrain's exhaustive table. "
        "Distinct solutions: the final population's designs at Hamming distance >= 1 whose fitness is within 0.5 m "
        "of the population's best. A failed run is one whose best design carries no distance (never averaged).",
        "",
        "### Random sampling (Table 5.1 row)",
        "",
        *markdown_table(["method", "max distance (m)", "failed runs", "max distance under emergency constraints (m)",
                         "EC answers without a distance", "EC optimum (m)", "thesis distance", "thesis EC distance"],
                        _random_rows(runs[runs.method == "random"], names.get("random", ""),
                                     modular["experiments"]["ec_draws"])),
        "",
        "Emergency constraints: each draw caps one module type (leg, wheel or leg-wheel) at 0, 1 or 2; a method "
        "answers with its best valid output design that satisfies the cap, else a random valid satisfying design. "
        "The EC distance averages the answers that carry a distance; the others are counted. The EC optimum is the "
        "best valid satisfying design of the exhaustive table under the same draws.",
        "",
        "### Exhaustive ground truth of the test terrains (not in the thesis)",
        "",
        "All 4096 designs on each test terrain (designs the rule skips score -10; the rest simulated).",
        "",
    ]
    rows = []
    for row in summary[summary.terrain_seed.isin(runs.terrain_seed)].itertuples():
        regrets = []
        for method in names:
            group = runs[(runs.method == method) & (runs.terrain_seed == row.terrain_seed)]
            regrets.append(_mean_std(group.regret) if len(group) else "n/a")
        rows.append((row.terrain_seed, row.simulated, row.optimum, row.best_design, row.near_optimal, *regrets))
    lines += markdown_table(["terrain seed", "simulated designs", "optimum (m)", "best design", "designs within 0.5 m",
                             *(f"{names[m]} regret (m)" for m in names)], rows,
                            formats=[None, None, "{:.2f}", "`{}`"])
    found = runs.assign(hit=runs.regret <= 1e-9).groupby("method").hit.mean()
    lines += [
        "",
        "Share of runs that found the exact optimum: "
        + ", ".join(f"{names[m]} {found[m]:.0%}" for m in names if m in found) + ".",
        "",
        _status_line(truth["statuses"]),
    ]
    if (Path(reports_dir) / "plots" / "modular_terrains.png").exists():
        lines += ["", "![test terrains and their best designs](plots/modular_terrains.png)", "",
                  "Top: height maps of the test terrains (the 50 x 20 task encoding, x to the right). Bottom: each "
                  "terrain's exhaustive best design at its start pose (ports: front-left, mid-left, back-left, "
                  "back-right, mid-right, front-right; n none, l leg, w wheel, b leg-wheel)."]
    return "\n".join(lines) + "\n"


def _random_rows(random_runs: pd.DataFrame, title: str, ec_draws: int) -> list[tuple]:
    """Table 5.1's random-sampling row (none before the runs exist), with the designs each run drew."""
    if random_runs.empty:
        return []
    answers = len(random_runs) * ec_draws
    designs = int(random_runs.evaluations.median())
    return [(f"{title} ({designs} designs)", _mean_std(random_runs.best_distance), _failures(random_runs),
             _mean_std(random_runs.ec_distance), f"{int(random_runs.ec_failures.sum())} of {answers}",
             _mean_std(random_runs.ec_optimum), *THESIS_RANDOM)]


def _criterion_lines(truth: dict) -> list[str]:
    """The terrain criterion over every terrain with an exhaustive table (from the stage's metrics)."""
    totals = truth["criterion"]
    per_terrain = pd.DataFrame(totals["per_terrain"])
    lines = [
        "### Does the best design depend on the terrain? (thesis Fig. 5.1)",
        "",
        f"Exhaustive tables on {totals['terrains']} seeded terrains: {totals['distinct_optima']} distinct optimal "
        f"designs (up to the left-right mirror); the single design best on average, `{totals['average_design']}`, "
        f"loses {totals['mean_regret']:.2f} m per terrain on average, {totals['regret_ratio']:.0%} of the mean "
        f"optimum ({totals['mean_optimum']:.2f} m).",
        "",
        verdict("The best design depends on the terrain (criterion: >= 8 terrains, >= 3 distinct optima, regret "
                ">= 10%)", held(totals["holds"]), f"({totals['terrains']} terrains, {totals['distinct_optima']} "
                f"distinct optima, regret {totals['regret_ratio']:.0%})."),
        "",
        *markdown_table(["terrain seed", "tallest block (cm)", "optimum design", "its distance (m)",
                         "best-on-average design's distance (m)", "its regret (m)"],
                        [(row.terrain_seed, truth["tallest_block_cm"][str(row.terrain_seed)], row.optimum_design,
                          row.optimum, row.average_distance, row.regret) for row in per_terrain.itertuples()],
                        formats=[None, "{:.1f}", "`{}`", "{:.2f}", "{:.2f}", "{:.2f}"]),
    ]
    return lines + [""]


def _status_line(statuses: dict[str, int]) -> str:
    counts = pd.Series(statuses).sort_index()
    return "Statuses over the exhaustive table: " + ", ".join(f"{k} {v}" for k, v in counts.items()) + "."
