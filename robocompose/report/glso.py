"""Report section for the GLSO search (thesis 8): Figs. 8.1 and 8.2 (best so far vs evaluations), the final
best per method and task, the thesis's claims beside ours, and each task's best design (Fig. 7.2).

Built from the `glso` stage's outputs (data/glso/steps.parquet, data/glso/rollouts/: each task's best design's
rollout GIF and picture; reports/metrics/glso.json: every method's title and figure groups, the registry's as the
stage wrote them: this module imports no registry, and a method without a title stops the report; and the MPPI
setting the runs used, `glso.rung`'s or `evaluation.mppi`); every score is the real evaluator's (MPPI in pybullet
at that setting), the same for every method.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from robocompose.glso import GROUPS, REFERENCE, best_designs, best_so_far_curves, draw_curves, group_titles
from robocompose.io import read_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import ArtifactError
from robocompose.report.tables import markdown_table
from robocompose.report.verdicts import verdict


def method_titles(record: dict, ran: set[str], where: Path) -> list[dict]:
    """The methods a stage recorded (`record["methods"]`: `registry.describe`), checked to name every method
    that ran (`ran`) and to give each one's comparison families; ArtifactError naming the file otherwise."""
    methods = record.get("methods")
    if not isinstance(methods, list):
        raise ArtifactError(f"{where}: no record of the methods' titles (rerun its stage)")
    if not all(isinstance(m.get("families"), dict) for m in methods):  # a record of older code
        raise ArtifactError(f"{where}: no record of each method's comparison families (rerun its stage)")
    unknown = sorted(ran - set(group_titles(methods)))
    if unknown:
        raise ArtifactError(f"{where}: no title for methods {unknown} (rerun its stage)")
    return methods


def _evaluator_setting(record: dict, where: Path) -> str:
    """The MPPI setting the runs used, in words, from the stage's record (`rung`, `mppi`); ArtifactError naming
    the file if it has none."""
    mppi = record.get("mppi")
    if not isinstance(mppi, dict) or not isinstance(record.get("rung"), str):
        raise ArtifactError(f"{where}: no record of the MPPI setting its runs used (rerun its stage)")
    setting = f"MPPI {mppi['samples']} samples, horizon {mppi['horizon']}, {mppi['episode']} control steps"
    if record["rung"]:
        return f"fidelity rung **{record['rung']}** (`glso.rung`: {setting}), not the evaluator's `evaluation.mppi`"
    return f"the evaluator's setting, `evaluation.mppi` ({setting})"


def _plot(stats: pd.DataFrame, tasks: list[str], methods: dict[str, str], title: str, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tasks), figsize=(4.2 * len(tasks), 3.4), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        draw_curves(ax, stats, task, methods, "mean", "min", "max")
        ax.set_title(task)
        ax.set_xlabel("evaluations")
        ax.set_ylabel("best reward so far")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _final_table(final: pd.DataFrame, tasks: list[str], titles: dict[str, str]) -> list[str]:
    rows = []
    for method, title in titles.items():
        cells = []
        for task in tasks:
            v = final[(final.task == task) & (final.method == method)]["best_so_far"]
            cells.append(f"{v.mean():.3f} [{v.min():.3f}, {v.max():.3f}] (n={len(v)})" if len(v) else "-")
        rows.append((title, *cells))
    return markdown_table(["method", *tasks], rows)


