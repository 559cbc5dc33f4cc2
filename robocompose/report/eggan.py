"""Report section for EG-GAN on modular robots (thesis ch. 4, 5.1): Table 5.1 (real-time methods), Table 5.2's
EG-GAN-crowding row beside the GA runs, the training budgets and surrogate error, the training curves, and
Fig. 5.1 (two test terrains, the generator's top designs, a random constraint and the designs that survive it).

Built from `train_eggan_modular` (reports/metrics/eggan_modular.json, reports/plots/eggan_modular_*.csv) and
`modular_realtime` (data/modular/realtime.parquet; reports/metrics/modular_realtime.json: the portfolio's designs,
DQN's symmetric-space ceiling and each learned row's mean and sd over its training seeds, `training_seeds`, which
Table 5.1 shows for those rows; data/modular/fig5_1.json, Fig. 5.1's generated designs); every distance is a pybullet
rollout, read from the test terrain's exhaustive table. Beside the thesis's rows: a terrain-agnostic portfolio
(the designs best on average over the training pool), the terrain-reading predictions of the table (the
predictability ceiling given the pool) and each terrain's exhaustive optimum (an oracle bound).

The rows, their order and their titles are the stages' (modular_realtime.json names each method's title and
whether it is learned; eggan_modular.json each learner's): this module imports no registry (and no torch), and
a row it cannot name, or a learner without training metrics, stops the report with one line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from robocompose.io import read_json, read_table
from robocompose.io.errors import ArtifactError
from robocompose.report.modular import THESIS_TABLE_5_2
from robocompose.report.tables import markdown_table
from robocompose.report.verdicts import held, verdict
from robocompose.search.significance import holm

# Thesis Table 5.1 (learned controller) by method: max distance (m), distinct solutions, max distance under EC (m).
# Thesis numbers, not a list of methods: a method the thesis has no row for gets "-".
THESIS_TABLE_5_1 = {"fit2form": ("4.03 ± 0.91", "1.2 ± 0.2", "2.55 ± 1.31"),
                    "dqn": ("4.31 ± 0.26", "2.7 ± 0.9", "3.10 ± 0.92"),
                    "molgan": ("3.82 ± 0.55", "1.8 ± 0.3", "2.93 ± 1.00"),
                    "random": ("0.72 ± 0.64", "-", "0.63 ± 0.69"),
                    "ga": ("5.10 ± 0.42", "2.2 ± 0.7", "3.77 ± 1.18"),
                    "crowding": ("5.73 ± 0.22", "5.8 ± 1.5", "5.36 ± 0.52")}
# Thesis, hand-crafted controller ("effect of the controller"): max distance (m).
THESIS_HANDCRAFTED = {"fit2form": "3.81 ± 1.22", "random": "0.86 ± 0.81", "crowding": "4.96 ± 0.45"}
THESIS_QUERY_MIN = 0.003  # EG-GAN-crowding's runtime in Table 5.2
NOT_IN_THESIS = ("-", "-", "-")


def _ms(values: pd.Series, digits: int = 2) -> str:
    values = values.dropna()
    return f"{values.mean():.{digits}f} ± {values.std(ddof=0):.{digits}f}" if len(values) else "n/a"


def _over_seeds(entry: dict | None, digits: int = 2) -> str:
    """A learned row's cell from the stage's record over training seeds (`training_seeds.COLUMN`): the mean of the
    seeds' means ± their sd; the mean alone for one seed (no spread over seeds)."""
    if not entry or entry.get("mean") is None:
        return "n/a"
    sd = entry.get("sd")
    return f"{entry['mean']:.{digits}f}" + ("" if sd is None else f" ± {sd:.{digits}f}")


def row_titles(table: pd.DataFrame, protocol: dict, metrics: dict, where: Path) -> dict[str, str]:
    """Method -> title of every row of Table 5.1, in the table's order, from the `modular_realtime` stage's
    metrics (`where`); ArtifactError for a method it does not name, or a learner `metrics` has no training of."""
    titles = {}
    for method in dict.fromkeys(table.method):
        info = protocol.get(method)
        if not isinstance(info, dict) or "title" not in info:
            raise ArtifactError(f"{where}: no title for method {method!r} of the realtime table (rerun stage "
                                "`modular_realtime`)")
        if info.get("learned") and method not in metrics:
            raise ArtifactError(f"{where}: {info['title']} is a learner, but eggan_modular.json has no training "
                                f"metrics for {method!r} (rerun stage `train_eggan_modular`)")
        titles[method] = info["title"]
    return titles


