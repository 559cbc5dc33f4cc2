import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from robocompose.glso.registry import describe
from robocompose.io import ArtifactError, write_table
from robocompose.latent.curves import LOG_FIELDS
from robocompose.latent.train import log_evaluation, log_row, training_log
from robocompose.report.latent import section

TRAIN_VAE = {"model": {"hidden": 16, "latent": 4},
             "train": {"steps": 200, "batch_size": 8, "beta_start": 100, "beta_increment": 0.001, "beta_every": 10,
                       "pred_weight": 20.0, "holdout": 0.1}}
METRIC = {"reconstruction_accuracy": 0.75, "prior_validity": 1.0, "prior_grammar_valid": 1.0,
          "prior_rest_valid": 0.8, "uniqueness": 0.9, "novelty": 0.5, "property_mse": 0.25,
          "property_baseline_mse": 0.5, "property_r2": 0.5, "prior_samples": 100,
          "unconstrained": {"reconstruction_accuracy": 0.125, "prior_validity": 0.5, "prior_grammar_valid": 0.0,
                            "prior_rest_valid": 0.0, "uniqueness": 1.0, "novelty": 1.0}}


def test_section_reports_pending_without_metrics(tmp_path):
    assert "Not run yet" in section(tmp_path, tmp_path, TRAIN_VAE)


def test_a_corrupt_summary_is_named(tmp_path):
    (tmp_path / "training" / "vae_full").mkdir(parents=True)
    (tmp_path / "training" / "vae_full" / "metrics.json").write_text("{not json")
    with pytest.raises(ArtifactError, match="vae_full/metrics.json: not valid JSON"):
        section(tmp_path, tmp_path, TRAIN_VAE)
    (tmp_path / "training" / "vae_full" / "metrics.json").write_text('{"loss": 1.0}')
    with pytest.raises(ArtifactError, match="vae_full/metrics.json: expected dvclive's summary"):
        section(tmp_path, tmp_path, TRAIN_VAE)


def _record_registry(reports):
    (reports / "metrics").mkdir(parents=True, exist_ok=True)  # as the glso stage records the registry
    (reports / "metrics" / "glso.json").write_text(json.dumps({"methods": describe()}))


def test_section_titles_each_vae_by_the_method_that_searches_it_from_the_glso_record(tmp_path):
    with training_log(tmp_path / "training" / "vae_nogram") as live:
        log_evaluation(live, METRIC)
    with pytest.raises(ArtifactError, match="glso.json: missing; the VAE variants are titled by the GLSO methods"):
        section(tmp_path, tmp_path, TRAIN_VAE)
    (tmp_path / "metrics").mkdir(exist_ok=True)
    (tmp_path / "metrics" / "glso.json").write_text(json.dumps({"methods": [{"name": "glso", "title": "GLSO"}]}))
    with pytest.raises(ArtifactError, match="glso.json: no record of the methods' VAE variants"):
        section(tmp_path, tmp_path, TRAIN_VAE)
    (tmp_path / "metrics" / "glso.json").write_text(json.dumps({"methods": [
        {"name": "glso", "title": "GLSO", "variant": "full"}]}))
    with pytest.raises(ArtifactError, match=r"no GLSO method searches VAE variants \['nogram'\]"):
        section(tmp_path, tmp_path, TRAIN_VAE)
    _record_registry(tmp_path)
    assert "| GLSO_nogram | 0.750 |" in section(tmp_path, tmp_path, TRAIN_VAE)