def claims(final: pd.DataFrame, tasks: list[str], methods: list[dict]) -> list[str]:
    """The thesis's two claims, checked on the mean final best over seeds, per task (`methods`: the stage's
    record of the registry, which names each figure group's members)."""
    mean = final.groupby(["task", "method"])["best_so_far"].mean()
    titles = group_titles(methods)
    others = {group: [x for x in group_titles(methods, group) if x != REFERENCE] for group in GROUPS}
    out = []
    for task in tasks:
        m = mean[task]
        baselines = [x for x in others["baselines"] if x in m.index]
        if REFERENCE in m.index and baselines:
            held = max([REFERENCE, *baselines], key=lambda x: m[x]) == REFERENCE
            out.append(f"- {task}: GLSO best of Fig. 8.1 in these means: {'yes' if held else 'no'} "
                       f"(GLSO {m[REFERENCE]:.3f}; best other {titles[max(baselines, key=m.get)]} "
                       f"{max(m[b] for b in baselines):.3f}).")
        ablations = [x for x in others["ablations"] if x in m.index]
        if REFERENCE in m.index and ablations:
            held = len(ablations) == len(others["ablations"]) and all(m[x] < m[REFERENCE] for x in ablations)
            out.append(f"- {task}: all ablations worse than GLSO in these means: {'yes' if held else 'no'} ("
                       + "; ".join(f"{titles[x]} {m[x]:.3f}" for x in ablations) + ").")
    return out


def section(reports_dir: Path, data_dir: Path) -> str:
    title = "## GLSO search: latent BO against random, GA, MCTS and GHS (thesis 8)"
    steps_path = Path(data_dir) / "glso" / "steps.parquet"
    if not steps_path.exists():
        return f"{title}\n\nNot run yet: missing {steps_path} (stage `glso`).\n"
    steps = read_table(steps_path, "glso_steps")
    metrics_path = Path(reports_dir) / "metrics" / "glso.json"
    metrics = read_json(metrics_path)
    record = method_titles(metrics, set(steps["method"]), metrics_path)
    setting = _evaluator_setting(metrics, metrics_path)
    tasks = list(dict.fromkeys(steps["task"]))
    titles = {m: t for m, t in group_titles(record).items() if m in set(steps["method"])}
    figures = Path(reports_dir) / "figures"
    stats = best_so_far_curves(steps)
    for group, figure in GROUPS.items():
        number = figure.removeprefix("Fig. ").replace(".", "_")
        _plot(stats, tasks, group_titles(record, group),
              f"{figure}: GLSO and its {group}, mean best so far over seeds, band = min-max",
              figures / f"glso_fig{number}.png")
    final = steps.sort_values("step").groupby(["task", "method", "seed"], as_index=False).last()
    budget = int(steps["step"].max() + 1)
    seeds = sorted(set(steps["seed"]))
    share = steps.groupby("method").agg(repeats=("repeat", "mean"),
                                        invalid=("status", lambda s: float(np.mean(s != "ok"))),
                                        rejected=("rejected", "mean"))
    lines = [title, "",
             f"Every method had the same budget of **{budget} objective calls** per run, the same evaluator and "
             f"controller seed; seeds {seeds}, tasks {tasks}. Every call scored at {setting}. The thesis: 500 "
             "evaluations per method and task, 3 seeds, all four tasks; it reports curves only (no numbers).", "",
             "The accounting rule, one for every method: a call is every design sent to the evaluator, an MPPI "
             "episode or the evaluator's verdict that the design cannot be simulated (which the method is told as "
             "its original's invalid score: GLSO 3.8 / 4.0, RoboGrammar's -2.0 for MCTS, GHS, random search and "
             "the GA); a design seen again costs a call and returns its cached score. Designs a method discards "
             "before sending them (the grammar methods' depth limit and self-penetration check, random search's "
             "dataset filters, the GA's self-penetration check; GLSO has none) cost no call and are counted "
             "below. Best so far counts simulated designs only.", "",
             *markdown_table(["method", "repeats", "not simulated (invalid score)",
                              "discarded before a call, per call"],
                             [(t, *share.loc[m, ["repeats", "invalid", "rejected"]]) for m, t in titles.items()],
                             formats=[None, "{:.0%}", "{:.0%}", "{:.1f}"]), "",
             "![Fig. 8.1](figures/glso_fig8_1.png)", "", "![Fig. 8.2](figures/glso_fig8_2.png)", "",
             "Final best reward per method and task: mean [min, max] over seeds:", "",
             *_final_table(final, tasks, titles), "",
             "The thesis's claims on this smoke run (mean final best over seeds; too few calls and seeds for a "
             "verdict, which only the campaign below gives):", "", *claims(final, tasks, record)]
    lines += _best_designs(steps, Path(data_dir) / "glso" / "rollouts", figures, titles)
    return "\n".join(lines) + "\n"