def section(reports_dir: Path, data_dir: Path) -> str:
    realtime_path = Path(data_dir) / "modular" / "realtime.parquet"
    metrics_path = Path(reports_dir) / "metrics" / "eggan_modular.json"
    protocol_path = Path(reports_dir) / "metrics" / "modular_realtime.json"
    title = "## EG-GAN: modular robots for a terrain in real time (thesis ch. 4, 5.1; Tables 5.1, 5.2)"
    missing = [str(p) for p in (realtime_path, metrics_path, protocol_path) if not p.exists()]
    if missing:
        return (f"{title}\n\nNot run yet: missing {', '.join(missing)} (stages `train_eggan_modular`, "
                "`modular_realtime`).\n")
    table = read_table(realtime_path, "modular_realtime")
    metrics = json.loads(metrics_path.read_text())
    protocol = read_json(protocol_path)
    titles = row_titles(table, protocol, metrics, protocol_path)
    ceiling = protocol.get("dqn_symmetric_ceiling")
    seeds = ", ".join(map(str, sorted(table.terrain_seed.unique())))
    lines = [title, "",
             "Trained on terrain seeds disjoint from the test terrains; tested on "
             f"{table.terrain_seed.nunique()} held-out terrains ({seeds})"
             f" x {table['query'].nunique()} queries per method (thesis: 10 x 20). Every method outputs "
             f"{int(table.candidates.max())} candidates per query, each answered from the test terrain's table of "
             "pybullet rollouts (hand-crafted gait; exhaustive or partial, a candidate outside a partial table "
             "simulated: below); "
             "max distance = the best valid candidate; distinct = niching metric (delta 1 Hamming, epsilon 0.5 m) "
             "over the candidates; EC = the best candidate satisfying a random cap on one module type (else a random "
             "valid satisfying design), looked up the same way; regret = the terrain's exhaustive optimum minus max "
             "distance. Thesis columns: its learned controller; the hand-crafted column is the thesis's experiment "
             "with a controller like ours; '-': a row the thesis does not have.", "",
             "### Table 5.1: real-time methods", ""]
    rows = []
    for method, name in titles.items():
        group = table[table.method == method]
        trained = method if protocol[method]["learned"] else protocol[method].get("generator")
        spent = metrics[trained]["real_evaluations"] if trained in metrics else "-"
        label = f"{name} (symmetric designs only: ceiling {ceiling['ceiling']:.2f} m)" if method == "dqn" and ceiling \
            else name
        seeds = protocol[method].get("training_seeds")
        if seeds:  # a learned row: mean ± sd over its training seeds
            cells = [_over_seeds(seeds.get(column), 1 if column == "distinct" else 2)
                     for column in ("max_distance", "distinct", "ec_distance", "regret")]
        else:
            cells = [_ms(group.max_distance), _ms(group.distinct, 1), _ms(group.ec_distance), _ms(group.regret)]
        rows.append((label, *cells, f"{int(group.max_distance.isna().sum())} / {int(group.ec_failures.sum())}", spent,
                     seeds["n"] if seeds else "-", *THESIS_TABLE_5_1.get(method, NOT_IN_THESIS),
                     THESIS_HANDCRAFTED.get(method, "-")))
    lines += markdown_table(["method", "max distance (m)", "distinct", "EC distance (m)", "regret (m)",
                             "no valid candidate / EC failures", "evaluations in training", "training seeds",
                             "thesis distance", "thesis distinct", "thesis EC", "thesis hand-crafted"], rows)
    lines += ["", *_seeds_lines(protocol, titles), *_selection_lines(metrics, titles),
              *_table_rows_lines(protocol, set(table.method)),
              *_test_tables_lines(protocol.get("test_tables")), _verdict(table, titles), ""]
    lines += _best_of_lines(protocol.get("best_of"), titles, protocol)
    lines += _significance(table, protocol.get("best_of"), titles)
    lines += _pool_lines(Path(reports_dir) / "metrics" / "modular_pool.json")
    lines += _training_lines(metrics, reports_dir)
    lines += _pool_size_lines(Path(data_dir) / "modular" / "pool_size.parquet", Path(reports_dir) / "figures", titles)
    lines += _table_5_2(table, reports_dir, data_dir, titles)
    fig_5_1 = Path(data_dir) / "modular" / "fig5_1.json"
    if fig_5_1.exists():
        figures = Path(reports_dir) / "figures"
        figures.mkdir(parents=True, exist_ok=True)
        lines += ["", "### Fig. 5.1: generated designs and emergency constraints", "",
                  _figure_5_1(read_json(fig_5_1), figures / "eggan_fig5_1.png"),
                  "", "![Fig. 5.1](figures/eggan_fig5_1.png)", "",
                  "Top: two test terrains (height maps). Below: EG-GAN-crowding's four most probable designs for each "
                  "(one query, 64 samples), a random emergency constraint, and the designs of the ten candidates "
                  "that survive it (ports front-left, mid-left, back-left, back-right, mid-right, front-right; "
                  "n none, l leg, w wheel, b leg-wheel)."]
    return "\n".join(lines) + "\n"


