import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.grammar.tree import N_TOKENS, DesignTree
from robocompose.io import read_table, write_table
from robocompose.io.errors import InputError
from robocompose.latent.constraints import replay
from robocompose.latent.landscape import (
    LandscapeConfig,
    knn_predictability,
    landscape,
    node_type_counts,
    principal_axes,
    read_search_designs,
    vae_gate,
    window_distinct,
)
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import Designs

pytestmark = pytest.mark.usefixtures("one_torch_thread")  # tests/conftest.py


def test_principal_axes_find_the_long_axis():
    rng = np.random.default_rng(0)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    x = rng.normal(size=(200, 3)) * [5.0, 1.0, 0.1] @ rotation
    axes, explained = principal_axes(x)
    assert explained[0] > 0.9 > explained[1] > 0.03
    assert abs(axes[0] @ rotation[0]) > 0.99  # the first axis is the long one
    xy = (x - x.mean(0)) @ axes.T
    assert np.var(xy[:, 0]) > 20 * np.var(xy[:, 1]) / 2
    np.testing.assert_allclose(principal_axes(x[::-1])[0], axes, atol=1e-9)  # sign fixed by the loadings


def test_landscape_scores_the_subset_with_the_evaluator(make_trees):
    torch.manual_seed(0)
    trees = make_trees(10, 0, min_links=11)  # dataset-like designs (all have hinges)
    designs = Designs([t.design_id for t in trees], trees, [replay(t, "grammar", 50) for t in trees],
                      np.zeros((len(trees), 16), dtype=np.float32))
    models = {name: GraphVAE(VAEConfig(hidden=8, latent=3)) for name in ("full", "nopred")}
    quick = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2))
    table, knn, gate = landscape(models, designs, LandscapeConfig(designs=10, evaluated=2, searches="", campaign=""),
                                 quick)
    assert len(table) == 20 and knn == {} == gate and set(table["source"]) == {"dataset"}
    assert set(table["variant"]) == {"full", "nopred"}
    for _, part in table.groupby("variant"):
        assert (part["status"] != "").sum() == 2 and part["status"].iloc[2:].eq("").all()
        assert abs(part["pc1"].mean()) < 1e-6  # centred
    full, nopred = (table[table["variant"] == v].reset_index() for v in ("full", "nopred"))
    assert list(full["design_id"]) == list(nopred["design_id"])
    assert full["reward"].iloc[:2].equals(nopred["reward"].iloc[:2])  # same designs, same scores


SEARCH = Path(__file__).parents[2] / "measured" / "fidelity" / "searches" / "flat__s8_h8_e48__random.parquet"


def _search_tables(directory: Path) -> pd.DataFrame:
    """A committed search table's first rows, its first 4 designs again under another method and on ridged."""
    steps = read_table(SEARCH, "glso_steps").head(12)
    write_table(steps, directory / "flat__s8_h8_e48__random.parquet", "glso_steps")
    write_table(steps.head(4).assign(method="mcts"), directory / "flat__s8_h8_e48__mcts.parquet", "glso_steps")
    write_table(steps.head(4).assign(task="ridged"), directory / "ridged__s8_h8_e48__random.parquet", "glso_steps")
    return steps


def test_search_designs_are_read_once_per_task_and_rung_with_their_first_result(tmp_path):
    steps = _search_tables(tmp_path)
    table, designs = read_search_designs(tmp_path, "grammar", 50)
    flat = table[table["task"] == "flat"]
    assert len(flat) == steps["design_id"].nunique() and len(table) == len(flat) + steps.head(4)["design_id"].nunique()
    assert designs.ids == list(table["design_id"]) == [t.design_id for t in designs.trees]
    first = steps.drop_duplicates("design_id").set_index("design_id")["reward"]
    np.testing.assert_array_equal(flat.set_index("design_id")["reward"], first[flat["design_id"]])
    (tmp_path / "flat_s8_random.parquet").write_bytes(SEARCH.read_bytes())
    with pytest.raises(InputError, match="flat_s8_random.parquet: expected a search table named"):
        read_search_designs(tmp_path, "grammar", 50)
    with pytest.raises(InputError, match="missing is not a directory"):
        read_search_designs(tmp_path / "missing", "grammar", 50)


def test_campaign_runs_join_at_the_rung_their_manifest_records(tmp_path):
    """Campaign tables are named <task>_<method>_seed<k>.parquet and say their rung only in campaign.json."""
    steps = read_table(SEARCH, "glso_steps").head(6)
    (tmp_path / "searches").mkdir()
    campaign = tmp_path / "campaign"
    campaign.mkdir()
    write_table(steps.assign(method="ghs"), campaign / "flat_ghs_seed0.parquet", "glso_steps")
    with pytest.raises(InputError, match="campaign.json: missing"):
        read_search_designs(tmp_path / "searches", "grammar", 50, campaign)
    (campaign / "campaign.json").write_text(json.dumps({"rung": "s16_h16_e48", "settings_hash": {}}))
    table, designs = read_search_designs(tmp_path / "searches", "grammar", 50, campaign)
    assert set(table["rung"]) == {"s16_h16_e48"} and set(table["source"]) == {"campaign:ghs"}
    assert list(table["design_id"]) == list(steps["design_id"].drop_duplicates()) == designs.ids