def _best_designs(steps: pd.DataFrame, rollouts: Path, figures: Path, titles: dict[str, str]) -> list[str]:
    """Fig. 7.2: the picture of each task's best design, and its rollout GIF (both drawn by the `glso` stage)."""
    lines = ["", "Fig. 7.2: the best design found on each task (any method; MCAP logs for Foxglove beside the GIFs "
             "in `data/glso/rollouts/`):", ""]
    for row in best_designs(steps).itertuples():
        caption = f"{row.task}: {titles[row.method]} seed {row.seed}, reward {row.score:.3f}, design {row.design_id}"
        drawn = ((rollouts / f"{row.task}.png", f"glso_best_{row.task}.png", caption),
                 (rollouts / f"{row.task}.gif", f"glso_rollout_{row.task}.gif", f"{row.task} rollout"))
        for source, name, alt in drawn:
            if source.exists():
                figures.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(source, figures / name)
                lines.append(f"![{alt}](figures/{name})")
            else:
                lines.append(f"{alt}: not drawn yet ({source} missing: stage `glso`).")
    return lines


def _number(value: float, form: str) -> str:
    return "-" if pd.isna(value) else form.format(value)


def _median_iqr(values: pd.Series) -> str:
    v = values.dropna()
    if v.empty:
        return "-"
    return f"{v.median():.3f} [{v.quantile(0.25):.3f}, {v.quantile(0.75):.3f}] (n={len(v)})"


class Compared(NamedTuple):
    """What a test compared (`title`), the columns of the summary's `spend` holding the median calls and distinct
    designs per run behind it, and the protocol its verdicts name."""

    title: str
    calls: str
    distinct: str
    protocol: str


COMPARED = {"matched": Compared("best so far at K distinct designs", "calls_at_k", "k", "at K distinct designs"),
            "search": Compared("final best at the search rung", "calls", "distinct", "at the search rung"),
            "rescored": Compared("final best, re-scored", "calls", "distinct", "re-scored at the thesis setting"),
            "heldout": Compared("held-out best", "calls", "distinct", "under held-out scoring")}


def campaign_verdicts(tests: pd.DataFrame, on: str, alpha: float, methods: list[dict],
                      reference: str = REFERENCE) -> list[str]:
    """The thesis's claims for `reference` (GLSO or one of its arms), from the campaign's tests `on` one
    comparison (a key of `COMPARED`): a claim holds when `reference` beats every method of its family
    (`methods`: the stage's record of the registry) after Holm correction. A fresh-seed arm's reported best is
    the thesis's protocol, and its verdict says so."""
    titles = group_titles(methods)
    fresh = {m["name"] for m in methods if m.get("fresh_seeds")}
    families = {m["name"]: m["families"] for m in methods}
    protocol = ("under the thesis's protocol (a fresh controller seed per call: its reported best)"
                if on == "search" and reference in fresh else COMPARED[on].protocol)
    out = []
    mine = tests[(tests["on"] == on) & (tests["reference"] == reference)]
    for (task, family), group in mine.groupby(["task", "family"], sort=False):
        claim = (f"{titles[reference]} best of {GROUPS[family]}" if family == "baselines"
                 else f"all ablations worse than {titles[reference]} ({GROUPS[family]})")
        members = {m: titles[m] for m in families[reference][family]}  # registry.family: an arm's ablations are its own
        missing = [t for m, t in members.items() if m not in set(group["method"])]
        held = not missing and bool(group["better"].all())
        floor = float(group["holm_floor"].max())
        caveat = (f" (with these seed counts the family's largest Holm-adjusted p is at least {floor:.3f}, not "
                  f"below {alpha}: this campaign cannot show it)") if not held and floor >= alpha else ""
        caveat += f" (no runs yet of {', '.join(missing)})" if missing else ""
        detail = "; ".join(f"{titles[r.method]} p = {r.p_holm:.3f}" for r in group.itertuples())
        out.append("- " + verdict(f"{task}, {protocol}: {claim}", "holds" if held else "not shown",
                                  f"({detail}){caveat}."))
    return out


