import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from robocompose.evaluation import fidelity
from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
from robocompose.evaluation.manifest import claim_directory
from robocompose.glso import campaign
from robocompose.glso.campaign import CampaignConfig, compare, run_specs
from robocompose.glso.runs import GLSOConfig
from robocompose.grammar.tree import DesignTree
from robocompose.io import write_table
from robocompose.io.errors import ArtifactError, InputError
from tests.glso.conftest import hand_steps, tree_designs


def test_runs_go_seed_major_so_a_partial_campaign_compares_every_method():
    config = CampaignConfig(seeds={"glso": 2, "random": 2, "glso_nopred": 1})
    names = [s.name for s in run_specs(config)]
    assert names == ["flat_glso_seed0", "flat_glso_nopred_seed0", "flat_random_seed0", "flat_glso_seed1",
                     "flat_random_seed1"]


@pytest.mark.parametrize("bad, message", [({"seeds": {"nelder_mead": 3}}, "seeds"), ({"init": 200}, "init"),
                                          ({"rung": "fast"}, "unknown fidelity rung 'fast'"),
                                          ({"ghs_eps_end": 1.5}, "ghs_eps_end"),
                                          ({"alpha": 1.5}, r"alpha: expected a finite number in \(0, 1\), found 1.5"),
                                          ({"alpha": float("nan")}, "alpha: expected a finite number"),
                                          ({"seeds": {"glso": -2}}, "seeds.glso: expected an integer >= 0"),
                                          ({"tasks": []}, "tasks: expected at least one task"),
                                          ({"tasks": ["moon"]}, r"tasks: expected tasks of \['flat'"),
                                          ({"bootstrap": 0}, "bootstrap: expected an integer >= 1"),
                                          ({"rescore_seeds": [-1]}, "rescore_seeds: expected controller seeds >= 0"),
                                          ({"heldout_seeds": [201, 202, 203, 102]},
                                           r"heldout_seeds: expected controller seeds disjoint from rescore_seeds "
                                           r"\[101, 102\], found \[201, 202, 203, 102\]"),
                                          ({"heldout_seeds": [201, 202, 203]},
                                           "heldout_seeds: expected at least 4 distinct controller seeds"),
                                          ({"heldout_seeds": [201, 202, 203, 203]},
                                           "heldout_seeds: expected at least 4 distinct controller seeds"),
                                          ({"heldout_seeds": [-1, 202, 203, 204]},
                                           "heldout_seeds: expected controller seeds >= 0"),
                                          ({"heldout_top": 0}, "heldout_top: expected an integer >= 1")])
def test_bad_campaign_settings_name_the_field(bad, message):
    with pytest.raises(ValueError, match=message):
        CampaignConfig(**bad)


def test_the_campaign_runs_its_own_budget_init_population_and_ghs_epsilons_over_the_profile():
    smoke = GLSOConfig(budget=16, bo={"init": 6}, ga={"population": 8}, ghs={"eps_end": 0.5, "eps_sample_end": 0.5})
    runs = campaign.search_config(CampaignConfig(budget=200, init=50, population=50, ghs_eps_end=0.1), smoke)
    assert (runs.budget, runs.bo.init, runs.ga.population) == (200, 50, 50)
    # GLSO's variants start from the campaign's init as GLSO does, keeping what makes each a variant
    assert (runs.bo_nodr.init, runs.bo_floor.init, runs.bo_reask.init) == (50, 50, 50)
    assert (runs.bo_nodr.domain_reduction, runs.bo_floor.minimum_window, runs.bo_reask.reask) == (False, 2.0, 3)
    assert (runs.ghs.eps_end, runs.ghs.eps_sample_end) == (0.1, 0.1)
    assert runs.ghs.eps_decay == smoke.ghs.eps_decay and runs.mcts == smoke.mcts  # the rest is the profile's


def test_the_campaign_runs_at_its_own_rung_whatever_glso_rung_says(tmp_path, monkeypatch):
    """glso.rung is the smoke run's: the campaign's jobs (settings, evaluator, so run keys and manifest) are the
    same with it as without it, at the campaign's rung."""
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    config = CampaignConfig(directory=str(tmp_path / "campaign"), checkpoints=str(tmp_path / "ckpt"),
                            cache=str(tmp_path / "cache.parquet"),
                            seeds={"random": 1, "mcts": 1}, budget=3, init=1)
    plain = campaign.campaign_jobs(config, GLSOConfig(), EvaluationConfig(), "tiny")
    smoke = campaign.campaign_jobs(config, GLSOConfig(rung="s8_h8_e48"), EvaluationConfig(), "tiny")
    assert smoke == plain  # the manifest written by the first call accepts the second: one evaluator
    for job in smoke:
        assert job.evaluation.mppi == fidelity.rung_config("tiny") and job.glso.rung == ""


def _finals(values: dict[str, list[float]]) -> pd.DataFrame:
    return pd.DataFrame([{"task": "flat", "method": m, "seed": i, "search": v, "rescored": v - 1.0}
                         for m, vs in values.items() for i, v in enumerate(vs)])


# The score logs of a campaign that has none yet, as read
NO_RESCORES, NO_HELDOUT = (campaign.read_scores("nowhere", log) for log in (campaign.RESCORES_FILE,
                                                                             campaign.HELDOUT_FILE))


