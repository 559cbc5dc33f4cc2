"""Report section for the graph VAE (thesis 7.1): variant metrics, training curves, the latent landscape.

Built from the `train_vae` stage's training logs (reports/training/vae_*/: dvclive curves and metrics.json) and each
variant's wall time (`train_vae@VARIANT` in reports/timings.json), each variant titled by the GLSO method that
searches it (reports/metrics/glso.json, the glso stage's record of the registry), the `vae_landscape` stage's
output and reports/benchmarks.json.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocompose.io import read_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import ArtifactError
from robocompose.report.verdicts import held, verdict

COLUMNS = [("reconstruction_accuracy", "reconstruction (held out)"), ("prior_validity", "prior valid (builds)"),
           ("prior_grammar_valid", "prior grammar-derivable"), ("prior_rest_valid", "prior passes rest check"),
           ("uniqueness", "uniqueness"), ("novelty", "novelty"), ("property_mse", "property MSE (held out)"),
           ("property_baseline_mse", "MSE of the training mean"), ("property_r2", "property R^2")]
PROPERTY_KEYS = {"property_mse", "property_baseline_mse", "property_r2"}


def vae_titles(record: Path) -> dict[str, str]:
    """Each VAE variant -> the title of the first GLSO method in the registry's order that searches it (GLSO for
    the full VAE its variants search too), from the glso stage's record of the registry (`methods` of
    reports/metrics/glso.json); ArtifactError naming the file if there is none."""
    if not record.exists():
        raise ArtifactError(f"{record}: missing; the VAE variants are titled by the GLSO methods that search them "
                            "(stage `glso`)")
    methods = read_json(record).get("methods")
    if not isinstance(methods, list) or not all("variant" in method for method in methods):
        raise ArtifactError(f"{record}: no record of the methods' VAE variants (rerun stage `glso`)")
    titles: dict[str, str] = {}
    for method in methods:
        if method["variant"]:
            titles.setdefault(method["variant"], method["title"])
    return titles


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.3f}"


def section(reports_dir: Path, data_dir: Path, train_vae: dict) -> str:
    """`train_vae`: the `train_vae:` params the VAEs were trained with."""
    title = "## Graph VAE: latent space of the grammar's designs (thesis 7.1)"
    reports_dir, data_dir = Path(reports_dir), Path(data_dir)
    found = {path.parent.name.removeprefix("vae_"): _evaluation(path)
             for path in sorted((reports_dir / "training").glob("vae_*/metrics.json"))}
    if not found:
        return f"{title}\n\nNot run yet: no {reports_dir}/training/vae_*/metrics.json (stage `train_vae`).\n"
    record = reports_dir / "metrics" / "glso.json"
    titles = vae_titles(record)
    untitled = sorted(set(found) - set(titles))
    if untitled:
        raise ArtifactError(f"{record}: no GLSO method searches VAE variants {untitled} (rerun stage `glso`)")
    metrics = {name: found[name] for name in titles if name in found}  # in the registry's order
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from robocompose.io.timings import read_timings
    from robocompose.latent.curves import read_curves

    settings = train_vae
    model, train = settings["model"], settings["train"]
    timings = read_timings(reports_dir / "timings.json")
    figures = reports_dir / "figures"
    figures.mkdir(parents=True, exist_ok=True)

    lines = [title, "",
             f"Settings: hidden {model['hidden']} (thesis 450), latent {model['latent']}, batch {train['batch_size']}, "
             f"{train['steps']} steps (thesis 400k), KL weight 0 until step {train['beta_start']} then "
             f"+{train['beta_increment']} every {train['beta_every']} steps, predictor weight {train['pred_weight']} "
             "(thesis 20, which kept held-out reconstruction at 0.51 at the default size, see README); "
             f"{round(100 * train['holdout'])}% of each dataset held out; "
             f"{settings.get('extra', {}).get('n', 0)} more designs of each kind (the dataset's own generators, "
             "another seed) train only, because the 3000-design dataset alone overfits (held-out exact "
             "reconstruction ~0.24 while training designs reach ~0.69). Two decoders: ours masks what the "
             "training data's kind forbids (`full`/`nopred`: only grammar designs; `nogram`: any tree with <= 4 "
             "neighbours), in training and decoding; the original's takes an unmasked argmax over all 42 labels "
             "(second table; the same model, decoded without masks).", "",
             "| variant | " + " | ".join(label for _, label in COLUMNS) + " | training time |",
             "|---|" + "---|" * (len(COLUMNS) + 1)]
    for name, label in titles.items():
        if name in metrics:
            seconds = timings.get(f"train_vae@{name}", {}).get("seconds")
            took = f"{seconds / 60:.1f} min" if seconds else "n/a"
            lines.append(f"| {label} | " + " | ".join(_fmt(metrics[name].get(k)) for k, _ in COLUMNS) + f" | {took} |")
    samples = next(iter(metrics.values())).get("prior_samples")
    unmasked = [k for k, _ in COLUMNS if k not in PROPERTY_KEYS]
    lines += ["", "Decoded as the original (unmasked argmax over all 42 labels):", "",
              "| variant | " + " | ".join(label for k, label in COLUMNS if k in unmasked) + " |",
              "|---|" + "---|" * len(unmasked)]
    for name, label in titles.items():
        if name in metrics and "unconstrained" in metrics[name]:
            lines.append(f"| {label} | " + " | ".join(_fmt(metrics[name]["unconstrained"].get(k)) for k in unmasked)
                         + " |")
    lines += ["", "Prior metrics decode z ~ N(0, I) "
              f"({samples} samples): *valid* = complete and built in pybullet "
              "with a finite rest state; *grammar-derivable* = its constructed rule sequence derives the same "
              "design; *rest check* = the dataset's own filter (no self-penetration, GLSO's contact rule: >= 4 floor "
              "points, none on the mid-plane away from the front). "
              "Uniqueness: distinct / valid; novelty: distinct designs not in the training split.", ""]

    logs = {name: reports_dir / "training" / f"vae_{name}" for name in metrics}
    curves = {name: read_curves(log) for name, log in logs.items() if (log / "plots").is_dir()}
    if curves:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
        for name, log in curves.items():
            axes[0].plot(log["step"], log["label_loss"] + log["stop_loss"], label=name)
            rec = log.dropna(subset=["heldout_reconstruction"])
            axes[1].plot(rec["step"], rec["heldout_reconstruction"], marker="o", label=name)
        axes[0].set(xlabel="step", ylabel="label + stop loss per design", title="Reconstruction loss", yscale="log")
        axes[1].set(xlabel="step", ylabel="exact reconstruction", title="Held-out reconstruction", ylim=(0, 1))
        axes[0].legend()
        fig.tight_layout()
        fig.savefig(figures / "vae_training.png", dpi=110)
        plt.close(fig)
        lines += ["![VAE training curves](figures/vae_training.png)", ""]

    lines += _landscape(data_dir / "vae_landscape.parquet", reports_dir / "metrics" / "vae_landscape.json", figures,
                        plt, titles)
    bench = reports_dir / "benchmarks.json"
    figures_ = read_json(bench) if bench.exists() else {}
    if "vae.steps_per_s" in figures_:
        lines += ["", f"Speed at thesis size (hidden 450, latent 28, batch 32, 2 threads): "
                  f"{figures_['vae.steps_per_s']:.2f} steps/s, {figures_['vae.speedup_vs_reference']:.1f}x the "
                  "original's schedule (20 synchronous iterations) in the same run, "
                  f"{100 * figures_['vae.flop_utilization']:.0f}% of the measured matmul FLOP/s; the paper "
                  f"profile's 400k steps would take ~{figures_['vae.paper_hours']:.0f} h here (thesis: ~5 h on a "
                  "GTX 1070)."]
    return "\n".join(lines)


def _evaluation(path: Path) -> dict:
    """The final metrics of one variant from its dvclive summary (`evaluation`), naming the file if it is bad."""
    summary = read_json(path)  # names the file if it is not JSON
    if not isinstance(summary, dict) or not isinstance(summary.get("evaluation"), dict):
        raise ArtifactError(f"{path}: expected dvclive's summary with an `evaluation` object")
    return summary["evaluation"]


def _landscape(path: Path, knn_path: Path, figures: Path, plt, titles: dict[str, str]) -> list[str]:
    if not path.exists():
        return [f"Latent landscape (Fig. 7.1): pending (stage `vae_landscape`, {path} missing)."]
    table = read_table(path, "vae_landscape")
    dataset = table[table["source"] == "dataset"]
    # one row of panels per task, first the task vae_landscape scored the dataset designs on
    tasks = list(dict.fromkeys([*sorted(set(dataset["task"])), *sorted(set(table["task"]))]))

    def reward_range(task: str) -> tuple[float, float]:
        scored = table[(table["task"] == task) & (table["status"] == "ok")]
        return tuple(np.nanpercentile(scored["reward"], [5, 95])) if len(scored) else (0.0, 1.0)

    low, high = reward_range(tasks[0])
    fig, axes = plt.subplots(len(tasks), 2, figsize=(10, 4.2 * len(tasks)), squeeze=False, layout="constrained")
    for row, task in enumerate(tasks):
        task_low, task_high = reward_range(task)
        points = None
        for ax, name in zip(axes[row], ("full", "nopred"), strict=True):
            part = table[table["variant"] == name]
            if part.empty:
                continue
            unscored = part[part["status"] == ""]
            ax.scatter(unscored["pc1"], unscored["pc2"], s=6, color="#cccccc", label="dataset, not scored")
            ok = part[(part["status"] == "ok") & (part["task"] == task)]
            points = ax.scatter(ok["pc1"], ok["pc2"], c=ok["reward"], cmap="viridis", vmin=task_low, vmax=task_high,
                                s=22, edgecolors="k", linewidths=0.3)
            bad = part[(part["status"] != "ok") & (part["status"] != "") & (part["task"] == task)]
            ax.scatter(bad["pc1"], bad["pc2"], marker="x", color="#d62728", s=25, label="invalid in simulation")
            ax.set(title=f"{titles[name]}: {task}", xlabel=f"PC1 ({100 * part['explained1'].iloc[0]:.0f}% var.)",
                   ylabel=f"PC2 ({100 * part['explained2'].iloc[0]:.0f}% var.)")
            ax.legend(fontsize=7, loc="lower right")
        if points is not None:
            fig.colorbar(points, ax=axes[row], label=f"{task} reward (MPPI)")
    fig.savefig(figures / "vae_landscape.png", dpi=110)
    plt.close(fig)
    full = table[table["variant"] == "full"]
    n_scored = int(((full["source"] == "dataset") & (full["status"] != "")).sum())
    found = full[full["source"] != "dataset"]
    lines = ["![Latent landscape](figures/vae_landscape.png)", "",
             f"Latent means of {int((full['source'] == 'dataset').sum())} dataset designs projected on their first "
             f"two principal components; {n_scored} of them scored on {tasks[0]} terrain by the default evaluator "
             f"(one episode each), and {len(found)} designs that committed searches scored "
             f"({', '.join(sorted(found['source'].unique()))}: search = a fidelity search, campaign = a run of the "
             "GLSO campaign; "
             f"{', '.join(f'{t} at {r}' for t, r in sorted(set(zip(found['task'], found['rung'], strict=True))))}) "
             "placed on the same axes, one row of panels per task coloured by that task's rewards (rungs mixed: "
             f"the same task, cheaper or dearer MPPI settings). The {tasks[0]} rewards span {low:.2f}-{high:.2f} "
             "(5th-95th percentile; ~4 is standing still). The thesis colours a few hundred designs scored with its "
             "controller."]
    if len(dataset) and knn_path.exists():
        metrics = read_json(knn_path)
        knn = metrics["knn_predictability"]
        if thesis := metrics.get("thesis_scale"):  # the thesis-scale VAE's rows, once it is gated
            titles = titles | {thesis["variant"]: thesis["title"]}
        if knn:
            lines += ["", "Does the latent space order scores? Each scored search design's reward predicted by the "
                      "mean of its 5 nearest neighbours in the full latent space (leave one out), Spearman against "
                      "its reward, beside the same statistic over shuffled rewards (permutation test, one-sided):",
                      "", "| VAE | task | rung | designs | k-NN Spearman | shuffled mean | shuffled 95th pct. | p |",
                      "|---|---|---|---:|---:|---:|---:|---:|"]
            for key, row in knn.items():
                name, task, rung = key.split("/")
                lines.append(f"| {titles[name]} | {task} | {rung} | {row['designs']} | {row['spearman']:.3f} | "
                             f"{row['shuffled_mean']:.3f} | {row['shuffled_95']:.3f} | {row['p_value']:.3f} |")
            above = {name: [k for k, row in knn.items() if k.startswith(f"{name}/")
                            and row["spearman"] > row["shuffled_95"]] for name in ("full", "nopred")}
            groups = {name: sum(k.startswith(f"{name}/") for k in knn) for name in ("full", "nopred")}
            lines += ["", "Above the shuffled 95th percentile: "
                      + "; ".join(f"{titles[name]} in {len(above[name])} of {groups[name]} groups"
                                  for name in ("full", "nopred")) + "."]
            lines += _gate(metrics, knn_path, titles)
    return lines


def _gate(metrics: dict, path: Path, titles: dict[str, str]) -> list[str]:
    """The gate table (issue 42, item 6) from the `gate` of reports/metrics/vae_landscape.json; ArtifactError naming
    the file if a stage older than the gate wrote it."""
    if "gate" not in metrics:
        raise ArtifactError(f"{path}: no `gate` (written before the VAE gate existed; rerun stage `vae_landscape`)")
    gate = metrics["gate"]
    if not gate:
        return []
    first = next(iter(gate.values()))
    width, samples, top = first["window_width"], first["window_samples"], first["gate_top"]
    lines = ["", "The gate a thesis-scale VAE must pass before a campaign uses it (issue 42): its latent k-NN "
             "Spearman (above) must beat the same statistic on a learning-free baseline, each design's count of "
             f"every node type, by >= {first['gate_margin']:g}, and a box {width:g} wide in every latent coordinate "
             f"(GLSO's collapsed domain-reduction window) around the latent means of the group's {top} best designs "
             f"must decode to >= {first['gate_distinct']} distinct designs of {samples} uniform draws (the median "
             f"over the {top}). From the scores the searches already have: no simulation.", "",
             "| VAE | task | rung | designs | latent k-NN Spearman | node-type-count k-NN Spearman | margin | "
             f"distinct designs in a {width:g}-wide window around the top {top} (of {samples} samples) | passes |",
             "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for key, row in gate.items():
        name, task, rung = key.split("/")
        lines.append(f"| {titles[name]} | {task} | {rung} | {row['designs']} | {row['latent_spearman']:.3f} | "
                     f"{row['node_count_spearman']:.3f} | {row['margin']:+.3f} | {row['window_distinct']:g} | "
                     f"{'yes' if row['passes'] else 'no'} |")
    return lines + _thesis_scale(metrics.get("thesis_scale"), gate)


def _thesis_scale(progress: dict | None, gate: dict) -> list[str]:
    """The thesis-scale VAE's gate verdict on the campaign's groups (the largest group of scored designs decides:
    the campaign's rung), or how far its committed measurement is; then how far GLSO_nopred's twin is, if asked."""
    if progress is None:
        return []
    scale = (f"hidden {progress['hidden']}, predictor weight {progress['pred_weight']:g}, "
             f"{progress['designs']:,} designs, {progress['steps']:,} steps")
    if not progress["issue_scale"]:
        scale += " (below the issue's 100k designs x 100k steps: a trial)"
    trained = progress["trained"]
    twin = ([f" Its twin without the property predictor (GLSO_nopred's): step {trained['nopred']['step']:,} of "
             f"{progress['steps']:,}{', finished' if trained['nopred']['finished'] else ''}."]
            if "nopred" in trained else [])
    rows = {key: row for key, row in gate.items() if key.startswith(f"{progress['variant']}/")}
    if not trained["full"]["finished"] or not rows:
        return ["", f"{progress['title']} ({scale}, `robocompose glso-campaign vae`): in progress, "
                f"{progress['designs']:,} of {progress['designs_asked']:,} designs enumerated, step "
                f"{trained['full']['step']:,} of {progress['steps']:,} trained (committed in "
                f"{progress['directory']}).{''.join(twin)}"]
    key, row = max(rows.items(), key=lambda item: item[1]["designs"])
    return ["", verdict(f"{progress['title']} passes the gate ({scale})", held(row["passes"]),
                        f"On {key.split('/', 1)[1]} ({row['designs']} designs): margin {row['margin']:+.3f} "
                        f"(needs >= {row['gate_margin']:g}), window {row['window_distinct']:g} distinct designs "
                        f"(needs >= {row['gate_distinct']}).{''.join(twin)}")]
