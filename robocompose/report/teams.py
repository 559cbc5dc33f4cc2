"""Report section for team formation (thesis 5.2): Tables 5.4 and 5.5 beside ours, and three figures.

Built only from the outputs of the `decompose`, `teams_baselines`, `teams_eggan` and `teams_heldout` stages (and
the runs' wall times in reports/timings.json, kept out of DVC's outputs).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.io import read_table
from robocompose.io.atomic import read_json
from robocompose.io.timings import read_timings
from robocompose.report.tables import markdown_table
from robocompose.report.verdicts import held, verdict

THESIS_TABLE_5_4 = {20: (9.4, 1.0, 43.1), 50: (11.9, 1.5, 107.6)}  # population: (HV, HV std, minutes)
THESIS_TABLE_5_5 = {  # method: coverage cost x 1e-2 at deployment budget 15 / 30 / 45 (None: not in the thesis)
    "no_decomposition": ("No decomposition", (0.365, 0.153, 0.056)),
    "dec_random_allocation": ("Dec + random allocation (random non-empty teams, the thesis's)", (0.732, 0.401, 0.062)),
    "dec_uniform_robots": ("Dec + uniform random robots (ours: each robot to a uniform region, regions may stay "
                           "empty)", None),
}
THESIS_EGGAN_5_5 = (0.049, 0.018, 0.007)  # Dec + EG-GAN, best front point within the budget
TERRAIN_COLOURS = ["#3b7dd8", "#8c6d46", "#b8d98a", "#9a9a9a"]  # Water, Mountain, Plain, City
SPECIES_COLOURS = ["#d62728", "#ff7f0e", "#1f77b4"]  # ground, aerial, aquatic
SPECIES_NAMES = ["ground", "aerial", "aquatic"]


def section(reports_dir: Path, data_dir: Path) -> str:
    """Markdown for the team-formation section; figures go to reports_dir/figures/."""
    paths = {name: Path(data_dir) / relative for name, relative in [
        ("regions", "regions.parquet"), ("purity", "teams/purity.parquet"),
        ("nsga2", "teams/nsga2.parquet"), ("fronts", "teams/fronts.parquet"),
        ("coverage", "teams/coverage.parquet"), ("trajectories", "teams/trajectories.parquet")]}
    eggan_paths = {name: Path(data_dir) / relative for name, relative in [
        ("queries", "teams/eggan_queries.parquet"), ("eggan_fronts", "teams/eggan_fronts.parquet"),
        ("examples", "teams/coverage_examples.parquet")]}
    missing = [str(path) for path in paths.values() if not path.exists()]
    if missing:
        return ("## Multi-robot team formation (thesis 5.2)\n\nNot run yet: missing "
                + ", ".join(missing) + " (stages `decompose` and `teams_baselines`).\n")
    regions = read_table(paths["regions"], "regions")
    purity = read_table(paths["purity"], "regions_purity")
    timings = read_timings(Path(reports_dir) / "timings.json")
    eggan = None
    if all(path.exists() for path in eggan_paths.values()):
        eggan = Eggan(read_table(eggan_paths["queries"], "teams_eggan_queries"),
                      read_table(eggan_paths["eggan_fronts"], "teams_eggan_fronts"),
                      read_table(eggan_paths["examples"], "teams_coverage_examples"),
                      pd.DataFrame(timings.get("teams_eggan", {}).get("queries", []),
                                   columns=["chip_id", "seed", "milliseconds", "front_seconds"]))
    heldout_paths = [*(Path(data_dir) / f"teams/heldout_{name}.parquet" for name in ("fronts", "picks")),
                     Path(reports_dir) / "metrics/teams_heldout.json"]
    heldout = None
    if all(path.exists() for path in heldout_paths):
        heldout = (read_table(heldout_paths[0], "teams_heldout_fronts"),
                   read_table(heldout_paths[1], "teams_heldout_picks"), read_json(heldout_paths[2]))
    training = _read_training(Path(reports_dir))
    fronts = read_table(paths["fronts"], "teams_fronts")
    coverage = read_table(paths["coverage"], "teams_coverage")
    trajectories = read_table(paths["trajectories"], "teams_trajectories")
    figures = Path(reports_dir) / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    _plot_decomposition(regions, figures / "teams_decomposition.png")
    _plot_fronts(fronts, eggan, regions, figures / "teams_pareto.png")
    if eggan is not None:
        _plot_coverage_examples(regions, eggan.examples, figures / "teams_coverage.png")
    if training is not None:
        _plot_training(training[0], figures / "teams_training.png")
    _plot_trajectories(regions, trajectories, figures / "teams_trajectories.png")

    n_chips = regions.chip_id.nunique()
    n_test = regions[regions.split == "test"].chip_id.nunique()
    n_regions = int(regions.region.max()) + 1
    weight = float(regions.terrain_weight.iloc[0])
    synthetic = regions.chip_id.str.startswith("synthetic-").all()
    source = ("synthetic label chips in the DroneDeploy PNG format (the dataset cannot be downloaded "
              "here; generated rivers, lakes, vegetated hills, fields and city blocks)" if synthetic
              else "DroneDeploy label chips")
    return "\n".join([
        "## Multi-robot team formation (thesis 5.2)",
        "",
        f"Terrain: {n_chips} chips ({n_test} test), {source}; each chip split into K = {n_regions} "
        f"regions that follow its terrain (Voronoi cells in position + terrain-class space, terrain weight "
        f"{weight:g}). Coverage cost: for each region, the spectral ergodic metric of its team (20 "
        "observations per robot, trajectories optimised by gradient descent, speeds x 0.003 per step) "
        "divided by the metric's expected value for one observation at a random point of the region, "
        "weighted by the region's share of the chip, summed over regions. So 1/N means every region is "
        "covered as well as by N random glances; a region without robots costs what the metric gives for "
        "no observation (no constant is chosen). Evaluator: the ergodic trajectory optimiser for every "
        "number below.",
        "",
        _purity_table(purity, weight),
        "",
        "![Chips and their regions](figures/teams_decomposition.png)",
        "",
        "### Table 5.4: NSGA-II and EG-GAN (hypervolume, spend, time to a measured front)",
        "",
        (_table_5_4(heldout[0], timings, eggan, training[1] if training is not None else {})
         if heldout is not None and eggan is not None else
         "Not run yet: stages `teams_eggan` and `teams_heldout` (every front re-measured at held-out seeds)."),
        "",
        *(_training_notes(*training) if training is not None else []),
        *(_chip_count(heldout[2]) if heldout is not None else []),
        "![Fig. 5.3: fronts on one test chip and two EG-GAN allocations](figures/teams_pareto.png)",
        "",
        "### Table 5.5: coverage cost (x 1e-2) at a deployment budget, reported at held-out seeds",
        "",
        (_table_5_5_heldout(heldout[1], heldout[2]["heldout_seeds"]) if heldout is not None else
         "Not run yet: stage `teams_heldout`."),
        "",
        "As the thesis measured it (a front's best point selected and reported at the same robot-start seed), on "
        f"{coverage.chip_id.nunique()} test chips:",
        "",
        _table_5_5(coverage, eggan),
        "",
        *(["![Fig. 5.4: coverage of the three methods on three test chips](figures/teams_coverage.png)", ""]
          if eggan is not None else ["EG-GAN: not run yet (stage `teams_eggan`).", ""]),
        "![Trajectories of a front allocation](figures/teams_trajectories.png)",
        "",
    ])


def _chip_count(metrics: dict) -> list[str]:
    """How many training chips pay: the committed chip-count pieces (validation hypervolume per training chip count,
    each a generator trained on that many chips and scored on the validation chips), or what is missing."""
    pieces = pd.DataFrame(metrics.get("chip_count", []))  # teams_heldout's summary (teams.chip_count.SUMMARY)
    stale = metrics.get("stale_chip_count_pieces", [])
    lines = ["**Training chips** (generators trained on N chips, scored on the validation chips at every search seed; "
             "`robocompose teams chip-count`):", ""]
    if not len(pieces):
        return lines + [f"No piece of the current settings and code yet ({len(stale)} stale).", ""]
    by_count = pieces.groupby("train_chips")
    rows = [(n, _mean_std(group.validation_hypervolume), ", ".join(map(str, sorted(group.seed))),
             f"{group.distinct_teams.mean():,.0f}", f"{group.training_seconds.mean() / 60:.1f}")
            for n, group in by_count]
    lines += markdown_table(["training chips", "validation hypervolume (mean ± sd over seeds)", "training seeds",
                             "distinct teams optimised", "training (min)"], rows)
    means = by_count.validation_hypervolume.mean()
    lines += ["", f"At the same training length (iterations, tasks per iteration), {means.idxmax()} training chips "
              f"score highest ({means.max():.2f}); each count's generators are scored on the same validation chips, "
              "none of which any count trains on."]
    if stale:
        lines += ["", f"{len(stale)} stale piece(s) of other settings or code, not used: {', '.join(stale)}."]
    return lines + [""]


def _purity_table(purity: pd.DataFrame, weight: float) -> str:
    means = purity.groupby("method").purity.agg(["mean", "std"])
    paired = purity.pivot(index="chip_id", columns="method", values="purity")
    wins = int((paired["terrain"] > paired["voronoi"]).sum())
    rows = [(f"terrain-driven (weight {weight:g})", means.loc["terrain"]),
            ("random-seed Voronoi, same seeds and Lloyd steps (weight 0)", means.loc["voronoi"])]
    return "\n".join([
        *markdown_table(["decomposition", "mean region purity (share of the dominant terrain)"], rows,
                        formats=[None, lambda m: f"{m['mean']:.3f} ± {m['std']:.3f}"]),
        "", f"Over all {len(paired)} chips; the terrain-driven regions are purer on {wins} of them. Regions may "
        "be split into several pieces (a region is a terrain class near its centre, not a convex cell)."])


def _mean_std(values: pd.Series, scale: float = 1.0, digits: int = 2) -> str:
    values = values.to_numpy(dtype=float) * scale
    if not len(values):
        return "-"
    return f"{values.mean():.{digits}f} ± {values.std():.{digits}f}"


@dataclass
class Eggan:
    """The outputs of the teams_eggan stage."""

    queries: pd.DataFrame  # chip x seed: hypervolume, distinct, front_size
    fronts: pd.DataFrame  # the query fronts
    examples: pd.DataFrame  # Fig. 5.4's observations
    milliseconds: pd.DataFrame  # chip x seed: the generator's wall time per query


def _read_training(reports_dir: Path) -> tuple[pd.DataFrame, dict] | None:
    """EG-GAN's training log and metrics (teams_eggan), or None before that stage ran."""
    log, metrics = reports_dir / "plots/teams_eggan.csv", reports_dir / "metrics/teams_eggan.json"
    if not (log.exists() and metrics.exists()):
        return None
    return pd.read_csv(log), read_json(metrics)