def _tests_table(tests: pd.DataFrame, spend: pd.DataFrame, titles: dict[str, str], on: list[str],
                 reference: str = REFERENCE) -> list[str]:
    """The tests of `reference` `on` these comparisons (keys of `COMPARED`), each beside what both sides spent to
    get there."""
    def spent(task: str, method: str, column: str) -> str:
        return f"{spend.loc[(task, reference), column]:g} / {spend.loc[(task, method), column]:g}"

    rows = []
    for r in tests[tests["on"].isin(on) & (tests["reference"] == reference)].itertuples():
        compared = COMPARED[r.on]
        rows.append((r.task, compared.title, titles[r.method], f"{r.n_reference} / {r.n_other}",
                     f"{spent(r.task, r.method, compared.calls)} calls, "
                     f"{spent(r.task, r.method, compared.distinct)} distinct",
                     r.p, r.p_holm, f"{r.median_difference:+.3f} [{r.ci_low:+.3f}, {r.ci_high:+.3f}]"))
    name = titles[reference]
    return [f"{name} against each method: one-sided Mann-Whitney U ({name} greater), Holm-corrected within its "
            f"family; median difference {name} - method with a bootstrap 95% interval.", "",
            *markdown_table(["task", "on", "method", f"n ({name} / other)", f"spend per run, median ({name} / other)",
                             "p", "p (Holm)", "median difference [95% CI]"], rows,
                            formats=[None] * 5 + ["{:.3f}", "{:.3f}"])]



def _pilot_lines(pilot: dict | None, methods: list[dict]) -> list[str]:
    """The pilot of GLSO's variants (`campaign.pilot_summary`): per variant its distinct designs, search best,
    that design's held-out mean and the held-out best, medians over its runs; the winner (`campaign.pilot_table`'s
    first row: among the variants reaching the summary's `distinct_target` distinct designs per 200 calls, the best
    held-out best)."""
    title = "#### The pilot: a GLSO whose window does not collapse"
    if pilot is None:
        return [title, "", "Not run yet (`robocompose glso-campaign pilot`, README): GLSO's variants are "
                "registered but unmeasured.", ""]
    titles = group_titles(methods)
    table = pd.DataFrame(pilot["methods"])
    progress = pilot["heldout_progress"] or {"complete": 0}
    lines = [title, "", f"{pilot['runs']} of {pilot['planned']} pilot runs committed ({pilot['directory']}), "
             f"{pilot['budget']} objective calls each at rung {pilot['rung']} (the ladder's cheapest: the variants "
             "are compared with one another, not with the baselines), every call at the campaign's one controller "
             f"seed; {progress['complete']} runs have their held-out pieces complete. The variants reaching "
             f"{pilot['distinct_target']} distinct designs per 200 calls (median) rank first (a fix must stop the "
             "collapse), then by the median held-out best, then by distinct designs; a repeat costs its call, as "
             "for every method.", ""]
    if table.empty:
        return lines
    lines += markdown_table(
        ["variant", "runs", "distinct designs, median", "search best, median", "its held-out mean, median",
         "held-out best, median"],
        [(titles[r.method], r.runs, f"{r.distinct:g}", _number(r.search, "{:.3f}"),
          _number(r.reported_heldout, "{:.3f}"), _number(r.heldout, "{:.3f}")) for r in table.itertuples()],
        align="lrrrrr")
    best = table.iloc[0]
    reaching = table.loc[table["reaches"], "method"]
    reach = "; ".join(titles[m] for m in reaching) or "none"  # "; ": titles hold commas
    winner = ("No winner yet: no variant has held-out scores (they are measured once every pilot run is "
              "finished)" if pd.isna(best["heldout"]) else
              f"Winner: **{titles[best['method']]}** ({best['distinct']:g} distinct designs, held-out best "
              f"{best['heldout']:.3f})" + ("" if best["reaches"] else "; it does not reach the target, and no "
                                           "variant does"))
    lines += ["", f"{winner}; variants reaching {pilot['distinct_target']} distinct designs per 200 calls: {reach}."
              + (" Interim: not every run is committed." if pilot["runs"] < pilot["planned"] else ""), ""]
    return lines