def _figure_5_1(records: list[dict], path: Path) -> str:
    """Draw Fig. 5.1 from the `modular_realtime` stage's records and return a one-line caption with the terrains
    and constraints used."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = {"l": "legs", "w": "wheels", "b": "leg-wheels"}
    fig, axes = plt.subplots(2, len(records), figsize=(6 * len(records), 6), squeeze=False)
    used = []
    for k, record in enumerate(records):
        seed, (module, cap) = record["terrain_seed"], record["constraint"]
        heights = np.asarray(record["heights"], dtype=np.float32)  # the generator's task encoding, (50, 20)
        axes[0, k].imshow(heights.T, origin="lower", extent=[-1, 9, -2, 2], cmap="copper")
        axes[0, k].set_title(f"test terrain {seed} (max block {heights.max() * 100:.1f} cm)")
        used.append(f"terrain {seed}: at most {cap} {names[module]}")
        surviving = ", ".join(record["surviving"][:4]) or "none (a random valid design)"
        text = ("top designs: " + ", ".join(record["designs"][:4]) + f"\n\nconstraint: at most {cap} "
                f"{names[module]}\nsurviving: " + surviving)
        axes[1, k].text(0.02, 0.5, text, family="monospace", fontsize=11, va="center", wrap=True)
        axes[1, k].axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return "Constraints drawn: " + "; ".join(used) + "."


def _seeds_lines(protocol: dict, titles: dict[str, str]) -> list[str]:
    """A paragraph on the learned rows' training seeds (reports/metrics/modular_realtime.json's `training_seeds`):
    what their ± means, how many seeds each has; none for a stage's record without them."""
    seeded = {method: protocol[method]["training_seeds"] for method in titles
              if isinstance(protocol.get(method), dict) and protocol[method].get("training_seeds")}
    if not seeded:
        return []
    counts = sorted({entry["n"] for entry in seeded.values()})
    seeds = sorted({seed for entry in seeded.values() for seed in entry["seeds"]})
    text = ("Learned rows (each learner, and the diverse query of EG-GAN-crowding's generator): mean ± sd over "
            f"their training seeds ({' or '.join(map(str, counts))} seeds: {', '.join(map(str, seeds))}; column "
            "`training seeds`) of each seed's mean over terrains x queries, every seed's models answering the same "
            "terrains, queries and candidates; the other rows (no training) are answered once: mean ± sd over "
            "terrains x queries. No valid candidate / EC failures count every seed's queries; evaluations in "
            "training are the stage's own models'.")
    if counts == [1]:
        text += (" n seeds = 1: one training seed per learner (no further seed committed under "
                 "measured/modular/seeds/), so no spread over seeds is shown; `robocompose modular train-seed` "
                 "trains more.")
    return [text, ""]


def _selection_lines(metrics: dict, titles: dict[str, str]) -> list[str]:
    """Which trained rows keep their best validation checkpoint (early stopping) and which report their final
    model (reports/metrics/eggan_modular.json): an asymmetry of model selection the reader must weigh."""
    trained = [m for m in titles if isinstance(metrics.get(m), dict)]
    kept = [m for m in trained if metrics[m].get("best_iteration") is not None]
    final = [m for m in trained if m not in kept]
    if not kept or not final:
        return []
    return [f"Model selection differs: {', '.join(titles[m] for m in kept)} keep the checkpoint best on the "
            f"validation terrains (early stopping); {', '.join(titles[m] for m in final)} report their final "
            "model. Selection on validation tends to carry over to the test terrains, so comparisons between the "
            "two groups may lean towards the first. Each learner's terrain encoder was chosen on the validation "
            "terrains by one rule (docs/eggan.md).", ""]