def _training_notes(log: pd.DataFrame, metrics: dict) -> list[str]:
    """What the training log says: the validation curve, the discriminator, the region-cost model's error."""
    notes = [f"EG-GAN training: {metrics['iterations']} iterations; {metrics['distinct_teams']} teams optimised "
             f"for training against {metrics['team_lookups']} team look-ups."]
    if "validation_hypervolume_last" in metrics:
        notes.append(f"Validation hypervolume (held-out training chips, 64 z, the optimiser): "
                     f"{metrics['validation_hypervolume_first']:.2f} at the first check, best "
                     f"{metrics['validation_hypervolume_best']:.2f}, last "
                     f"{metrics['validation_hypervolume_last']:.2f}.")
    chance = metrics.get("d_at_chance")
    if chance is not None:
        notes.append(f"Discriminator accuracy over the last tenth of training: {metrics['d_accuracy_final']:.2f}"
                     + (" -- **FLAG: at chance, the generator got no signal**." if chance else "."))
    if "model_heldout_log_rmse" in metrics:
        notes.append(f"Training's team costs came from a learned region-cost model (the optimiser for "
                     f"{metrics['model_teams']} fitted teams); on {metrics['model_heldout_n']} held-out optimised "
                     f"teams its log-cost RMSE is {metrics['model_heldout_log_rmse']:.2f} (R^2 "
                     f"{metrics['model_heldout_log_r2']:.2f}, Spearman {metrics['model_heldout_spearman']:.2f}, "
                     f"median relative error {metrics['model_heldout_median_relative_error']:.0%})"
                     + (f"; on each round's new teams before it saw them, RMSE "
                        f"{metrics['model_prospective_log_rmse']:.2f} (median relative error "
                        f"{metrics['model_prospective_median_relative_error']:.0%})"
                        if "model_prospective_log_rmse" in metrics else "")
                     + ". It steers training only: every number in the tables comes from the optimiser.")
    return [" ".join(notes), "", "![EG-GAN training](figures/teams_training.png)", ""]