def test_search_designs_join_the_projection_on_the_dataset_axes(make_trees, tmp_path):
    torch.manual_seed(0)
    _search_tables(tmp_path)
    trees = make_trees(10, 0, min_links=11)
    designs = Designs([t.design_id for t in trees], trees, [replay(t, "grammar", 50) for t in trees],
                      np.zeros((len(trees), 16), dtype=np.float32))
    models = {"full": GraphVAE(VAEConfig(hidden=8, latent=3))}
    quick = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2))
    config = LandscapeConfig(designs=10, evaluated=1, searches=str(tmp_path), campaign="", neighbours=2, min_group=5,
                             shuffles=20)
    table, knn, gate = landscape(models, designs, config, quick)
    dataset, found = table[table["source"] == "dataset"], table[table["source"] != "dataset"]
    assert len(dataset) == 10 and abs(dataset["pc1"].mean()) < 1e-6  # the axes are the dataset designs' own
    # files in name order: the mcts table, read first, claims the 4 designs it repeats
    assert found[found["task"] == "flat"]["source"].value_counts().to_dict() == {"search:random": 8, "search:mcts": 4}
    assert set(knn) == {"full/flat/s8_h8_e48"}  # ridged has 4 designs, fewer than min_group
    assert knn["full/flat/s8_h8_e48"]["designs"] == int((found[found["task"] == "flat"]["status"] == "ok").sum())
    assert set(gate) == set(knn)  # the gate beside each k-NN figure, its latent Spearman the same number
    row = gate["full/flat/s8_h8_e48"]
    assert row["latent_spearman"] == knn["full/flat/s8_h8_e48"]["spearman"]
    assert row["designs"] == knn["full/flat/s8_h8_e48"]["designs"]
    assert row["margin"] == pytest.approx(row["latent_spearman"] - row["node_count_spearman"])
    assert len(row["window_distinct_each"]) == 5 and row["window_samples"] == 200
    assert row["passes"] == (row["margin"] >= 0.1 and row["window_distinct"] >= 10)


def test_knn_predictability_tells_a_smooth_score_from_a_shuffled_one():
    rng = np.random.default_rng(0)
    latents = rng.normal(size=(120, 4))
    smooth = knn_predictability(latents, latents[:, 0] + 0.1 * rng.normal(size=120), k=5, shuffles=200, seed=0)
    noise = knn_predictability(latents, rng.normal(size=120), k=5, shuffles=200, seed=0)
    assert smooth["spearman"] > 0.7 and smooth["p_value"] == pytest.approx(1 / 201)
    assert abs(smooth["shuffled_mean"]) < 0.1 and smooth["shuffled_95"] < 0.3
    assert noise["spearman"] < noise["shuffled_95"] and noise["p_value"] > 0.05
    assert knn_predictability(latents, latents[:, 0], k=5, shuffles=50, seed=3) == \
        knn_predictability(latents, latents[:, 0], k=5, shuffles=50, seed=3)  # seeded


def test_node_type_counts_count_each_token_over_a_designs_nodes():
    trees = [DesignTree((-1,), (14,)), DesignTree((-1, 0, 0, 1), (14, 31, 31, 5))]
    counts = node_type_counts(trees)
    assert counts.shape == (2, N_TOKENS) and counts.sum(1).tolist() == [1, 4]
    assert counts[0, 14] == 1 and counts[1, 14] == 1 and counts[1, 31] == 2 and counts[1, 5] == 1
    assert node_type_counts([]).shape == (0, N_TOKENS)


def test_the_gate_fails_a_latent_space_that_node_counts_beat():
    """Scores that are the number of one token: node counts predict them (ties included), a random latent does not."""
    rng = np.random.default_rng(0)
    trees = [DesignTree(tuple(range(-1, n - 1)), (14,) + (5,) * (n - 1)) for n in rng.integers(1, 12, size=90)]
    scores = np.array([t.n_links for t in trees], dtype=float) + 0.01 * rng.normal(size=90)
    counts = node_type_counts(trees)
    baseline = knn_predictability(counts, scores, k=5, shuffles=50, seed=0)
    latent = knn_predictability(rng.normal(size=(90, 4)), scores, k=5, shuffles=50, seed=0)
    assert baseline["spearman"] > 0.9 and abs(latent["spearman"]) < 0.3
    model = GraphVAE(VAEConfig(hidden=8, latent=4, max_nodes=12))
    config = LandscapeConfig(window_samples=20, gate_distinct=1)  # the window cannot fail this one: the margin does
    gate = vae_gate(model, rng.normal(size=(90, 4)), baseline, scores, latent, config)
    assert gate["margin"] < 0 and not gate["passes"] and gate["window_distinct"] >= 1
    assert gate["node_count_spearman"] == baseline["spearman"] and gate["designs"] == 90
    swapped = vae_gate(model, rng.normal(size=(90, 4)), latent, scores, baseline, config)  # the other way round
    assert swapped["margin"] > 0.1 and swapped["passes"]


def test_a_wider_window_decodes_to_more_designs():
    torch.manual_seed(0)
    model = GraphVAE(VAEConfig(hidden=16, latent=4))
    centre = np.zeros(4)
    assert window_distinct(model, centre, width=0.0, samples=30, seed=0) == 1  # every draw is the centre
    assert window_distinct(model, centre, width=6.0, samples=30, seed=0) > 1
    assert window_distinct(model, np.full(4, 5.0), width=0.0, samples=5) == 1  # a centre outside: moved inside
    with pytest.raises(InputError, match="width: expected a finite number in"):
        window_distinct(model, centre, width=7.0)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("gate_margin", float("nan"), "gate_margin: expected a finite number in"),
    ("window_width", 0.0, r"window_width: expected a finite number in \(0, 6\]"),
    ("window_samples", 0, "window_samples: expected an integer >= 1"),
    ("gate_distinct", 201, r"gate_distinct: expected an integer in \[1, window_samples \(200\)\]"),
    ("gate_top", 0, "gate_top: expected an integer in"),
])
def test_the_gates_settings_are_checked(field, value, message):
    with pytest.raises(InputError, match=message):
        LandscapeConfig(**{field: value})