def _table_rows_lines(protocol: dict, methods: set[str]) -> list[str]:
    """Paragraphs on the rows the thesis does not have and on DQN's ceiling (reports/metrics/modular_realtime.json)."""
    lines = []
    chosen, ceiling = protocol.get("portfolio_designs"), protocol.get("dqn_symmetric_ceiling")
    if chosen and "portfolio" in methods:
        lines.append(f"Portfolio (terrain-agnostic baseline): every query on every terrain gets the same "
                     f"{len(chosen['designs'])} designs, those of highest mean fitness over the training pool's "
                     f"{chosen['pool_terrains']} exhaustive tables (penalties included): "
                     + ", ".join(f"`{d}`" for d in chosen["designs"]) + ". A method that reads the terrain should "
                     "beat it.")
    if chosen and chosen.get("greedy") and "portfolio_greedy" in methods:
        lines.append(f"Portfolio, greedy (terrain-agnostic): the same {len(chosen['greedy'])} designs for every "
                     "query, picked one at a time on the same pool, each the design that most raises the pool's mean "
                     "of the best of those picked (its best-of-k, not each design's own mean, is what it "
                     "maximises), answered in pick order: "
                     + ", ".join(f"`{d}`" for d in chosen["greedy"]) + ".")
    predict = protocol.get("predict_table")
    named = [protocol[m]["title"] for m in ("predict_knn", "predict_ridge") if m in methods]
    if predict and named:
        lines.append(f"{' and '.join(named)}: for each test terrain, its row of the fitness table predicted from "
                     f"its height map ({len(predict['features'])} summaries: "
                     + ", ".join(f"`{f}`" for f in predict["features"])
                     + f") and the {predict['pool_terrains']} training terrains of the pool (their height maps' "
                     f"summaries and their rows of the table, {predict['designs']} designs): k-NN, the mean row of "
                     f"the {predict['neighbours']} nearest terrains in standardised feature space; ridge, a "
                     f"per-design ridge regression (penalty {predict['ridge']:g}); the designs predicted best, "
                     "best first. Nothing is trained beyond the pool's tables: the measured predictability "
                     "ceiling of a terrain-reading answer given the pool (the gate's, `robocompose modular gate`), "
                     "to compare the learners with.")
    diverse = protocol.get("diverse_query")
    for method in sorted(m for m in methods if isinstance(protocol.get(m), dict) and protocol[m].get("generator")):
        lines.append(f"{protocol[method]['title']}: the same trained generator and look-up budget, its candidates "
                     "taken in probability order, each skipped if it is within "
                     + (f"{diverse['min_hamming'] - 1} port(s) of one already taken (pairwise Hamming distance >= "
                        f"{diverse['min_hamming']})" if diverse else "the stated Hamming distance of one already taken")
                     + "; where even 16x the draws leave fewer far enough apart, the query answers the fewer it has "
                     "(the column `candidates` of the realtime table says so).")
    if "optimum" in methods:
        lines.append("Exhaustive optimum (oracle): each test terrain's fittest designs of its table; no method can "
                     "score more (regret 0 by construction). An upper bound, not a method.")
    if ceiling and "dqn" in methods:
        lines.append(f"DQN builds left-right symmetric designs only (one module per mirrored port pair: "
                     f"{ceiling['designs']} designs). On the {ceiling['terrains']} test terrains with an exhaustive "
                     "table (a partial one holds too few symmetric designs) the best symmetric "
                     f"design of each terrain averages {ceiling['ceiling']:.2f} m: the ceiling of its max distance; "
                     f"the single symmetric design best on average, `{ceiling['best_design']}`, "
                     f"{ceiling['best_design_mean']:.2f} m.")
    return [line for text in lines for line in (text, "")]


def _test_tables_lines(tables: dict | None) -> list[str]:
    """A paragraph on the partial test tables (reports/metrics/modular_realtime.json's `test_tables`); none when
    every test terrain has its exhaustive table."""
    if not tables or not tables["partial"]:
        return []
    partial = tables["partial"]
    sets = sorted({f"`{t['design_set']}` ({t['designs']} designs)" for t in partial.values()})
    raised = sum(t["optimum"] > t["table_optimum"] for t in partial.values())
    return [f"Test tables: {len(tables['full'])} terrains have their exhaustive table (all designs: "
            f"{', '.join(map(str, tables['full'])) or 'none'}); {len(partial)} have a partial one, a design set "
            f"measured by the same evaluator ({', '.join(sets)}: {', '.join(partial)}). A candidate outside a partial "
            f"table is simulated, never imputed: {tables['rollouts_outside_tables']} candidate rollouts outside the "
            "partial tables. A partial terrain's optimum (regret's reference, the oracle's) is the best over its "
            "measured set and every simulated candidate: a lower bound on its true optimum, so its regret is a lower "
            "bound too and the oracle row may show regret there. On the 10 full test tables the `balanced` set "
            f"keeps the optimum within 0.001 m (2.620 of 2.621 m). A simulated candidate beat the set on {raised} "
            f"of the {len(partial)} partial terrains.", ""]