def _plot_training(log: pd.DataFrame, path: Path) -> None:
    """EG-GAN's training curves: validation hypervolume, discriminator accuracy, generated deployment."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.4))
    if "validation_hypervolume" in log:
        checked = log.dropna(subset=["validation_hypervolume"])
        axes[0].plot(checked.iteration, checked.validation_hypervolume, marker="o")
    axes[0].set(title="validation hypervolume (64 z, optimiser)", xlabel="iteration")
    axes[1].plot(log.iteration, log.d_accuracy)
    axes[1].axhline(0.5, color="grey", linestyle=":")
    axes[1].set(title="discriminator accuracy (0.5 = chance)", xlabel="iteration")
    axes[2].plot(log.iteration, log.gen_deployment_cost_mean, label="X_gen")
    axes[2].plot(log.iteration, log.pop_deployment_cost_mean, label="X_pop")
    axes[2].set(title="robots deployed (mean)", xlabel="iteration")
    axes[2].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


THESIS_HYPERVOLUME = {"nsga2:fractions:20": "9.4 ± 1.0", "nsga2:fractions:50": "11.9 ± 1.5", "eggan": "11.8 ± 0.8"}
THESIS_MINUTES = {"nsga2:fractions:20": "43.1", "nsga2:fractions:50": "107.6", "eggan": "0.02"}
_KINDS = ("nsga2", "nsga2-matched", "random", "eggan")


def _method_order(method: str) -> tuple:
    """Thesis genome first, then other genomes, NSGA-II at EG-GAN's spend, random fronts, EG-GAN."""
    kind, *rest = method.split(":")
    return (_KINDS.index(kind) if kind in _KINDS else len(_KINDS), rest[0] != "fractions" if rest else False,
            int(rest[-1]) if rest and rest[-1].isdigit() else 0, method)