def test_the_distinct_axis_is_the_calls_axis_without_the_repeats_and_k_is_the_fewest_any_run_reached():
    steps = hand_steps({("glso", 0): [("a", 4.0), ("b", 4.5), ("a", 4.0), ("c", 4.8), ("b", 4.5), ("d", 4.9)],
                        ("random", 0): [("p", 3.0), ("q", 3.5), ("r", 4.0), ("s", 4.2), ("t", 5.0), ("u", 5.1)],
                        ("random", 1): [("p", 3.0), ("p", 3.0), ("p", 3.0), ("q", 3.5), ("p", 3.0), ("r", 4.1)]})
    new = campaign.by_distinct_designs(steps)
    glso = new[new["method"] == "glso"]
    assert list(glso["distinct"]) == [1, 2, 3, 4] and list(glso["step"]) == [0, 1, 3, 5]
    assert glso.drop(columns="distinct").equals(steps[(steps["method"] == "glso") & ~steps["repeat"]])
    assert list(glso["best_so_far"]) == [4.0, 4.5, 4.8, 4.9]

    final = campaign.final_bests(steps, NO_RESCORES).set_index(["method", "seed"])
    assert list(final["calls"]) == [6, 6, 6] and list(final["distinct"]) == [4, 6, 3]
    assert set(final["k"]) == {3}  # random seed 1's 3 distinct designs: every run has a value there
    # After 3 distinct designs, not 3 calls (GLSO's best after 3 calls is 4.5): GLSO's 4th call, random seed 1's 6th
    assert list(final["matched"]) == [4.8, 4.0, 4.1] and list(final["calls_at_k"]) == [4, 3, 6]
    assert list(final["search"]) == [4.9, 5.1, 4.1]

    spent = campaign.spend(final.reset_index()).set_index("method")
    assert spent.loc["random", ["runs", "calls", "distinct", "distinct_q25", "distinct_q75", "calls_at_k"]].tolist() \
        == [2, 6, 4.5, 3.75, 5.25, 4.5]
    curves = campaign.distinct_curves(steps)
    random = curves[curves["method"] == "random"]  # ends at its shortest run: past it, one seed would be the median
    assert list(random["distinct"]) == [1, 2, 3] and set(random["runs"]) == {2}
    assert list(random["median"]) == [3.0, 3.5, 4.05]
    assert list(curves[curves["method"] == "glso"]["median"]) == [4.0, 4.5, 4.8, 4.9]


def test_the_matched_comparison_is_at_k_distinct_designs_beside_the_calls_comparison(tmp_path):
    """GLSO sends one good design four times; random search four designs, the last its best: per call random
    search wins, per distinct design GLSO does."""
    runs = {("glso", i): [("g", 5.0 + i / 100)] * 4 for i in range(5)}
    runs |= {("random", i): [(f"r{i}{j}", 4.0 + i / 100 + j) for j in range(4)] for i in range(5)}
    summary = campaign.statistics(hand_steps(runs), NO_RESCORES, NO_HELDOUT, CampaignConfig(bootstrap=100))
    assert summary["k"] == {"flat": 1} and summary["alpha"] == 0.05
    tests = {r["on"]: r for r in summary["tests"]}
    assert set(tests) == {"matched", "search"}  # nothing re-scored: no re-scored comparison
    assert tests["matched"]["p"] == pytest.approx(1 / math.comb(10, 5)) and tests["matched"]["better"]
    assert tests["matched"]["median_difference"] == pytest.approx(1.0)
    assert tests["search"]["p"] > 0.5 and not tests["search"]["better"]
    assert tests["search"]["median_difference"] == pytest.approx(-2.0)
    assert [(s["method"], s["calls"], s["distinct"], s["calls_at_k"]) for s in summary["spend"]] == [
        ("glso", 4, 1, 1), ("random", 4, 4, 1)]
    assert set(summary["curves"]) == {"calls", "distinct"}
    assert max(c["distinct"] for c in summary["curves"]["distinct"]) == 4
    path = campaign.plot(summary, tmp_path / "plot.png")
    width, height = Image.open(path).size
    assert width > height  # a task drawn on both axes: two panels per figure row


def test_glso_is_called_better_only_when_the_test_after_correction_says_so():
    finals = _finals({"glso": [5.0, 5.1, 5.2, 5.3, 5.4], "random": [4.0, 4.1, 4.2, 4.3, 4.4],
                      "mcts": [4.9, 5.5, 5.0, 5.6, 5.05], "glso_nopred": [4.0, 4.1, 4.2]})
    rows = {r["method"]: r for r in compare(finals, "search", bootstrap=500, alpha=0.05)}
    assert rows["random"]["p"] == pytest.approx(1 / math.comb(10, 5))  # every GLSO run beats every random run
    assert rows["random"]["p_holm"] == pytest.approx(2 / math.comb(10, 5)) and rows["random"]["better"]
    assert not rows["mcts"]["better"] and rows["mcts"]["p_holm"] >= rows["mcts"]["p"]
    assert rows["glso_nopred"]["family"] == "ablations" and rows["glso_nopred"]["p_floor"] == 1 / math.comb(8, 3)
    assert rows["glso_nopred"]["holm_floor"] == rows["glso_nopred"]["p_floor"]  # alone in its family
    assert rows["random"]["holm_floor"] == rows["mcts"]["holm_floor"] == pytest.approx(2 / math.comb(10, 5))
    assert rows["random"]["median_difference"] == pytest.approx(1.0)
    assert rows["random"]["ci_low"] <= 1.0 <= rows["random"]["ci_high"] and rows["random"]["ci_low"] > 0