def test_section_shows_metrics_curves_and_landscape(tmp_path):
    _record_registry(tmp_path)
    for name, metric in {"full": METRIC, "nopred": {**METRIC, "property_mse": None}}.items():
        with training_log(tmp_path / "training" / f"vae_{name}") as live:  # as the train_vae stage logs
            for step in (50, 100, 150, 200):
                log_row(live, {**{k: step / 100 for k in LOG_FIELDS}, "step": step,
                               "heldout_reconstruction": 0.5 if step == 200 else np.nan})
            log_evaluation(live, metric)
    text = section(tmp_path, tmp_path, TRAIN_VAE)
    assert "| GLSO | 0.750 | 1.000" in text and "| GLSO_nopred |" in text
    assert "| 0.250 | 0.500 | 0.500 |" in text and "n/a" in text  # MSE, its mean baseline, R^2; nopred: none
    assert "| GLSO | 0.125 | 0.500 | 0.000" in text  # decoded as the original
    assert (tmp_path / "figures" / "vae_training.png").exists()
    assert "Latent landscape (Fig. 7.1): pending" in text

    rows = [{"variant": v, "design_id": f"d{i}", "pc1": float(i), "pc2": float(-i), "explained1": 0.5,
             "explained2": 0.2, "status": ["ok", "self_collision", ""][i % 3], "reward": [4.5, None, None][i % 3],
             "source": "dataset", "task": "flat", "rung": "default"} for v in ("full", "nopred") for i in range(9)]
    rows += [{**row, "design_id": f"s{i}", "status": "ok", "reward": 4.0 + i / 10, "source": "search:glso",
              "rung": "s8_h8_e48", "task": ["flat", "ridged"][i % 2]} for i, row in enumerate(rows)]
    write_table(pd.DataFrame(rows), tmp_path / "vae_landscape.parquet", "vae_landscape")
    text = section(tmp_path, tmp_path, TRAIN_VAE)
    assert "figures/vae_landscape.png" in text and "6 of them scored" in text and "and 9 designs" in text
    assert "(search:glso: search = a fidelity search, campaign = a run of the GLSO campaign; flat at s8_h8_e48, " \
        "ridged at s8_h8_e48)" in text
    with Image.open(tmp_path / "figures" / "vae_landscape.png") as figure:  # a row of panels per task
        assert figure.size == (1100, 924)

    knn = {"spearman": 0.4, "shuffled_mean": 0.0, "shuffled_95": 0.15, "p_value": 0.001, "designs": 120}
    (tmp_path / "metrics").mkdir(exist_ok=True)
    knns = {"full/flat/s8_h8_e48": knn, "nopred/flat/s8_h8_e48": {**knn, "spearman": 0.1}}
    (tmp_path / "metrics" / "vae_landscape.json").write_text(json.dumps({"knn_predictability": knns}))
    with pytest.raises(ArtifactError, match=r"vae_landscape.json: no `gate` .*rerun stage `vae_landscape`"):
        section(tmp_path, tmp_path, TRAIN_VAE)  # written before the gate existed

    settings = {"window_samples": 200, "window_width": 0.5, "gate_margin": 0.1, "gate_distinct": 10, "gate_top": 5}
    gate = {"full/flat/s8_h8_e48": {**settings, "designs": 120, "latent_spearman": 0.4, "node_count_spearman": 0.25,
                                    "margin": 0.15, "window_distinct": 12.0, "passes": True},
            "nopred/flat/s8_h8_e48": {**settings, "designs": 120, "latent_spearman": 0.1, "node_count_spearman": 0.25,
                                      "margin": -0.15, "window_distinct": 2.0, "passes": False}}
    (tmp_path / "metrics" / "vae_landscape.json").write_text(json.dumps({"knn_predictability": knns, "gate": gate}))
    text = section(tmp_path, tmp_path, TRAIN_VAE)
    assert "| GLSO | flat | s8_h8_e48 | 120 | 0.400 | 0.000 | 0.150 | 0.001 |" in text
    assert "GLSO in 1 of 1 groups; GLSO_nopred in 0 of 1 groups" in text
    assert "The gate a thesis-scale VAE must pass before a campaign uses it (issue 42)" in text
    assert "by >= 0.1, and a box 0.5 wide" in text and ">= 10 distinct designs of 200 uniform draws" in text
    assert "| GLSO | flat | s8_h8_e48 | 120 | 0.400 | 0.250 | +0.150 | 12 | yes |" in text
    assert "| GLSO_nopred | flat | s8_h8_e48 | 120 | 0.100 | 0.250 | -0.150 | 2 | no |" in text

    # the thesis-scale VAE: its progress until finished, then a verdict from its gate on the largest group
    progress = {"directory": "measured/vae_thesis", "pieces": 4, "designs": 40_000, "designs_asked": 100_000,
                "steps": 100_000, "trained": {"full": {"step": 0, "finished": False, "sha256": None}},
                "hidden": 450, "pred_weight": 20.0, "issue_scale": True, "variant": "thesis",
                "title": "GLSO's VAE at thesis scale"}
    metrics = {"knn_predictability": knns, "gate": gate, "thesis_scale": progress}
    (tmp_path / "metrics" / "vae_landscape.json").write_text(json.dumps(metrics))
    text = section(tmp_path, tmp_path, TRAIN_VAE)
    assert "GLSO's VAE at thesis scale (hidden 450, predictor weight 20, 40,000 designs, 100,000 steps, " \
        "`robocompose glso-campaign vae`): in progress, 40,000 of 100,000 designs enumerated, step 0 of 100,000" in text
    failed = {**gate["full/flat/s8_h8_e48"], "designs": 3002, "margin": 0.05, "window_distinct": 30.0, "passes": False}
    metrics = {"knn_predictability": knns | {"thesis/flat/s16_h16_e48": knn},
               "gate": gate | {"thesis/flat/s8_h8_e48": {**failed, "designs": 120, "passes": True},
                               "thesis/flat/s16_h16_e48": failed},
               "thesis_scale": {**progress, "designs": 100_500, "trained": {
                   "full": {"step": 100_000, "finished": True, "sha256": "ab"},
                   "nopred": {"step": 3_000, "finished": False, "sha256": None}}}}
    (tmp_path / "metrics" / "vae_landscape.json").write_text(json.dumps(metrics))
    text = section(tmp_path, tmp_path, TRAIN_VAE)
    assert "| GLSO's VAE at thesis scale | flat | s16_h16_e48 | 3002 | 0.400 | 0.250 | +0.050 | 30 | no |" in text
    assert "GLSO's VAE at thesis scale passes the gate (hidden 450, predictor weight 20, 100,500 designs, 100,000 " \
        "steps): **does NOT hold** On flat/s16_h16_e48 (3002 designs): margin +0.050 (needs >= 0.1)" in text
    assert "Its twin without the property predictor (GLSO_nopred's): step 3,000 of 100,000." in text