def _seconds(method: str, timings: dict, eggan: Eggan) -> pd.Series:
    """Wall times (s) to a method's measured front, one per run (empty: not timed)."""
    kind, *rest = method.split(":")
    if kind == "eggan":
        return eggan.milliseconds.front_seconds.dropna()
    if kind not in ("nsga2", "nsga2-matched"):
        return pd.Series(dtype=float)
    stage, key = ("teams_eggan", "nsga2_alone") if kind == "nsga2" else ("teams_heldout", "matched_runs")
    runs = pd.DataFrame(timings.get(stage, {}).get(key, []), columns=["genome", "population", "seconds"])
    return runs[(runs.genome == rest[0]) & (runs.population == int(rest[1]))].seconds


def _seconds_cell(seconds: pd.Series) -> str:
    """Wall times as mean ± sd, or the one run's, or "-"."""
    if len(seconds) == 1:
        return f"{seconds.iloc[0]:.1f} (one run)"
    return _mean_std(seconds, digits=1) if len(seconds) else "-"


def _generators_as_one(table: pd.DataFrame, keys: list[str], value: str) -> tuple[pd.DataFrame, pd.Series]:
    """`table` with the rows of every EG-GAN generator ("eggan:<seed>") replaced by their mean per `keys` (method
    "eggan"), and each generator's mean `value` (the spread across generators)."""
    generators = table[table.method.str.startswith("eggan:")]
    per_generator = generators.groupby("method")[value].mean()
    numeric = [c for c in generators.columns if c not in keys + ["method", "title"]]
    mean = generators.groupby(keys, as_index=False)[numeric].mean()
    mean = mean.assign(method="eggan", title=f"EG-GAN, mean of {len(per_generator)} generator"
                                             f"{'s' if len(per_generator) > 1 else ''}")
    return pd.concat([table[~table.method.str.startswith("eggan:")], mean], ignore_index=True), per_generator