def test_an_arm_of_glso_meets_the_baselines_alone_in_its_own_family_and_glso_keeps_its_tests():
    finals = _finals({"glso": [4.0, 4.1, 4.2], "glso_thesis": [5.0, 5.1, 5.2, 5.3, 5.4],
                      "random": [4.5, 4.6, 4.7, 4.8, 4.9], "glso_nopred": [3.0, 3.1, 3.2]})
    assert campaign.challengers(finals) == ["glso", "glso_thesis"]
    assert campaign.challengers(finals[finals["method"] != "glso_thesis"]) == ["glso"]  # no runs, no tests
    rows = compare(finals, "search", bootstrap=50, alpha=0.05, reference="glso_thesis")
    assert [(r["reference"], r["family"], r["method"], r["n_reference"]) for r in rows] == [
        ("glso_thesis", "baselines", "random", 5)]  # the ablations are GLSO's, and GLSO is not its baseline
    assert rows[0]["p"] == pytest.approx(1 / math.comb(10, 5)) and rows[0]["better"]
    glso = compare(finals, "search", bootstrap=50, alpha=0.05)
    assert {(r["family"], r["method"]): r["better"] for r in glso} == {("baselines", "random"): False,
                                                                       ("ablations", "glso_nopred"): False}


def test_the_thesis_scale_arm_meets_the_baselines_and_its_own_nopred_not_glsos_ablations():
    finals = _finals({"glso": [4.0, 4.1, 4.2], "glso_turbo_thesis": [5.0, 5.1, 5.2, 5.3, 5.4],
                      "glso_nopred_turbo_thesis": [4.5, 4.6, 4.7, 4.8, 4.9], "random": [4.5, 4.6, 4.7, 4.8, 4.9],
                      "glso_nopred": [3.0, 3.1, 3.2]})
    assert campaign.challengers(finals) == ["glso", "glso_turbo_thesis"]  # its nopred twin is an ablation, no arm
    rows = compare(finals, "search", bootstrap=50, alpha=0.05, reference="glso_turbo_thesis")
    assert [(r["family"], r["method"]) for r in rows] == [("baselines", "random"),
                                                          ("ablations", "glso_nopred_turbo_thesis")]
    glso = compare(finals, "search", bootstrap=50, alpha=0.05)
    assert "glso_nopred_turbo_thesis" not in {r["method"] for r in glso}  # another VAE: not GLSO's ablation


def _thesis_gate(tmp_path: Path, passes: bool, model: bytes = b"vae") -> tuple[CampaignConfig, GLSOConfig, Path]:
    (tmp_path / "vae").mkdir(exist_ok=True)
    for variant in ("full", "nopred"):
        (tmp_path / "vae" / f"vae_{variant}.pt").write_bytes(model if variant == "full" else b"twin")
    gate = {"thesis/flat/s8_h8_e48": {"margin": 0.2 if passes else 0.05, "gate_margin": 0.1,
                                      "window_distinct": 12.0, "gate_distinct": 10, "passes": passes}}
    sha = hashlib.sha256(b"vae").hexdigest()
    metrics = tmp_path / "vae_landscape.json"
    metrics.write_text(json.dumps({"gate": gate, "thesis_scale": {"trained": {"full": {"sha256": sha}}}}))
    config = CampaignConfig(directory=str(tmp_path / "runs"), tasks=["flat"],
                            seeds={"glso_turbo_thesis": 1, "glso_nopred_turbo_thesis": 1})
    return config, GLSOConfig(thesis_models=str(tmp_path / "vae" / "vae_{variant}.pt")), metrics


def test_a_thesis_scale_vae_is_searched_only_once_this_very_model_passed_its_gate(tmp_path):
    config, glso, metrics = _thesis_gate(tmp_path, passes=True)
    assert glso.model_path("glso_nopred_turbo_thesis") == tmp_path / "vae" / "vae_nopred.pt"
    campaign.check_thesis_gate(config, glso, "s8_h8_e48", metrics)  # passed: no error
    with pytest.raises(InputError, match=r"gate.thesis/flat/s16_h16_e48: no gate; expected a passed gate"):
        campaign.check_thesis_gate(config, glso, "s16_h16_e48", metrics)  # gated at another rung
    config, glso, metrics = _thesis_gate(tmp_path, passes=False)
    with pytest.raises(InputError, match=r"margin \+0.050 \(needs >= 0.1\), window 12 \(needs >= 10\); expected"):
        campaign.check_thesis_gate(config, glso, "s8_h8_e48", metrics)
    config, glso, metrics = _thesis_gate(tmp_path, passes=True, model=b"retrained")
    with pytest.raises(InputError, match=r"thesis_scale.trained.full.sha256: .* is not the SHA-256 of"):
        campaign.check_thesis_gate(config, glso, "s8_h8_e48", metrics)
    with pytest.raises(InputError, match="not found; the thesis-scale VAE is gated by stage vae_landscape"):
        campaign.check_thesis_gate(config, glso, "s8_h8_e48", tmp_path / "none.json")
    (tmp_path / "vae" / "vae_nopred.pt").unlink()
    with pytest.raises(InputError, match="vae_nopred.pt: the thesis-scale VAE of method glso_nopred_turbo_thesis"):
        campaign.check_thesis_gate(config, glso, "s8_h8_e48", metrics)
    # no planned run searches it: nothing to check, whatever the files say
    campaign.check_thesis_gate(CampaignConfig(seeds={"glso_turbo_thesis": 0, "glso": 1}), glso, "s8_h8_e48",
                               tmp_path / "none.json")