def _omnibus_lines(summary: dict, on: list[str], titles: dict[str, str]) -> list[str]:
    """The Kruskal-Wallis omnibus test over GLSO and the baselines `on` these comparisons (the summary's
    `omnibus`), one line each: are any of the methods distinguishable at all."""
    rows = [r for r in summary.get("omnibus", []) if r["on"] in on]
    return [f"Kruskal-Wallis over {', '.join(titles[m] for m in r['methods'])} ({COMPARED[r['on']].title}, "
            f"{r['task']}; runs {'/'.join(map(str, r['n']))}): H = {r['h']:.2f}, p = {r['p']:.3f}." for r in rows]


def _arm_lines(summary: dict, tests: pd.DataFrame, spend: pd.DataFrame, methods: list[dict]) -> list[str]:
    """GLSO's arms (the thesis-protocol arm, the improved GLSO, that GLSO on the thesis-scale VAE): per arm with
    runs, its tests against the baselines (and its own ablations) on every comparison and a verdict per protocol;
    nothing while no arm has runs."""
    titles = group_titles(methods)
    arms = list(dict.fromkeys(tests.loc[tests["reference"] != REFERENCE, "reference"])) if len(tests) else []
    if not arms:
        return []
    lines = ["#### GLSO's arms against the baselines", "",
             "Each arm is a GLSO run another way (its own rows in the tables above): the thesis's protocol "
             "(a fresh controller seed per call, repeats simulated again, no deduplication: its reported best is "
             "a maximum over noisy re-draws), GLSO variants that keep its window from collapsing, and the improved "
             "GLSO on the thesis-scale VAE (searched only once that VAE passed its gate). Each is tested against "
             "the baselines of Fig. 8.1 on every comparison, the thesis-scale one also against its own "
             "GLSO_nopred (its Fig. 8.2); a verdict names its protocol.", ""]
    for arm in arms:
        lines += [f"##### {titles[arm]}", "", *_tests_table(tests, spend, titles, list(COMPARED), arm), "",
                  *(verdict for on in COMPARED
                    for verdict in campaign_verdicts(tests, on, summary["alpha"], methods, arm)), ""]
    return lines