def _verdict(table: pd.DataFrame, titles: dict[str, str]) -> str:
    """The thesis's claim on Table 5.1 (EG-GAN-crowding the farthest of the real-time methods, on the mean over
    queries as the thesis compares them; the paired tests come below), then how it stands against each kind of row."""
    means = table.groupby("method")[["max_distance", "distinct"]].mean()
    if not {"crowding", "random", "ga"} <= set(means.index):
        return ""
    rival = max((m for m in means.index if m not in ("crowding", ORACLE)), key=lambda m: means.max_distance[m])
    stated = verdict("EG-GAN-crowding the farthest of Table 5.1's methods, mean max distance (thesis: it is)",
                     held(means.max_distance["crowding"] > means.max_distance[rival]),
                     f"(EG-GAN-crowding {means.max_distance['crowding']:.2f} m, the farthest other "
                     f"{titles.get(rival, rival)} {means.max_distance[rival]:.2f} m; paired tests below).")
    beats = means.max_distance["crowding"] > means.max_distance["random"]
    diverse = means.distinct["crowding"] > means.distinct["ga"]
    text = (f"EG-GAN-crowding {'beats' if beats else 'does not beat'} random sampling on max distance "
            f"({means.max_distance['crowding']:.2f} vs {means.max_distance['random']:.2f} m) and "
            f"{'has' if diverse else 'does not have'} more distinct solutions than EG-GAN "
            f"({means.distinct['crowding']:.1f} vs {means.distinct['ga']:.1f}).")
    if "portfolio" in means.index:
        ahead = means.max_distance["crowding"] > means.max_distance["portfolio"]
        text += (f" It {'beats' if ahead else 'does not beat'} the terrain-agnostic portfolio "
                 f"({means.max_distance['portfolio']:.2f} m).")
    if "optimum" in means.index:
        text += (f" It reaches {means.max_distance['crowding'] / means.max_distance['optimum']:.0%} of the exhaustive "
                 f"optimum ({means.max_distance['optimum']:.2f} m).")
    return f"{stated}\n\n{text}"


def _pool_lines(path: Path) -> list[str]:
    """The training pool (stage modular_pool): per split its terrains, distinct optima, best-on-average design and
    regret, and how the best fixed design's regret changes with the pool's size."""
    if not path.exists():
        return []
    pool = read_json(path)
    lines = ["### Training pool: exact ground truth", "",
             *markdown_table(["split", "terrains (seeds)", "distinct optima (up to mirror)", "best-on-average design",
                              "its mean regret (m)", "regret / mean optimum"],
                             [(split, f"{p['terrains']} ({p['seeds'][0]}..{p['seeds'][1]})", p["distinct_optima"],
                               p["average_design"], p["mean_regret"], p["regret_ratio"])
                              for split, p in ((split, pool[split]) for split in ("training", "validation"))],
                             formats=[None, None, None, "`{}`", "{:.2f}", "{:.0%}"])]
    sizes = ", ".join(f"{n} terrains: `{p['average_design']}` {p['mean_regret']:.2f} m"
                      for n, p in pool.get("by_size", {}).items())
    lines += ["", "Every design on every pool terrain, simulated once (`robocompose modular exhaustive`, committed "
              f"under measured/modular/pool/); {pool['simulated_designs']} rollouts. Best fixed design and its regret "
              f"by pool size: {sizes or 'n/a'}.", ""]
    return lines