def test_the_omnibus_test_covers_glso_and_the_baselines_only_and_tells_separated_from_level_groups():
    separated = _finals({"glso": [5.0, 5.1, 5.2], "random": [4.0, 4.1, 4.2], "ga": [3.0, 3.1, 3.2],
                         "glso_nopred": [9.0, 9.1, 9.2], "glso_thesis": [9.0, 9.1]})
    row, = campaign.omnibus(separated, "search")
    assert row["methods"] == ["glso", "random", "ga"] and row["n"] == [3, 3, 3]  # Fig. 8.1's, in registry order
    assert row["p"] < 0.05
    level = _finals({"glso": [4.0, 4.2, 4.1], "random": [4.1, 4.0, 4.2], "ga": [4.2, 4.1, 4.0]})
    assert campaign.omnibus(level, "search")[0]["p"] > 0.9
    assert campaign.omnibus(_finals({"glso": [4.0, 4.1]}), "search") == []  # one method: nothing to compare


def test_the_holm_floor_is_set_by_the_smallest_samples_not_by_the_family_size():
    # Floors 1/252, 1/252, 1/21, 1/21: at best Holm gives 4/252, 3/252, 2/21, 1/21 -> the largest is 2/21.
    finals = _finals({"glso": [5.0, 5.1, 5.2, 5.3, 5.4], "random": [4.0, 4.1], "ga": [4.0, 4.1],
                      "mcts": [4.0, 4.1, 4.2, 4.3, 4.4], "ghs": [4.0, 4.1, 4.2, 4.3, 4.4]})
    rows = compare(finals, "search", bootstrap=10, alpha=0.05)
    assert all(r["holm_floor"] == pytest.approx(2 / 21) for r in rows)
    assert max(r["p_holm"] for r in rows) == pytest.approx(2 / 21)  # reached: every GLSO run above every other


def test_the_rung_must_come_from_the_search_rule(tmp_path):
    choice = tmp_path / "evaluator_fidelity.json"
    choice.write_text(json.dumps({"rung": "s8_h8_e48", "rule": "provisional", "reason": "provisional: not measured"}))
    with pytest.raises(ValueError, match="not chosen by the search rule yet"):
        campaign.campaign_rung(CampaignConfig(), choice)
    choice.write_text(json.dumps({"rung": "s32_h8_e48", "rule": "search", "reason": "r"}))
    assert campaign.campaign_rung(CampaignConfig(), choice) == "s32_h8_e48"
    assert campaign.campaign_rung(CampaignConfig(rung="s16_h8_e48"), choice) == "s16_h8_e48"


def test_a_tiny_campaign_runs_resumes_rescores_measures_held_out_and_summarises(tmp_path, monkeypatch):
    """Random search and MCTS, 1 seed each, 3 calls at a tiny rung, re-scored at another tiny rung, their top
    designs measured at the held-out seeds at the runs' rung."""
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config = CampaignConfig(directory=str(tmp_path / "campaign"), checkpoints=str(tmp_path / "ckpt"),
                            cache=str(tmp_path / "cache.parquet"),
                            seeds={"random": 1, "mcts": 1}, budget=3, init=1, population=2,
                            rescore_rung="tiny_rescore", rescore_seeds=[7, 8], bootstrap=50)
    tables = campaign.run_campaign(config, GLSOConfig(), EvaluationConfig(), "tiny")
    assert [t.name for t in tables] == ["flat_random_seed0.parquet", "flat_mcts_seed0.parquet"]
    assert sorted(p.name for p in (tmp_path / "campaign").iterdir()) == [
        "campaign.json", "flat_mcts_seed0.parquet", "flat_random_seed0.parquet", "heldout.csv", "rescores.csv"]
    steps = campaign.read_runs(config)
    rescores = campaign.read_scores(config.directory, campaign.RESCORES_FILE).merge(
        campaign.top_designs(steps, 1)[[*campaign.RUN, "design_id"]])  # the search bests' (held-out bests' beside)
    assert len(rescores) == 4 and sorted(set(rescores["rescore_seed"])) == [7, 8]
    best = campaign.best_design(steps[steps["method"] == "random"])
    row = rescores[(rescores["method"] == "random") & (rescores["rescore_seed"] == 8)].iloc[0]
    again = evaluate(DesignTree(tuple(best["parents"]), tuple(best["tokens"])), "flat",
                     EvaluationConfig(mppi=fidelity.rung_config("tiny_rescore"), seed=8), 8)
    assert row["design_id"] == best["design_id"] and row["reward"] == pytest.approx(again["reward"], rel=1e-12)
    heldout = campaign.read_scores(config.directory, campaign.HELDOUT_FILE)
    top = campaign.top_designs(steps, 3)
    assert len(heldout) == 4 * len(top) and set(heldout["heldout_seed"]) == {201, 202, 203, 204}
    line = heldout.iloc[-1]  # at the runs' rung, with its held-out seed
    design = top[(top["method"] == line["method"]) & (top["design_id"] == line["design_id"])].iloc[0]
    again = evaluate(DesignTree(tuple(design["parents"]), tuple(design["tokens"])), "flat",
                     EvaluationConfig(mppi=fidelity.rung_config("tiny"), seed=204), 204)
    assert (line["rank"], line["heldout_seed"]) == (design["rank"], 204)
    assert line["reward"] == pytest.approx(again["reward"], rel=1e-12)

    def never(*args, **kwargs):
        raise AssertionError("a finished run or re-score ran again")

    monkeypatch.setattr(campaign, "run_search", never)
    monkeypatch.setattr(campaign, "evaluate", never)
    campaign.run_campaign(config, GLSOConfig(), EvaluationConfig(), "tiny")  # everything is there: nothing runs
    summary = campaign.summarise(config)
    assert summary["runs"] == summary["planned"] == 2 and summary["budget"] == 3 and summary["rung"] == "tiny"
    assert summary["heldout_progress"] == {"runs": 2, "complete": 2, "evaluations": len(heldout),
                                           "planned": len(heldout), "rescores_missing": 0}
    with pytest.raises(ValueError, match="campaign.json: the committed runs used rung tiny .* would use tiny_rescore"):
        campaign.run_campaign(config, GLSOConfig(), EvaluationConfig(), "tiny_rescore")
    with pytest.raises(ValueError, match="the committed runs used rung tiny"):  # same rung, other physics code
        monkeypatch.setattr(EvaluationConfig, "settings_hash", lambda self, task: "0" * 16)
        campaign.run_campaign(config, GLSOConfig(), EvaluationConfig(), "tiny")
    finals = pd.DataFrame(summary["finals"])
    assert (finals["search"] == steps.groupby("method")["best_so_far"].last().loc[finals["method"]].values).all()
    for final in finals.itertuples():  # the best design's id (not the last call's), and the run's spend
        run = steps[steps["method"] == final.method]
        assert final.design_id == campaign.best_design(run)["design_id"]
        assert (final.calls, final.distinct) == (3, int((~run["repeat"]).sum()))
    assert summary["k"] == {"flat": finals["distinct"].min()}
    assert np.allclose(finals.set_index("method").loc["random", "rescored"],
                       rescores[rescores["method"] == "random"]["reward"].mean())
    assert summary["tests"] == []  # no GLSO runs: nothing to compare
    path = campaign.plot(summary, tmp_path / "plot.png")
    assert path.stat().st_size > 0
    json.dumps({k: v for k, v in summary.items() if k != "curves"})  # the stage writes it as JSON