def campaign_section(reports_dir: Path) -> str:
    """The GLSO campaign (stage `glso_campaign`): the only source of verdicts on the thesis's search claims, per
    distinct design evaluated first (a repeat is a call but no new design), then per objective call (the
    thesis's axis)."""
    from robocompose.io.atomic import read_json

    title = "### The GLSO campaign: seeds, statistics, re-scored at the thesis setting"
    path = Path(reports_dir) / "metrics" / "glso_campaign.json"
    if not path.exists():
        return f"{title}\n\nNot run yet: missing {path} (stage `glso_campaign`).\n"
    summary = read_json(path)
    if summary["runs"] and "heldout_progress" not in summary:
        raise ArtifactError(f"{path}: no record of the held-out scoring (rerun stage glso_campaign)")
    if not summary["runs"]:
        return (f"{title}\n\nNo campaign run is committed yet (0 of {summary['planned']} planned; "
                "`robocompose glso-campaign run`, README). The searches above are a smoke run: the thesis's "
                "claims get no verdict from them.\n")
    finals, tests = pd.DataFrame(summary["finals"]), pd.DataFrame(summary["tests"])
    spend = pd.DataFrame(summary["spend"]).set_index(["task", "method"])
    methods = method_titles(summary, set(finals["method"]), path)
    titles = group_titles(methods)
    ran = spend.loc[[(task, method) for task in dict.fromkeys(finals["task"]) for method in titles
                     if (task, method) in spend.index]].reset_index()
    runs = finals.groupby(["task", "method"])
    k = ", ".join(f"{task}: K = {value}" for task, value in summary["k"].items())
    rung = f" at rung {summary['rung']} (the fidelity search rule's)" if summary.get("rung") else ""
    partial = (" The campaign is partial: every number and verdict below is interim until all planned runs are "
               "committed." if summary["runs"] < summary["planned"] else "")
    lines = [title, "", f"{summary['runs']} of {summary['planned']} planned runs committed, "
             f"{summary['budget']} objective calls each{rung}; each run's best simulated design re-scored at the "
             f"thesis setting with controller seeds {summary['rescore_seeds']} (never used in search).{partial}", "",
             "A call that sends a design the run sent before (a repeat) is served from the cache: a call all the "
             "same, but no new design, and the methods repeat very differently. So the methods are compared first "
             "per distinct design evaluated (the figure's right panels; a method's curve ends at its shortest "
             "run), then per objective call, the thesis's axis (left panels).", "",
             "![GLSO campaign](plots/glso_campaign.png)", "",
             f"#### Per distinct design (primary): every run at K distinct designs ({k})", "",
             "K is the fewest distinct designs any run of the task evaluated, so every run has a value there; best "
             "so far at the search rung (re-scores exist only for the final bests).", "",
             *_random_null_lines(Path(reports_dir), set(finals["method"]))]
    lines += markdown_table(
        ["method", "task", "distinct designs per run, median [IQR]", "K", "calls to reach K, median",
         "best so far at K distinct designs, median [IQR]"],
        [(titles[r.method], r.task, f"{r.distinct:g} [{r.distinct_q25:g}, {r.distinct_q75:g}]", r.k,
          f"{r.calls_at_k:g}", _median_iqr(runs.get_group((r.task, r.method))["matched"])) for r in ran.itertuples()],
        align="llrrrl")
    if not tests.empty:
        lines += ["", *_tests_table(tests, spend, titles, ["matched"]), "",
                  *_omnibus_lines(summary, ["matched"], titles), "",
                  "Verdicts at K distinct designs (search rung):", "",
                  *campaign_verdicts(tests, "matched", summary["alpha"], methods)]
    lines += ["", f"#### Per objective call (the thesis's axis): every run at {summary['budget']} calls", ""]
    lines += markdown_table(
        ["method", "task", "calls per run", "distinct designs per run, median", "final best at the search rung, "
         "median [IQR]", "re-scored, median [IQR]"],
        [(titles[r.method], r.task, f"{r.calls:g}", f"{r.distinct:g}",
          *(_median_iqr(runs.get_group((r.task, r.method))[column]) for column in ("search", "rescored")))
         for r in ran.itertuples()], align="llrrll")
    if tests.empty:
        alone = "Only GLSO has runs yet" if REFERENCE in set(finals["method"]) else "No GLSO runs yet"
        lines += ["", f"{alone}: nothing to compare."]
    else:
        lines += ["", *_tests_table(tests, spend, titles, ["search", "rescored"]), "",
                  *_omnibus_lines(summary, ["search", "rescored"], titles), "",
                  f"Verdicts (re-scored finals, {summary['budget']} calls):", "",
                  *campaign_verdicts(tests, "rescored", summary["alpha"], methods)]
    return "\n".join(lines + ["", *_heldout_lines(summary, finals, tests, spend, ran, methods), "",
                              *_pilot_lines(summary.get("pilot"), methods),
                              *_arm_lines(summary, tests, spend, methods)])


def _random_null_lines(reports_dir: Path, methods: set[str]) -> list[str]:
    """What random search draws from (its row's null), with the enumeration's share of too-small discards."""
    if "random" not in methods:
        return []
    from robocompose.io.atomic import read_json

    stats = reports_dir / "metrics" / "enumerate.json"
    rejected = read_json(stats)["grammar"]["rejected"] if stats.exists() else {}
    share = (f"; {rejected.get('too_few_links', 0) / sum(rejected.values()):.0%} of the enumeration's discarded "
             "candidates have fewer than 11 links" if rejected else "")
    return ["Random: the dataset's own enumeration, its filters included (>= 11 links, valid rest contacts"
            f"{share}), so it samples the designs GLSO's VAE was trained on. That is the right null for GLSO and a "
            "stronger baseline than the thesis's random search, which keeps whatever a random derivation gives.", ""]