def _table_5_4(fronts: pd.DataFrame, timings: dict, eggan: Eggan, training: dict) -> str:
    """Table 5.4 from every method's fronts, each re-measured at the held-out seeds (teams_heldout)."""
    from scipy.stats import wilcoxon

    from robocompose.search.significance import holm

    fronts, per_generator = _generators_as_one(fronts, ["chip_id", "seed"], "heldout_hypervolume")
    methods = sorted(fronts.method.unique(), key=_method_order)
    titles = fronts.groupby("method").title.first()
    by_method = {m: fronts[fronts.method == m].set_index(["chip_id", "seed"]) for m in methods}
    seconds = {m: _seconds(m, timings, eggan) for m in methods}
    rows = [(titles[m], THESIS_HYPERVOLUME.get(m, "-"), THESIS_MINUTES.get(m, "-"),
             _mean_std(by_method[m].hypervolume), _mean_std(by_method[m].heldout_hypervolume),
             f"{by_method[m].distinct_teams.mean():,.0f}",
             _seconds_cell(seconds[m]), len(by_method[m])) for m in methods]
    lines = markdown_table(["method", "thesis HV", "thesis runtime (min)", "HV at its search seed",
                            "HV re-measured at held-out seeds", "distinct teams optimised (mean)",
                            "time to a measured front (s)", "chip x seed"], rows)
    generator = by_method["eggan"].heldout_hypervolume
    full = [m for m in methods if m.startswith("nsga2:") and m.endswith(":50")]
    best = max(full, key=lambda m: by_method[m].heldout_hypervolume.mean()) if full else None
    notes, goal = [], []
    if best is not None and "random:512" in by_method:
        share = generator.mean() / by_method[best].heldout_hypervolume.mean()
        random_gap = (generator - by_method["random:512"].heldout_hypervolume).dropna()
        speed = (seconds[best].mean() / seconds["eggan"].mean()
                 if len(seconds[best]) and len(seconds["eggan"]) else float("nan"))
        met = share >= 0.95 and random_gap.mean() > 0 and speed >= 20
        goal = [verdict("Goal (EG-GAN >= 95% of the best NSGA-II:50 row, above the random-512 front, >= 20x "
                             "faster to a measured front; held-out seeds)", held(met),
                             f"EG-GAN reaches {share:.0%} of {titles[best]} ({generator.mean():.2f} vs "
                             f"{by_method[best].heldout_hypervolume.mean():.2f}), {random_gap.mean():+.2f} over the "
                             f"random-512 front (higher on {int((random_gap > 0).sum())} of {len(random_gap)} chip x "
                             f"seed pairs), and measures its front {speed:,.1f}x faster than that NSGA-II row "
                             f"({seconds['eggan'].mean():.1f} s against {seconds[best].mean():.1f} s)."), ""]
    tests = {}
    for m in methods:
        if m == "eggan":
            continue
        gap = (generator - by_method[m].heldout_hypervolume).dropna()
        tests[m] = (gap, wilcoxon(gap).pvalue if len(gap) and gap.abs().sum() > 0 else 1.0)
    adjusted = holm({m: p for m, (_, p) in tests.items()})
    lines += ["", "EG-GAN against each row, paired by chip x seed on the held-out hypervolume (Wilcoxon "
              f"signed-rank, Holm-corrected over the {len(tests)} comparisons):", ""]
    lines += markdown_table(["method", "EG-GAN minus method", "EG-GAN higher", "p", "Holm p"],
                            [(titles[m], f"{gap.mean():+.2f}", f"{int((gap > 0).sum())} of {len(gap)}", p, adjusted[m])
                             for m, (gap, p) in tests.items()], formats=[None, None, None, "{:.3g}", "{:.3g}"])
    notes.append(f"EG-GAN: {len(per_generator)} independently trained generator"
                 f"{'s' if len(per_generator) > 1 else ''} (training seeds "
                 f"{', '.join(m.split(':')[1] for m in per_generator.index)}), each queried on every chip x seed; "
                 "its rows are their mean, and the held-out hypervolume of each generator is "
                 + ", ".join(f"{v:.2f}" for v in per_generator)
                 + (f" (sd across generators {per_generator.std():.2f})." if len(per_generator) > 1 else
                    " (one generator: no spread across training seeds yet)."))
    curse = {m: (by_method[m].hypervolume - by_method[m].heldout_hypervolume).mean() for m in methods}
    notes.append("Re-measured at the held-out seeds, every front loses what its selection at one seed won (mean "
                 "hypervolume lost: " + ", ".join(f"{titles[m]} {curse[m]:.2f}" for m in methods) + ").")
    if "nsga2:fractions:50" in by_method and "nsga2:share_split:50" in by_method:
        gain = (by_method["nsga2:share_split:50"].heldout_hypervolume
                - by_method["nsga2:fractions:50"].heldout_hypervolume).dropna()
        notes.append(f"The genome: the same NSGA-II:50 on share x split genes against the thesis's raw fractions, "
                     f"{gain.mean():+.2f} held-out hypervolume (higher on {int((gain > 0).sum())} of {len(gain)}); "
                     "a mutated raw fraction mostly adds robots (the first population's genes average ~0.06, a "
                     "redraw 0.5).")
    forward = eggan.milliseconds.milliseconds.dropna()
    notes.append("Spend: the distinct teams a method had the ergodic optimiser plan (one team = one region's robots), "
                 "what measuring its answer costs; EG-GAN's own training spent "
                 f"{training.get('distinct_teams', 'its budget of')} teams once for all chips. Time to a "
                 "measured front: an NSGA-II row's is that row run alone from an empty team-cost memo on the first "
                 "chip and seed (the stage steps a chip's NSGA-II rows together over one memo, a saving a user "
                 "running one of them would not have); EG-GAN's, per chip x seed, the query (noise, forward pass, "
                 f"rounding: {forward.mean():.2f} ms of it) plus the optimiser on every distinct allocation it "
                 "draws. One thread each. The NSGA-II row at EG-GAN's spend stops after the generation at which it "
                 "has optimised as many teams as EG-GAN's query did on that chip and seed. The NSGA-II rows and "
                 "EG-GAN's queries are timed in the same run of stage teams_eggan, one after the other, so the "
                 "speed ratio compares them under one machine load.")
    return "\n".join(goal + lines + [""] + [" ".join(notes)])