def test_a_rescore_recorded_twice_keeps_one_row_and_two_different_ones_are_an_error(tmp_path):
    """Two workers that re-scored one run at once wrote the same line twice; a different score is corruption."""
    row = {"task": "flat", "method": "ga", "seed": 2, "design_id": "abc", "rescore_seed": 101, "reward": 4.25,
           "status": "ok", "objective": 4.25}
    log = tmp_path / campaign.RESCORES_FILE
    for line in (row, {**row, "rescore_seed": 102}, row):
        fidelity.append_row(log, campaign.RESCORE_COLUMNS, line)
    scores = campaign.read_scores(tmp_path, campaign.RESCORES_FILE)
    assert list(scores["rescore_seed"]) == [101, 102] and list(scores["reward"]) == [4.25, 4.25]
    fidelity.append_row(log, campaign.RESCORE_COLUMNS, {**row, "reward": 4.5, "objective": 4.5})
    with pytest.raises(ArtifactError, match="rescores.csv: .*'rescore_seed': '101'.* different results .*reward "
                                            "'4.25' / '4.5'"):
        campaign.read_scores(tmp_path, campaign.RESCORES_FILE)


def test_runs_share_one_evaluation_cache_and_give_the_same_table_from_it(tmp_path, monkeypatch):
    """A design another run already simulated costs a call but no simulation; the table does not change."""
    import robocompose.evaluation.evaluate as evaluate_module

    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config = CampaignConfig(directory=str(tmp_path / "campaign"), checkpoints=str(tmp_path / "ckpt"),
                            cache=str(tmp_path / "cache.parquet"),
                            seeds={"random": 1}, budget=3, init=1, rescore_rung="tiny_rescore")
    (job,) = campaign.campaign_jobs(config, GLSOConfig(), EvaluationConfig(), "tiny")
    assert job.cache == str(tmp_path / "cache.parquet")
    first = Path(campaign.run_job(job)).read_bytes()
    assert not any(Path(job.checkpoint).parent.iterdir())  # a finished run leaves nothing in the committed folder
    Path(job.table).unlink()

    def never(*args, **kwargs):
        raise AssertionError("a cached design was simulated again")

    monkeypatch.setattr(evaluate_module, "run_job", never)
    assert Path(campaign.run_job(job)).read_bytes() == first


def test_a_missing_campaign_directory_is_an_error_not_zero_runs(tmp_path):
    with pytest.raises(InputError, match="nowhere: not a directory"):
        campaign.summarise(CampaignConfig(directory=str(tmp_path / "nowhere")))


def test_the_summary_of_no_runs_says_so(tmp_path):
    summary = campaign.summarise(CampaignConfig(directory=str(tmp_path)))
    # 5 seeds of GLSO, GA, MCTS, GHS and the thesis-protocol arm, 10 of random search and of the improved GLSO
    # (the pilot's pick), 3 of the two ablations
    assert summary["runs"] == 0 and summary["planned"] == 51