def _pool_size_lines(path: Path, figures: Path, titles: dict[str, str]) -> list[str]:
    """Held-out score against the training pool's size (stage modular_pool_size): a table and a figure; its
    methods are rows of Table 5.1 (`titles`), ArtifactError for one that is not."""
    if not path.exists():
        return []
    study = read_table(path, "modular_pool_size")
    unknown = sorted(set(study.method) - set(titles))
    if unknown:
        raise ArtifactError(f"{path}: methods {unknown} are not rows of the realtime table (rerun the stages)")
    grouped = study.groupby(["pool_terrains", "method"])
    rows = []
    for (n, method), group in grouped:
        cost = f"{group.iterations_done.iloc[0]} / {group.lookups.iloc[0]}" if method == "crowding" else "-"
        fit = group.groupby("seed").train_max_distance.first()
        rows.append((n, titles[method], group.seed.nunique(), _ms(group.max_distance), _ms(group.regret), _ms(fit),
                     cost))
    lines = ["### Beyond the thesis: held-out score against the training pool's size", "",
             *markdown_table(["pool terrains", "method", "runs", "test max distance (m)", "test regret (m)",
                              "training max distance (m)", "EG-GAN iterations / look-ups"], rows)]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    means = grouped.max_distance.mean().unstack("method")
    fits = grouped.train_max_distance.mean().unstack("method")
    fig, ax = plt.subplots(figsize=(5, 3.5))
    for method in means.columns:
        line = ax.plot(means.index, means[method], marker="o", label=f"{titles[method]}, test terrains")[0]
        ax.plot(fits.index, fits[method], marker="x", linestyle="--", color=line.get_color(),
                label=f"{titles[method]}, its training terrains")
    ax.set(xlabel="training terrains", ylabel="max distance (m)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    figures.mkdir(parents=True, exist_ok=True)
    fig.savefig(figures / "eggan_modular_pool_size.png", dpi=80)
    plt.close(fig)
    return [*lines, "", "![pool size](figures/eggan_modular_pool_size.png)", "",
            f"EG-GAN-crowding trained on the first n training terrains ({int(study.iterations_done.max())} "
            f"iterations at most, {study.seed.nunique()} training seeds), beside the portfolio of the same n "
            f"terrains; both on the test terrains x {study['query'].nunique()} queries, from their tables (mean "
            "± sd over queries and seeds), and on their own n training terrains (query 0): the gap between the "
            "two is what a method fits but does not carry to terrains it never saw.", ""]


CHANCE = 0.05  # a discriminator whose accuracy stays within this of 1/2 gives the generator no signal


def _best_of_lines(best_of: dict | None, titles: dict[str, str], protocol: dict) -> list[str]:
    """Each row's mean best of its first k candidates for every k the stage recorded (1, 3, all), with the
    distinct look-ups a query spent on them (reports/metrics/modular_realtime.json; a learned row's mean ± sd over
    its training seeds from `training_seeds`); none for an older stage's."""
    if not best_of:
        return []
    ks, methods = best_of["ks"], best_of["methods"]
    rows = []
    for method, name in titles.items():
        cells = []
        info = protocol.get(method)
        seeds = info.get("training_seeds") if isinstance(info, dict) else None
        for k in ks:
            entry = methods.get(method, {}).get(str(k))
            if entry is None or entry["mean"] is None:
                cells += ["n/a", "-"]
                continue
            failed = f" ({entry['no_valid']} without a valid one)" if entry["no_valid"] else ""
            spread = _over_seeds(seeds.get(f"best_of_{k}")) if seeds else f"{entry['mean']:.2f} ± {entry['std']:.2f}"
            cells += [f"{spread}{failed}", f"{entry['lookups']:g}"]
        rows.append((name, *cells))
    header = ["method"] + [h for k in ks for h in (f"best of {k} (m)", "look-ups per query")]
    return ["### Best of the first k candidates", "", *markdown_table(header, rows), "",
            "The same queries and candidates as Table 5.1 (no further look-up): the best valid one of each query's "
            "first k candidates, in the method's own order (the generators' most probable first, the greedy "
            "portfolio's pick order, the top-k portfolio's by mean fitness, the predict rows' by predicted "
            "fitness, random sampling's draw order), mean ± sd "
            "over terrains x queries (a learned row: over its training seeds, as in Table 5.1); look-ups: the "
            "distinct designs those k candidates cost a query. A method that "
            "reads the terrain should lead at k = 1 and 3, where a fixed portfolio cannot cover every terrain.", ""]


ORACLE = "optimum"  # the exhaustive optimum: an upper bound, not a method, so never one of the tests' family


def _significance(table: pd.DataFrame, best_of: dict | None, titles: dict[str, str]) -> list[str]:
    """Wilcoxon signed-rank tests of EG-GAN-crowding against every other row of Table 5.1 but the oracle, paired by
    test terrain (each terrain's mean over its queries, averaged over a learned row's training seeds: the queries of
    one terrain are not independent), for each best-of-k the stage recorded (`best_of`; else max distance, the best
    of all the candidates), Holm-corrected over the family of every comparison made at that k: the lines of their
    table, none if no comparison could be made."""
    from scipy.stats import wilcoxon

    if best_of:
        pairs_by_k = {k: pd.DataFrame({m: pd.Series(best_of["per_terrain"][m][str(k)], dtype=float)
                                       for m in titles if m in best_of["per_terrain"]}) for k in best_of["ks"]}
    else:
        per_seed = table.groupby(["method", "training_seed", "terrain_seed"]).max_distance.mean()
        pairs_by_k = {int(table.candidates.max()):
                      per_seed.groupby(["method", "terrain_seed"]).mean().unstack("method")}
    others = [m for m in titles if m not in ("crowding", ORACLE)]
    raw, adjusted, pairs = {}, {}, {}
    for k, per_terrain in pairs_by_k.items():
        if "crowding" not in per_terrain:
            continue
        raw[k] = {}
        for other in others:
            if other not in per_terrain:
                continue
            diff = (per_terrain["crowding"] - per_terrain[other]).dropna()
            if len(diff) >= 5 and (diff != 0).any():
                raw[k][other], pairs[other] = float(wilcoxon(diff).pvalue), len(diff)
        adjusted[k] = holm(raw[k])
    tested = [m for m in others if m in pairs]
    if not tested:
        return []

    def cells(k: int, method: str) -> tuple:
        return (raw[k][method], adjusted[k][method]) if method in raw.get(k, {}) else ("-", "-")

    ks = list(raw)
    family = ", ".join(f"{len(raw[k])} at best of {k}" for k in ks)
    return [f"Paired by terrain (Wilcoxon signed-rank, {max(pairs.values())} terrains): EG-GAN-crowding against "
            "every other row but the oracle, Holm-corrected over each best-of-k's family of comparisons "
            f"({family}); a terrain's score is its mean over queries, averaged over a learned row's training seeds; "
            "'-': no test (fewer than 5 terrains, or no difference on any):", "",
            *markdown_table(["EG-GAN-crowding vs", "paired terrains",
                             *(h for k in ks for h in (f"best of {k}: p", f"best of {k}: Holm p"))],
                            [(titles[m], pairs[m], *(c for k in ks for c in cells(k, m))) for m in tested],
                            formats=[None, None, *([_p] * 2 * len(ks))]), ""]


def _p(value: float | str) -> str:
    return value if isinstance(value, str) else f"{value:.3f}"


def _accuracy(accuracy: float | None, pop_new: float | None) -> str:
    """The discriminator's accuracy and, where the log has the evolved share of X_pop, the most a perfect
    discriminator could reach, (1 + share) / 2: X_pop's other designs stand in both halves of its batch."""
    if accuracy is None:
        return "-"
    return f"{accuracy:.2f}" if pop_new is None else f"{accuracy:.2f} ({(1 + pop_new) / 2:.2f})"


def _training_lines(metrics: dict, reports_dir: Path) -> list[str]:
    """Each learner's fitness source, iterations, evaluations against the budget, discriminator accuracy (flagged at
    chance), validation-terrain score, surrogate error where a surrogate was used; the validation curves."""
    rows, flagged = [], []
    for method, m in metrics.items():
        final, name = m.get("final", {}), m.get("method", method)
        accuracy = final.get("d_accuracy")
        if accuracy is not None and abs(accuracy - 0.5) < CHANCE:
            flagged.append(name)
        surrogate = m.get("surrogate_heldout") or {}
        source = {"table": "exact (pool tables)", "surrogate": "surrogate + rollouts"}.get(m.get("fitness_source"),
                                                                                           "surrogate + rollouts")
        kept = m.get("best") or final  # early stopping: the saved model is the best-validated iteration's
        done = f"{m.get('iterations_done', m.get('iterations'))} / {m.get('iterations')}"
        if "best_iteration" in m:
            done += f" (kept {m['best_iteration']})"
        rows.append((name, source, done, f"{m.get('real_evaluations')} / {m.get('evaluation_budget', '-')}",
                     _accuracy(accuracy, final.get("pop_new")),
                     (m.get("training_terrains") or {}).get("train_max_distance"), kept.get("val_max_distance"),
                     kept.get("val_regret"), surrogate.get("spearman_within_terrain")))
    lines = ["### Training", "",
             *markdown_table(["method", "fitness", "iterations (done / asked)", "evaluations / budget",
                              "discriminator accuracy (ceiling)", "training max distance (m)",
                              "validation max distance (m)", "validation regret (m)",
                              "surrogate Spearman within a terrain"], rows, formats=[None] * 5 + [_number] * 4)]
    lines += ["", "Exact fitness: a design's fitness on a training terrain is its entry in that terrain's exhaustive "
              "table (the pybullet rollout); evaluations = distinct (terrain, design) look-ups, the same budget for "
              "every learner, which stops when it is spent. Training and validation max distance: the best of each "
              "learner's 10 candidates on the pool's training terrains and on its validation terrains (never "
              "trained on), from their tables, for the model kept (with early stopping: the best-validated "
              "iteration's generator, \"kept\"); the gap between them is what the learner fits but does not "
              "carry to terrains it never saw. Ceiling: evolution leaves most of X_gen in X_pop, and a design in "
              "both halves of the discriminator's batch is right only half the time, so a perfect discriminator "
              "reaches (1 + the evolved share of X_pop) / 2.", ""]
    if flagged:
        lines += [f"**Discriminator at chance** (accuracy within {CHANCE} of 0.5 at the end of training): "
                  + ", ".join(flagged) + ". A generator trained against such a discriminator has no signal to learn "
                  "from.", ""]
    # EG-GAN's variants (the learners that name their evolution) log curves; the other learners do not
    variants = [variant for variant, m in metrics.items() if "evolution" in m]
    curves = {metrics[v]["method"]: Path(reports_dir) / "plots" / f"eggan_modular_{v}.csv" for v in variants}
    if curves and all(path.exists() for path in curves.values()):
        figure = Path(reports_dir) / "figures" / "eggan_modular_validation.png"
        if _validation_figure(curves, figure):
            files = ", ".join(f"`reports/plots/eggan_modular_{v}.csv`" for v in variants)
            lines += ["![validation curves](figures/eggan_modular_validation.png)", "",
                      f"Validation-terrain max distance and discriminator accuracy over training ({files}).", ""]
    return lines


def _number(value) -> str:
    return "-" if value is None or value != value else f"{value:.2f}"


def _validation_figure(curves: dict[str, Path], path: Path) -> bool:
    """Validation max distance and discriminator accuracy against iteration, per EG-GAN variant (`curves`: its
    title -> its log; False: no curve)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = {name: pd.read_csv(csv) for name, csv in curves.items()}
    if not all("val_max_distance" in frame for frame in frames.values()):
        return False
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.5))
    for name, frame in frames.items():
        scored = frame.dropna(subset=["val_max_distance"])
        left.plot(scored.iteration, scored.val_max_distance, marker="o", label=name)
        right.plot(frame.iteration, frame.d_accuracy, label=name)
    left.set(xlabel="iteration", ylabel="validation max distance (m)")
    right.axhline(0.5, color="grey", linestyle=":")
    right.set(xlabel="iteration", ylabel="discriminator accuracy")
    left.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return True


def _seeds(group: pd.DataFrame) -> str:
    return ", ".join(map(str, sorted(group.terrain_seed.unique())))


def _table_5_2(table: pd.DataFrame, reports_dir: Path, data_dir: Path, titles: dict[str, str]) -> list[str]:
    runs_path = Path(data_dir) / "modular" / "runs.parquet"
    crowding = table[table.method == "crowding"]
    rows = []
    if runs_path.exists():
        runs = read_table(runs_path, "modular_runs")
        for method, name in (("ga20", "GA-20"), ("ga50", "GA-50"), ("crowding", "GA-crowding")):
            group = runs[runs.method == method]
            if len(group):
                rows.append((name, _ms(group.best_distance), _ms(group.distinct, 1),
                             f"{int(group.evaluations.mean())} rollouts (see the modular section's runtimes)",
                             _seeds(group), *THESIS_TABLE_5_2[method]))
    bench = Path(reports_dir) / "benchmarks.json"
    query_ms = read_json(bench).get("eggan.modular.query_ms") if bench.exists() else None
    if len(crowding):
        runtime = "not benchmarked (`make bench`)" if query_ms is None else f"{query_ms:.1f} ms per query"
        rows.append((titles["crowding"], _ms(crowding.max_distance), _ms(crowding.distinct, 1), runtime,
                     _seeds(crowding), *THESIS_TABLE_5_1["crowding"][:2], THESIS_QUERY_MIN))
    lines = ["### Table 5.2: EG-GAN-crowding beside the GA runs", "",
             *markdown_table(["method", "max distance (m)", "distinct", "runtime", "test terrains", "thesis distance",
                              "thesis distinct", "thesis runtime (min)"], rows)]
    lines += ["", "The GA rows search each test terrain from scratch (their runtime is simulation); EG-GAN-crowding's "
              "runtime is `eggan.modular.query_ms` of `make bench` (one query: 64 samples, one core, the ranking "
              "included; reports/benchmarks.json). The protocol's queries keep drawing batches of 64 until 10 "
              "distinct designs appear; their median wall time per method is in reports/timings.json "
              "(`modular_realtime`). Simulating the candidates for the table is not part of a query."]
    return lines