def _table_5_5(coverage: pd.DataFrame, eggan: Eggan | None) -> str:
    budgets = sorted(coverage.budget.unique())
    header = ["method", *[f"{'thesis ' if i == 0 else ''}<= {b}" for i, b in enumerate(budgets)],
              *[f"{'ours ' if i == 0 else ''}<= {b}" for i, b in enumerate(budgets)]]
    table, means = [], {}
    for method, (name, thesis) in THESIS_TABLE_5_5.items():
        rows = coverage[coverage.method == method]
        values = [rows[rows.budget == b].coverage_cost for b in budgets]
        means[method] = [v.mean() for v in values]
        table.append((name, *(map(str, thesis) if thesis else ["-"] * len(budgets)),
                      *(_mean_std(v, 100, 3) for v in values)))
    pairs = {method: frozenset(zip(rows.chip_id, rows.seed, strict=True))
             for method, rows in coverage.groupby("method")}
    notes = []
    if eggan is not None:
        cells, means["dec_eggan"] = [], []
        wanted = pd.MultiIndex.from_tuples(sorted(next(iter(pairs.values()))), names=["chip_id", "seed"])
        for budget in budgets:
            within = (eggan.fronts[eggan.fronts.deployment_cost <= budget]
                      .groupby(["chip_id", "seed"]).coverage_cost.min().reindex(wanted))
            cells.append(_mean_std(within, 100, 3) if within.notna().all() else
                         f"{_mean_std(within.dropna(), 100, 3)} ({within.isna().sum()} without a front point)")
            means["dec_eggan"].append(within.mean())
        queried = frozenset(zip(eggan.queries.chip_id, eggan.queries.seed, strict=True))
        pairs["dec_eggan"] = frozenset(wanted) if frozenset(wanted) <= queried else queried
        table.append(("Dec + EG-GAN (best front point within the budget)", *map(str, THESIS_EGGAN_5_5), *cells))
        best = [min(means, key=lambda m: means[m][i]) for i in range(len(budgets))]
        best_at = [b for b, m in zip(budgets, best, strict=True) if m == "dec_eggan"]
        where = ", ".join(f"<= {b}" for b in best_at) or "no budget"
        notes.append(verdict("Dec + EG-GAN best at every budget, selected and reported at one seed (thesis: it is)",
                             held(len(best_at) == len(budgets)), f"(best at {where})."))
    order = [nd < ra for nd, ra in zip(means["no_decomposition"], means["dec_random_allocation"], strict=True)]
    notes.append(verdict("No decomposition < Dec + random at each budget, one seed (thesis: at every budget)",
                         held(all(order)),
                         "(" + ", ".join(f"{'holds' if o else 'does not hold'} at <= {b}"
                                         for o, b in zip(order, budgets, strict=True)) + ")."))
    same = len(set(pairs.values())) == 1
    empty = coverage.assign(any_empty=coverage.empty_regions > 0).pivot_table(
        index="method", columns="budget", values="any_empty", aggfunc="mean")
    lines = markdown_table(header, table)
    lines += ["", f"Ours: mean ± std over {coverage.chip_id.nunique()} test chips x {coverage.seed.nunique()} "
              "seeds, " + ("every row on the same chip x seed pairs" if same else
                          "WARNING: the rows do not cover the same chip x seed pairs") +
              ". The joint plan without decomposition is scored by the regions its observations fall in.",
              *[line for note in notes for line in ("", note)],
              "", "Why our values are far (more than 10x) above the thesis's: our cost is in units of one "
              "random glance per region, the thesis's is the raw ergodic metric (its public code reports "
              "per-region metrics of ~5e-4), so only the ordering of the rows compares. A region left "
              "without observations costs its area share x the metric of no observation (about 4 for "
              "K = 8), so a row's mean mostly reflects how often that happens: share of draws with at "
              "least one empty region, "
              + "; ".join(f"{THESIS_TABLE_5_5[method][0]}: "
                          + ", ".join(f"{share:.0%} at <= {b}" for b, share in row.items())
                          for method, row in empty.iterrows()) + "."]
    return "\n".join(lines)


def _table_5_5_heldout(picks: pd.DataFrame, heldout_seeds: list[int]) -> str:
    """Table 5.5 with every row's cost the mean over held-out seeds; a front's point picked at its search seed."""
    budgets = sorted(picks.budget.unique())
    pairs = picks[["chip_id", "seed"]].drop_duplicates()
    by_generator = picks[picks.method.str.startswith("eggan:")].groupby(["budget", "method"]).heldout_mean.mean()
    picks, _ = _generators_as_one(picks, ["chip_id", "seed", "budget"], "heldout_mean")
    methods = [*[m for m in THESIS_TABLE_5_5 if m in set(picks.method)],
               *sorted(set(picks.method) - set(THESIS_TABLE_5_5), key=_method_order)]
    rows = []
    for method in methods:
        chosen = picks[picks.method == method]
        thesis = (THESIS_TABLE_5_5[method][1] if method in THESIS_TABLE_5_5 else
                  THESIS_EGGAN_5_5 if method == "eggan" else None)
        cells = []
        for budget in budgets:
            values = chosen[chosen.budget == budget].heldout_mean
            missing = len(pairs) - len(values)
            cells.append(_mean_std(values, 100, 3) + (f" ({missing} without a point)" if missing else ""))
        title = chosen.title.iloc[0] + ("" if chosen.selected_cost.isna().all() else " (best within the budget)")
        rows.append((title, *(map(str, thesis) if thesis else ["-"] * len(budgets)), *cells))
    header = ["method", *[f"thesis <= {b}" for b in budgets], *[f"ours <= {b}" for b in budgets]]
    means = picks.groupby(["budget", "method"]).heldout_mean.mean()
    best = {b: means[b].idxmin() for b in budgets}
    titles = picks.groupby("method").title.first()
    lead = ([verdict("Dec + EG-GAN lowest at every budget, at held-out seeds (thesis: it is)",
                     held(all(m == "eggan" for m in best.values())),
                     "Lowest: " + "; ".join(f"<= {b}: {titles[m]} ({means[b, m] * 100:.3f})" for b, m in best.items())
                     + "."), ""]
            if "eggan" in titles else [])
    lines = lead + markdown_table(header, rows)
    selected = picks.dropna(subset=["selected_cost"])
    ratio = (selected.heldout_mean / selected.selected_cost).groupby(selected.method).median()
    noise = (picks.heldout_sd / picks.heldout_mean).median()
    lines += ["", f"Ours: mean ± std over {pairs.chip_id.nunique()} test chips x {pairs.seed.nunique()} search "
              f"seeds; each cost is the mean over {len(heldout_seeds)} held-out robot-start seeds ({heldout_seeds}), "
              "none of which any "
              "method searched or selected on. A front's point is chosen at its own search seed (the lowest cost "
              "within the budget there) and reported at the held-out seeds; the single draws select nothing. "
              "Held-out over selection-seed cost of the chosen points (median): "
              + ", ".join(f"{selected[selected.method == m].title.iloc[0]} {r:.2f}x" for m, r in ratio.items())
              + f". The optimiser's own seed-to-seed noise: a chosen allocation's cost varies by a median "
              f"{noise:.0%} (sd over mean) across the held-out seeds. EG-GAN's row is the mean of its generators' "
              "picks; the spread across generators (sd of each generator's mean x 1e-2): "
              + ", ".join(f"{by_generator[b].std() * 100:.3f} at <= {b}" if by_generator[b].size > 1 else
                          f"- at <= {b} (one generator)" for b in budgets if b in by_generator.index) + "."]
    if "eggan" in titles:
        lines += ["", *_table_5_5_tests(picks, budgets, titles)]
    return "\n".join(lines)