def test_the_top_designs_are_a_runs_best_distinct_simulated_designs_by_search_score_ties_by_first_call():
    steps = hand_steps({("glso", 0): [("a", 4.0), ("b", 4.5), ("b", 4.5), ("c", 4.5), ("d", 4.8), ("e", 3.0)],
                        ("random", 0): [("p", 3.0), ("p", 3.0)]})
    steps.loc[steps["design_id"] == "e", ["status", "score"]] = ["unstable", 4.9]  # its invalid score: no result
    top = campaign.top_designs(steps, 3)
    assert [(r.method, r.design_id, r.rank, r.step) for r in top.itertuples()] == [
        ("glso", "d", 1, 4), ("glso", "b", 2, 1), ("glso", "c", 3, 3), ("random", "p", 1, 0)]
    for method, run in steps.groupby("method"):  # rank 1 is the run's reported best
        assert top[(top["method"] == method) & (top["rank"] == 1)]["design_id"].item() == \
            campaign.best_design(run)["design_id"]


def _commit(tmp_path: Path, runs: dict, **settings) -> tuple[CampaignConfig, pd.DataFrame]:
    """A campaign directory of hand-made finished runs (`hand_steps`, at rung tiny as its manifest says), and its
    config with `settings`."""
    steps = hand_steps(runs)
    seeds = {m: 1 + max(s for method, s in runs if method == m) for m, _ in runs}
    config = CampaignConfig(directory=str(tmp_path / "campaign"), seeds=seeds, rescore_rung="tiny_rescore",
                            rescore_seeds=[7, 8], bootstrap=20, **settings)
    for spec in run_specs(config):
        run = steps[(steps["method"] == spec.method) & (steps["seed"] == spec.seed)]
        write_table(run, campaign.run_path(config, spec), "glso_steps")
    at_rung = EvaluationConfig(mppi=fidelity.rung_config("tiny"))
    claim_directory(config.directory, {"rung": "tiny", "settings_hash": {"flat": at_rung.settings_hash("flat")}})
    return config, steps


class StandIn:
    """`evaluate` standing in for the simulator: `reward(design id, controller seed)`, every call recorded as
    (design id, MPPI settings, seed); it raises (a kill) at call `kill`."""

    def __init__(self, steps: pd.DataFrame, reward, kill: int | None = None):
        self.designs, self.reward, self.kill, self.calls = tree_designs(steps), reward, kill, []

    def __call__(self, tree, task, config, seed):
        assert config.seed == seed
        if len(self.calls) == self.kill:
            raise KeyboardInterrupt
        design = self.designs[tree]
        self.calls.append((design, config.mppi, seed))
        return {"reward": self.reward(design, seed), "status": "ok", "sim_steps": 1, "seconds": 0.0}


# GLSO's search best `a` was lucky: its fresh seeds put it below `b`; random search's best stays its best
RUNS = {("glso", 0): [("a", 5.0), ("b", 4.9), ("a", 5.0), ("c", 4.8), ("d", 4.7)],
        ("random", 0): [("p", 4.5), ("q", 4.4)]}
HELD_OUT = {"a": 4.2, "b": 4.6, "c": 4.5, "d": 9.0, "p": 4.3, "q": 4.1, "e": 4.3, "f": 4.4, "r": 4.0}


def held_out(design: str, seed: int) -> float:
    return HELD_OUT[design] + (seed % 2) / 10  # seed-to-seed noise


def test_held_out_scores_use_only_held_out_seeds_at_the_runs_rung_and_the_thesis_setting_rescores_a_new_pick(
        tmp_path, monkeypatch):
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config, steps = _commit(tmp_path, RUNS)
    stand_in = StandIn(steps, held_out)
    monkeypatch.setattr(campaign, "evaluate", stand_in)
    assert campaign.rescore(config, campaign.top_designs(steps, 1)) == 4  # as `run` does: the search bests
    assert campaign.measure_heldout(config, EvaluationConfig(seed=0)) == {"heldout": 20, "rescores": 2}
    thesis, search = fidelity.rung_config("tiny_rescore"), fidelity.rung_config("tiny")
    held = [(design, seed) for design, mppi, seed in stand_in.calls[4:24]]
    assert all(mppi == search for _, mppi, _ in stand_in.calls[4:24])
    assert sorted(held) == sorted((d, s) for d in "abcpq" for s in config.heldout_seeds)  # top 3: not d
    assert not {seed for _, seed in held} & {0, *config.rescore_seeds}  # neither the search's seed nor a re-score's
    assert stand_in.calls[:4] + stand_in.calls[24:] == [("a", thesis, 7), ("a", thesis, 8), ("p", thesis, 7),
                                                        ("p", thesis, 8), ("b", thesis, 7), ("b", thesis, 8)]
    lines = campaign.read_scores(config.directory, campaign.HELDOUT_FILE)
    assert list(lines.columns) == list(campaign.HELDOUT_COLUMNS) and len(lines) == 20
    assert lines.set_index("design_id")["rank"].to_dict() == {"a": 1, "b": 2, "c": 3, "p": 1, "q": 2}
    final = campaign.summarise(config)["finals"]
    assert [(f["method"], f["design_id"], f["heldout_design"]) for f in final] == [("glso", "a", "b"),
                                                                                  ("random", "p", "p")]
    assert final[0]["heldout_rescored"] == pytest.approx(4.65) and final[0]["rescored"] == pytest.approx(4.25)