def _heldout_lines(summary: dict, finals: pd.DataFrame, tests: pd.DataFrame, spend: pd.DataFrame,
                   ran: pd.DataFrame, methods: list[dict]) -> list[str]:
    """Held-out scoring: how far its pieces are measured (and the command that measures the rest); per method
    (the rows of `ran`) the reported bests beside their designs' held-out means, the inflation and the held-out
    bests with their thesis re-scores, over the runs whose pieces are complete; the tests and verdicts on the
    held-out bests."""
    progress, titles = summary["heldout_progress"], group_titles(methods)
    lines = [f"#### Under held-out scoring: each run's top {summary['heldout_top']} designs at fresh controller "
             "seeds", "",
             "A run scores each call once, with one controller seed, and its reported best is the largest of those "
             "noisy scores, so it is inflated (the winner's curse). Each run's "
             f"{summary['heldout_top']} best distinct designs by search score are re-measured at the search rung "
             f"with held-out controller seeds {summary['heldout_seeds']} (never used in search or re-scoring); the "
             "run's held-out best is the design of the highest held-out mean, re-scored at the thesis setting with "
             f"seeds {summary['rescore_seeds']}. Inflation is the reported best less its own design's held-out "
             "mean, beside the evaluator's seed-to-seed sd on the measured designs.", ""]
    missing = progress["planned"] - progress["evaluations"]
    status = (f"{progress['complete']} of {progress['runs']} runs have their held-out pieces complete "
              f"({progress['evaluations']} of {progress['planned']} held-out evaluations measured)")
    if missing or progress["rescores_missing"]:
        status += (f"; missing: {missing} of the held-out evaluations, {progress['rescores_missing']} thesis "
                   "re-scores of the held-out bests found so far. `robocompose glso-campaign heldout [--address "
                   "tcp://SCHEDULER:8786]` measures them (resumable), then stage `glso_campaign` summarises. Every "
                   "number below is over the complete runs only, and interim")
    lines += [status + ".", ""]
    done = finals[finals["heldout_complete"]]
    per_method = pd.DataFrame(summary["heldout"]).set_index(["task", "method"])

    def median(task: str, method: str, column: str) -> str:
        return _median_iqr(done.loc[(done["task"] == task) & (done["method"] == method), column])

    rows = []
    for r in ran.itertuples():
        h = per_method.loc[(r.task, r.method)]
        rows.append((titles[r.method], r.task, f"{h['complete']:g} / {h['runs']:g}",
                     median(r.task, r.method, "search"), median(r.task, r.method, "reported_heldout"),
                     _number(h["inflation"], "{:+.3f}"), _number(h["seed_sd"], "{:.3f}"),
                     median(r.task, r.method, "heldout"), median(r.task, r.method, "heldout_rescored")))
    lines += markdown_table(
        ["method", "task", "runs complete / runs", "reported best (search rung), median [IQR]",
         "held-out mean of that design, median [IQR]", "inflation, median", "seed-to-seed sd",
         "held-out best, median [IQR]", "its thesis re-score, median [IQR]"], rows, align="llrllrrll")
    if tests.empty or not (tests["on"] == "heldout").any():
        return lines + ["", "No verdict under held-out scoring yet: it needs complete GLSO runs and complete runs "
                            "of another method."]
    return lines + ["", *_tests_table(tests, spend, titles, ["heldout"]), "",
                    *_omnibus_lines(summary, ["heldout"], titles), "",
                    "Verdicts under held-out scoring (the held-out bests, at the search rung):", "",
                    *campaign_verdicts(tests, "heldout", summary["alpha"], methods)]