def _table_5_5_tests(picks: pd.DataFrame, budgets: list[int], titles: pd.Series) -> list[str]:
    """EG-GAN against every other row at every budget, paired by chip x seed on the held-out cost (Wilcoxon
    signed-rank, Holm-corrected over all of them: one family)."""
    from scipy.stats import wilcoxon

    from robocompose.search.significance import holm

    cost = picks.pivot_table(index=["budget", "chip_id", "seed"], columns="method", values="heldout_mean")
    tests = {}
    for method in [m for m in titles.index if m != "eggan"]:
        for budget in budgets:
            gap = (cost.loc[budget, "eggan"] - cost.loc[budget, method]).dropna()  # < 0: EG-GAN's pick costs less
            if len(gap):
                tests[(method, budget)] = (gap, wilcoxon(gap).pvalue if gap.abs().sum() > 0 else 1.0)
    adjusted = holm({f"{m}@{b}": p for (m, b), (_, p) in tests.items()})
    return ["EG-GAN against each row at each budget, paired by chip x seed on the held-out cost (Wilcoxon signed-rank, "
            f"Holm-corrected over the {len(tests)} comparisons):", "",
            *markdown_table(["method", "budget", "EG-GAN minus method (x 1e-2)", "EG-GAN lower", "p", "Holm p"],
                            [(titles[m], f"<= {b}", f"{gap.mean() * 100:+.3f}", f"{int((gap < 0).sum())} of {len(gap)}",
                              p, adjusted[f"{m}@{b}"]) for (m, b), (gap, p) in tests.items()],
                            formats=[None, None, None, None, "{:.3g}", "{:.3g}"])]


def _chip_background(source: str) -> tuple[np.ndarray, np.ndarray]:
    from robocompose.teams.chips import CLASS_TO_TERRAIN, read_label_png

    classes, _ = read_label_png(Path(source))
    terrain = CLASS_TO_TERRAIN[classes]
    rgb = np.array([[int(c[i:i + 2], 16) for i in (1, 3, 5)] for c in TERRAIN_COLOURS], dtype=np.uint8)
    return rgb[terrain], terrain


def _draw_chip(axis, chip_rows: pd.DataFrame) -> None:
    from robocompose.teams.decompose import chip_decomposition

    image, terrain = _chip_background(chip_rows.source.iloc[0])
    seeds = chip_rows.sort_values("region")[["seed_x", "seed_y"]].to_numpy()
    regions = chip_decomposition(chip_rows).raster(terrain)
    axis.imshow(image, extent=(0, 1, 1, 0), interpolation="nearest")
    axis.contour(np.linspace(0, 1, terrain.shape[1]), np.linspace(0, 1, terrain.shape[0]), regions,
                 levels=np.arange(len(seeds)) + 0.5, colors="black", linewidths=0.8)
    axis.scatter(seeds[:, 0], seeds[:, 1], s=8, c="black")
    axis.set(xlim=(0, 1), ylim=(1, 0), xticks=[], yticks=[])