def test_a_held_out_seed_the_search_selected_with_is_refused_before_anything_is_measured(tmp_path, monkeypatch):
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config, steps = _commit(tmp_path, RUNS)
    stand_in = StandIn(steps, held_out)
    monkeypatch.setattr(campaign, "evaluate", stand_in)
    with pytest.raises(InputError, match=r"^glso_campaign.heldout_seeds: expected controller seeds other than "
                                         r"evaluation.seed = 203, the one the runs searched with, found "
                                         r"\[201, 202, 203, 204\]$"):
        campaign.measure_heldout(config, EvaluationConfig(seed=203))
    with pytest.raises(InputError, match="glso_campaign.heldout_seeds"):
        campaign.run_campaign(config, GLSOConfig(), EvaluationConfig(seed=201), "tiny")
    assert stand_in.calls == [] and not (tmp_path / "campaign" / campaign.HELDOUT_FILE).exists()


def test_a_killed_held_out_measurement_is_summarised_as_far_as_it_went_and_resumes_without_measuring_again(
        tmp_path, monkeypatch):
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config, steps = _commit(tmp_path, RUNS)
    monkeypatch.setattr(campaign, "evaluate", StandIn(steps, held_out, kill=13))
    with pytest.raises(KeyboardInterrupt):
        campaign.measure_heldout(config, EvaluationConfig())
    log = tmp_path / "campaign" / campaign.HELDOUT_FILE
    with open(log, "a") as f:
        f.write("flat,random,0,1,p,20")  # a line cut off by the kill mid-write
    first = campaign.read_scores(config.directory, campaign.HELDOUT_FILE)
    assert len(first) == 13  # GLSO's 12, the first of random search's

    def never(*args, **kwargs):
        raise AssertionError("the summary simulated")

    monkeypatch.setattr(campaign, "evaluate", never)
    summary = campaign.summarise(config)
    assert summary["heldout_progress"] == {"runs": 2, "complete": 1, "evaluations": 13, "planned": 20,
                                           "rescores_missing": 2}  # GLSO's new pick b, not yet re-scored
    finals = {f["method"]: f for f in summary["finals"]}
    assert finals["glso"]["heldout_design"] == "b" and math.isnan(finals["random"]["heldout"])
    assert [h["complete"] for h in summary["heldout"]] == [1, 0]

    stand_in = StandIn(steps, held_out)
    monkeypatch.setattr(campaign, "evaluate", stand_in)
    assert campaign.measure_heldout(config, EvaluationConfig()) == {"heldout": 7, "rescores": 4}  # b's, p's
    done = set(first[["design_id", "heldout_seed"]].itertuples(index=False, name=None))
    assert not done & {(design, seed) for design, _, seed in stand_in.calls}  # nothing measured twice
    assert len(campaign.read_scores(config.directory, campaign.HELDOUT_FILE)) == 20
    assert campaign.measure_heldout(config, EvaluationConfig()) == {"heldout": 0, "rescores": 0}


def test_the_held_out_best_is_the_highest_held_out_mean_not_the_highest_search_score_and_inflation_is_per_run():
    config = CampaignConfig(bootstrap=20)
    runs = {**RUNS, ("glso", 1): [("e", 4.6), ("f", 4.5)], ("random", 1): [("r", 4.0)]}
    steps = hand_steps(runs)
    top = campaign.top_designs(steps, config.heldout_top)
    heldout = pd.DataFrame([{"task": "flat", "method": r.method, "seed": r.seed, "rank": r.rank,
                             "design_id": r.design_id, "heldout_seed": s, "reward": held_out(r.design_id, s),
                             "status": "ok"} for r in top.itertuples() for s in config.heldout_seeds
                            if (r.design_id, s) != ("f", 204)])  # glso seed 1: one piece missing
    heldout.loc[(heldout["design_id"] == "q") & (heldout["heldout_seed"] == 202), "status"] = "unstable"
    heldout.loc[len(heldout)] = {**heldout.iloc[0], "heldout_seed": 999, "reward": 99.0}  # not a held-out seed
    rescores = pd.DataFrame([{"task": "flat", "method": "glso", "seed": 0, "design_id": d, "rescore_seed": s,
                              "reward": v + (s - 101) / 10, "status": "ok"} for d, v in (("a", 4.0), ("b", 5.0))
                             for s in (101, 102)])
    summary = campaign.statistics(steps, rescores, heldout, config)
    final = pd.DataFrame(summary["finals"]).set_index(["method", "seed"])
    assert final.loc[("glso", 0), ["design_id", "heldout_design", "heldout_rank"]].tolist() == ["a", "b", 2]
    assert final.loc[("glso", 0), ["search", "reported_heldout", "inflation", "heldout"]].tolist() == \
        pytest.approx([5.0, 4.25, 0.75, 4.65])
    assert final.loc[("glso", 0), "heldout_sd"] == pytest.approx(np.std([4.6, 4.7] * 2, ddof=1))
    assert final.loc[("glso", 0), ["rescored", "heldout_rescored"]].tolist() == pytest.approx([4.05, 5.05])
    # q was not simulated at one seed: no held-out mean, so p stays random search's pick
    assert final.loc[("random", 0), ["heldout_design", "inflation", "heldout"]].tolist() == ["p", pytest.approx(0.15),
                                                                                            pytest.approx(4.35)]
    assert not final.loc[("glso", 1), "heldout_complete"] and math.isnan(final.loc[("glso", 1), "heldout"])
    assert final.loc[("glso", 1), ["heldout_measured", "heldout_planned"]].tolist() == [7, 8]
    assert final.loc[("random", 1), "inflation"] == pytest.approx(4.0 - 4.05) and final["heldout_complete"].sum() == 3
    per_method = {h["method"]: h for h in summary["heldout"]}
    assert (per_method["glso"]["runs"], per_method["glso"]["complete"]) == (2, 1)
    assert per_method["random"]["inflation"] == pytest.approx(np.median([0.15, -0.05]))
    assert per_method["glso"]["seed_sd"] == pytest.approx(np.std([0, 1] * 2, ddof=1) / 10)  # every design's
    assert summary["heldout_progress"] == {"runs": 4, "complete": 3, "evaluations": 31, "planned": 32,
                                           "rescores_missing": 4}  # random search's two picks
    tests = [t for t in summary["tests"] if t["on"] == "heldout"]
    assert [(t["method"], t["n_reference"], t["n_other"]) for t in tests] == [("random", 1, 2)]
    assert tests[0]["median_difference"] == pytest.approx(4.65 - np.median([4.35, 4.05]))


def test_verify_records_todays_evaluator_only_if_it_rescores_the_committed_designs_bit_for_bit(tmp_path, monkeypatch):
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.setitem(fidelity.LADDER, "tiny_rescore", (2, 2, 2, 4))
    config, steps = _commit(tmp_path, RUNS)
    manifest = tmp_path / "campaign" / "campaign.json"
    today = json.loads(manifest.read_text())["settings_hash"]["flat"]
    manifest.write_text(json.dumps({"rung": "tiny", "settings_hash": {"flat": "0123456789abcdef"}}))  # older code
    committed = {r.design_id: r.reward for r in steps.itertuples()}
    with pytest.raises(InputError, match="campaign.json: the committed runs used rung tiny"):
        campaign.measure_heldout(config, EvaluationConfig())  # another settings hash: refused until verified

    monkeypatch.setattr(campaign, "evaluate", StandIn(steps, lambda d, s: committed[d] + (d == "p") * 1e-12))
    with pytest.raises(InputError, match=r"does not reproduce the committed runs \(flat_random_seed0 p: 4.5 then, "
                                         r"4.500000000001 now\)"):
        campaign.verify_evaluator(config, EvaluationConfig())
    assert "reproduced" not in json.loads(manifest.read_text())  # a near miss is no reproduction

    stand_in = StandIn(steps, lambda d, s: committed[d])
    monkeypatch.setattr(campaign, "evaluate", stand_in)
    assert campaign.verify_evaluator(config, EvaluationConfig()) == {"flat": ["a", "p"]}  # each method's first
    assert [(design, seed) for design, _, seed in stand_in.calls] == [("a", 0), ("p", 0)]  # at the search's seed
    recorded = json.loads(manifest.read_text())
    assert recorded["settings_hash"] == {"flat": "0123456789abcdef"} and recorded["reproduced"] == {"flat": {
        today: ["a", "p"]}}
    monkeypatch.setattr(campaign, "evaluate", StandIn(steps, held_out))
    assert campaign.measure_heldout(config, EvaluationConfig())["heldout"] == 20  # today's code now continues


def test_the_pilot_runs_glso_and_its_variants_as_the_campaign_does_and_ranks_them_by_held_out_best(
        tmp_path, monkeypatch, tiny_models):
    """The pilot is the campaign's machinery on GLSO and the registered methods searching its VAE, in its own
    folder at its own rung, held-out scored and never re-scored at the thesis setting."""
    config = CampaignConfig(directory=str(tmp_path / "measured" / "glso_campaign"),
                            checkpoints=str(tmp_path / "measured" / "glso_campaign_progress"),
                            cache=str(tmp_path / "data" / "cache.parquet"), budget=4, init=2, bootstrap=20)
    pilot = campaign.pilot_config(config)
    assert pilot.directory == str(tmp_path / "measured" / "glso_pilot") and pilot.rescore_seeds == []
    assert pilot.checkpoints == str(tmp_path / "measured" / "glso_campaign_progress" / "pilot")
    assert pilot.seeds == {"glso": 3, "glso_nodr": 3, "glso_floor": 3, "glso_reask": 3, "glso_turbo": 3}
    assert (pilot.rung, pilot.budget, pilot.init, pilot.heldout_seeds) == (
        "s8_h8_e48", 4, 2, config.heldout_seeds)
    assert campaign.pilot_summary(config) is None  # no pilot committed: the stage records none
    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    tiny = CampaignConfig(**{**pilot.__dict__, "seeds": {name: 1 for name in pilot.seeds}, "rung": "tiny"})
    campaign.run_campaign(tiny, GLSOConfig(models=tiny_models), EvaluationConfig(), "tiny")
    assert not (tmp_path / "measured" / "glso_pilot" / campaign.RESCORES_FILE).exists()
    summary = campaign.summarise(tiny)
    assert summary["heldout_progress"]["complete"] == len(pilot.seeds)
    table = campaign.pilot_table(summary, tiny.budget)
    assert sorted(table["method"]) == sorted(pilot.seeds) and (table["runs"] == 1).all()
    assert (table["reaches"] == (table["distinct"] >= campaign.DISTINCT_TARGET * 4 / 200)).all()
    for _, group in table.groupby("reaches"):  # the variants reaching the target first, each part by held-out best
        assert group["heldout"].is_monotonic_decreasing
    assert table["reaches"].is_monotonic_decreasing  # the pick is the first row
    assert (table["distinct"] <= 4).all() and (table["distinct"] >= 1).all()
    recorded = campaign.pilot_summary(config)  # what the stage records: the pilot's plan, its seed-0 runs so far
    assert (recorded["runs"], recorded["planned"], recorded["budget"]) == (len(pilot.seeds), 3 * len(pilot.seeds), 4)
    assert recorded["methods"] == table.to_dict("records")