def _plot_decomposition(regions: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    chip_ids = sorted(regions.chip_id.unique())[:6]
    figure, axes = plt.subplots(1, len(chip_ids), figsize=(2.4 * len(chip_ids), 2.8))
    for axis, chip_id in zip(np.atleast_1d(axes), chip_ids, strict=True):
        rows = regions[regions.chip_id == chip_id]
        _draw_chip(axis, rows)
        axis.set_title(f"{chip_id[-12:]} ({rows.split.iloc[0]})", fontsize=7)
    figure.legend(handles=[Patch(color=c, label=t) for c, t in
                           zip(TERRAIN_COLOURS, ["Water", "Mountain", "Plain", "City"], strict=True)],
                  loc="lower center", ncol=4, fontsize=7)
    figure.tight_layout(rect=(0, 0.08, 1, 1))
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _plot_fronts(fronts: pd.DataFrame, eggan: Eggan | None, regions: pd.DataFrame, path: Path) -> None:
    """Fig. 5.3: the fronts of NSGA-II (each genome and population) and EG-GAN on one test chip, at its search seed;
    two EG-GAN allocations."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chip_id, seed = fronts.sort_values(["chip_id", "seed"]).iloc[0][["chip_id", "seed"]]
    shown = {f"NSGA-II:{population} ({genome})": group for (genome, population), group in
             fronts[(fronts.chip_id == chip_id) & (fronts.seed == seed)].groupby(["genome", "population"])}
    examples = []
    if eggan is not None:
        generated = eggan.fronts[(eggan.fronts.chip_id == chip_id) & (eggan.fronts.seed == seed)]
        shown["EG-GAN"] = generated
        inside = generated[generated.coverage_cost < 0.25].sort_values("deployment_cost")
        if len(inside):
            examples = [inside.iloc[0], inside.iloc[len(inside) * 2 // 3]]
    figure, axes = plt.subplots(1, 1 + len(examples), figsize=(5 + 3.2 * len(examples), 3.6),
                                gridspec_kw={"width_ratios": [1.6] + [1] * len(examples)})
    axes = np.atleast_1d(axes)
    for label, group in shown.items():
        inside = group[group.coverage_cost < 0.25].sort_values("deployment_cost")
        axes[0].step(inside.deployment_cost, inside.coverage_cost, where="post", marker="o", markersize=3,
                     label=label)
    axes[0].set(xlabel="deployment cost (robots)", ylabel="coverage cost", yscale="log", xlim=(0, 60),
                title=f"Fronts on {chip_id} (seed {seed}), inside the reference box")
    axes[0].title.set_fontsize(8)
    axes[0].legend(fontsize=7)
    chip_rows = regions[regions.chip_id == chip_id]
    for axis, example in zip(axes[1:], examples, strict=True):
        _draw_chip(axis, chip_rows)
        counts = np.asarray(example.counts).reshape(len(chip_rows), -1)
        for (_, row), team in zip(chip_rows.sort_values("region").iterrows(), counts, strict=True):
            axis.text(row.seed_x, row.seed_y, "/".join(map(str, team)), fontsize=7, ha="center", va="bottom",
                      bbox={"facecolor": "white", "alpha": 0.7, "pad": 1, "linewidth": 0})
        axis.set_title(f"EG-GAN: {int(example.deployment_cost)} robots, cost {example.coverage_cost:.3f}\n"
                       "(ground/aerial/aquatic per region)", fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _plot_coverage_examples(regions: pd.DataFrame, examples: pd.DataFrame, path: Path) -> None:
    """Fig. 5.4: trajectories of Dec + EG-GAN, Dec + random allocation and no decomposition."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = [("dec_eggan", "Dec + EG-GAN"), ("dec_random_allocation", "Dec + random"),
               ("no_decomposition", "No decomposition")]
    chip_ids = sorted(examples.chip_id.unique())
    figure, axes = plt.subplots(len(chip_ids), 3, figsize=(7.5, 2.6 * len(chip_ids)), squeeze=False)
    for row_axes, chip_id in zip(axes, chip_ids, strict=True):
        for axis, (method, title) in zip(row_axes, methods, strict=True):
            _draw_chip(axis, regions[regions.chip_id == chip_id])
            for _, robot in examples[(examples.chip_id == chip_id) & (examples.method == method)].groupby("robot"):
                robot = robot.sort_values("step")
                axis.plot(robot.x, robot.y, "-", color=SPECIES_COLOURS[int(robot.species.iloc[0])], linewidth=0.7)
            axis.set_title(f"{title} ({chip_id[-12:]})", fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _plot_trajectories(regions: pd.DataFrame, trajectories: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chip_id = trajectories.chip_id.iloc[0]
    figure, axis = plt.subplots(figsize=(4.6, 4.6))
    _draw_chip(axis, regions[regions.chip_id == chip_id])
    for _, robot in trajectories.groupby("robot"):
        robot = robot.sort_values("step")
        species = int(robot.species.iloc[0])
        axis.plot(robot.x, robot.y, "-", color=SPECIES_COLOURS[species], linewidth=0.8, alpha=0.9)
        axis.plot(robot.x.iloc[0], robot.y.iloc[0], "o", color=SPECIES_COLOURS[species], markersize=3)
    for colour, name in zip(SPECIES_COLOURS, SPECIES_NAMES, strict=True):
        axis.plot([], [], color=colour, label=name)
    axis.legend(fontsize=7, loc="upper right")
    n_robots = trajectories.robot.nunique()
    axis.set_title(f"{n_robots} robots of a front allocation on {chip_id}", fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
