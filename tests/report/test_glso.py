import json
from pathlib import Path

import pandas as pd
import pytest
from PIL import Image

from robocompose.glso import best_so_far_curves
from robocompose.glso.registry import describe
from robocompose.io.errors import ArtifactError
from robocompose.report.glso import claims, section
from robocompose.report.verdicts import find
from tests.glso.conftest import hand_steps

METHODS = describe()  # the registry's record, as the stages write it into glso.json and glso_campaign.json


def _steps(best: dict[tuple[str, int], list[float]]) -> pd.DataFrame:
    rows = []
    for (method, seed), values in best.items():
        for step, v in enumerate(values):
            rows.append({"task": "flat", "method": method, "seed": seed, "step": step, "best_so_far": v})
    return pd.DataFrame(rows)


def test_curves_summarise_the_seeds_at_each_call_count():
    stats = best_so_far_curves(_steps({("glso", 0): [4.0, 4.5], ("glso", 1): [4.2, 4.3], ("glso", 2): [4.1, 4.9]}))
    last = stats[stats.calls == 2].iloc[0]
    assert (last["min"], last["max"], last["runs"]) == (4.3, 4.9, 3) and last["mean"] == pytest.approx(13.7 / 3)
    assert [last["median"], last["q25"], last["q75"]] == pytest.approx([4.5, 4.4, 4.7])


def test_smoke_claims_say_plainly_whether_the_means_agree_but_are_no_verdicts():
    final = _steps({("glso", 0): [4.5], ("random", 0): [4.6], ("glso_nopred", 0): [4.1], ("glso_nogram", 0): [4.0]})
    text = "\n".join(claims(final, ["flat"], METHODS))
    assert "GLSO best of Fig. 8.1 in these means: no" in text and "Random 4.600" in text
    assert "all ablations worse than GLSO in these means: yes" in text
    assert find(text) == []  # one seed of a smoke run: the report's verdict summary must not list it


def test_section_without_runs_says_which_stage_to_run(tmp_path):
    assert "stage `glso`" in section(tmp_path, tmp_path)


def test_section_draws_both_figures_the_table_and_the_best_design(tmp_path):
    from robocompose.evaluation.evaluate import EvaluationConfig
    from robocompose.glso.graph_ga import GAConfig
    from robocompose.glso.runs import GLSOConfig, RunSpec, run_search
    from robocompose.io import write_table
    from tests.glso.conftest import fake_objective

    config = GLSOConfig(tasks=["flat"], budget=4, ga=GAConfig(population=3))
    steps = pd.concat([run_search(RunSpec("flat", m, s), config, EvaluationConfig(), objective_fn=fake_objective)
                       for m in ("random", "mcts", "ga") for s in (0, 1)], ignore_index=True)
    write_table(steps, tmp_path / "data" / "glso" / "steps.parquet", "glso_steps")
    (tmp_path / "reports" / "metrics").mkdir(parents=True)
    metrics = tmp_path / "reports" / "metrics" / "glso.json"
    metrics.write_text(json.dumps({"methods": [m for m in METHODS if m["name"] != "mcts"]}))
    with pytest.raises(ArtifactError, match=r"glso\.json: no title for methods \['mcts'\]"):
        section(tmp_path / "reports", tmp_path / "data")  # never a method silently left out
    metrics.write_text(json.dumps({"methods": METHODS}))
    with pytest.raises(ArtifactError, match=r"glso\.json: no record of the MPPI setting its runs used"):
        section(tmp_path / "reports", tmp_path / "data")  # a record of older code: the stage reruns
    mppi = {"samples": 16, "first_samples": 64, "horizon": 16, "episode": 48}
    metrics.write_text(json.dumps({"methods": METHODS, "rung": "", "mppi": mppi}))
    text = section(tmp_path / "reports", tmp_path / "data")
    assert "Every call scored at the evaluator's setting, `evaluation.mppi` (MPPI 16 samples, horizon 16, 48 " \
           "control steps)." in text
    metrics.write_text(json.dumps({"methods": METHODS, "rung": "s8_h8_e48",
                                   "mppi": {**mppi, "samples": 8, "horizon": 8}}))
    text = section(tmp_path / "reports", tmp_path / "data")
    assert "Every call scored at fidelity rung **s8_h8_e48** (`glso.rung`: MPPI 8 samples, horizon 8, 48 control " \
           "steps), not the evaluator's `evaluation.mppi`." in text
    assert "flat rollout: not drawn yet" in text and "glso_best_flat.png" not in text
    rollouts = tmp_path / "data" / "glso" / "rollouts"
    rollouts.mkdir()
    Image.new("RGB", (8, 8), "red").save(rollouts / "flat.png")  # as the glso stage draws them
    Image.new("RGB", (8, 8)).save(rollouts / "flat.gif")
    text = section(tmp_path / "reports", tmp_path / "data")
    for figure in ("glso_fig8_1.png", "glso_fig8_2.png", "glso_best_flat.png", "glso_rollout_flat.gif"):
        assert (tmp_path / "reports" / "figures" / figure).stat().st_size > 0 and figure in text
    picture = tmp_path / "reports" / "figures" / "glso_best_flat.png"
    assert picture.read_bytes() == (rollouts / "flat.png").read_bytes()  # the stage's picture, copied
    assert "budget of **4 objective calls**" in text and "| MCTS |" in text and "(n=2)" in text
    discarded = steps.groupby("method")["rejected"].mean()
    assert f"| Random | 0% | {(steps[steps.method == 'random'].status != 'ok').mean():.0%} | " \
           f"{discarded['random']:.1f} |" in text and "The accounting rule, one for every method" in text


def _campaign(reports: Path, finals: dict[str, list[float]], planned: int, inflation: dict[str, float] | None = None,
              **recorded) -> None:
    """reports/metrics/glso_campaign.json as the stage writes it, of runs with these final bests (method -> one
    per seed), each re-scored at its final best: GLSO sends one design four times, every other method four
    designs, 1.0 below its final best first, its final best last. With `inflation` (method -> how far its
    designs' held-out means lie below their search scores), every run's top designs measured at the held-out
    seeds but for GLSO's last run (its last seed missing)."""
    from robocompose.glso import campaign

    config = campaign.CampaignConfig(bootstrap=100)
    runs = {(m, i): [("g", v)] * 4 if m == "glso" else [(f"{m}{i}{j}", v - 1.0 + j / 3) for j in range(4)]
            for m, vs in finals.items() for i, v in enumerate(vs)}
    rescores = pd.DataFrame([{"task": "flat", "method": m, "seed": i, "design_id": calls[-1][0], "rescore_seed": s,
                              "reward": calls[-1][1], "status": "ok"} for (m, i), calls in runs.items()
                             for s in config.rescore_seeds])
    steps = hand_steps(runs)
    top = campaign.top_designs(steps, config.heldout_top)
    last = len(finals["glso"]) - 1
    heldout = pd.DataFrame([
        {"task": "flat", "method": r.method, "seed": r.seed, "rank": r.rank, "design_id": r.design_id,
         "heldout_seed": s, "reward": r.score - inflation[r.method] + (s % 2) / 100, "status": "ok"}
        for r in top.itertuples() for s in config.heldout_seeds if (r.method, r.seed, s) != ("glso", last, 204)]
        if inflation else [], columns=list(campaign.HELDOUT_COLUMNS))
    summary = campaign.statistics(steps, rescores, heldout, config)
    (reports / "metrics").mkdir(exist_ok=True)
    (reports / "metrics" / "glso_campaign.json").write_text(json.dumps(
        {k: v for k, v in summary.items() if k != "curves"} | {"planned": planned, **recorded}))


FINALS = {"glso": [5.0, 5.1, 5.2, 5.3, 5.4], "random": [4.0, 4.1, 4.2, 4.3, 4.4], "ga": [4.0, 4.1, 4.2, 4.3, 4.4],
          "mcts": [4.9, 5.5, 5.0, 5.6, 5.05], "ghs": [4.0, 4.1, 4.2, 4.3, 4.4], "glso_nopred": [4.0, 4.1, 4.2],
          "glso_nogram": [4.0, 4.1, 4.2]}


def test_the_campaign_section_leads_with_distinct_designs_and_gives_verdicts_only_from_the_corrected_tests(tmp_path):
    from robocompose.report.glso import campaign_section

    assert "Not run yet" in campaign_section(tmp_path)
    (tmp_path / "metrics").mkdir()
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps({"runs": 0, "planned": 31}))
    assert "0 of 31 planned" in campaign_section(tmp_path)
    finals = FINALS
    _campaign(tmp_path, finals, planned=40)
    text = campaign_section(tmp_path)
    assert "31 of 40 planned runs committed, 4 objective calls each; each" in text
    assert "The campaign is partial: every number and verdict below is interim" in text
    distinct, calls = text.index("#### Per distinct design (primary)"), text.index("#### Per objective call")
    assert distinct < calls and "every run at K distinct designs (flat: K = 1)" in text
    # Per distinct design: GLSO's one design against each method's first, 1.0 below its final best
    assert "| GLSO | flat | 1 [1, 1] | 1 | 1 | 5.200 [5.100, 5.300] (n=5) |" in text
    assert "| MCTS | flat | 4 [4, 4] | 1 | 1 | 4.050 [4.000, 4.500] (n=5) |" in text
    assert "| flat | best so far at K distinct designs | MCTS | 5 / 5 | 1 / 1 calls, 1 / 1 distinct |" in text
    verdicts_k = text[distinct:calls]
    assert "GLSO best of Fig. 8.1: **holds** (Random p = " in verdicts_k
    assert "all ablations worse than GLSO (Fig. 8.2): **holds**" in verdicts_k
    # Per call: the final bests, where MCTS is not beaten
    assert "| GLSO | flat | 4 | 1 | 5.200 [5.100, 5.300] (n=5) | 5.200 [5.100, 5.300] (n=5) |" in text
    assert "| flat | final best, re-scored | MCTS | 5 / 5 | 4 / 4 calls, 1 / 4 distinct |" in text
    verdicts_calls = text[text.index("Verdicts (re-scored finals, 4 calls):"):]
    assert "GLSO best of Fig. 8.1: **not shown**" in verdicts_calls
    assert "all ablations worse than GLSO (Fig. 8.2): **holds**" in verdicts_calls
    assert "cannot show it" not in text  # 5 vs 5 and 5 vs 3 seeds can reach significance
    # Random's row is the dataset's filtered enumeration: its null, with the share of too-small discards
    assert "Random: the dataset's own enumeration, its filters included (>= 11 links, valid rest contacts)" in text
    (tmp_path / "metrics" / "enumerate.json").write_text(json.dumps({"grammar": {"rejected": {
        "too_few_links": 75, "self_collision": 20, "depth_limit": 5}}}))
    assert "rest contacts; 75% of the enumeration's discarded candidates have fewer than 11 links)" in \
        campaign_section(tmp_path)
    # Beside the pairwise tests, whether the five methods of Fig. 8.1 are distinguishable at all
    assert "Kruskal-Wallis over GLSO, Random, GA, MCTS, GHS (best so far at K distinct designs, flat; runs " \
           "5/5/5/5/5): H = " in verdicts_k

    _campaign(tmp_path, {m: v for m, v in finals.items() if m != "glso_nogram"}, planned=40)
    assert "GLSO_nopred p = 0.018) (no runs yet of GLSO_nogram)" in campaign_section(tmp_path)
    _campaign(tmp_path, finals | {"glso": finals["glso"][:3]}, planned=40)  # 3 vs 3 floors at 0.05, Holm at 0.1
    assert "(with these seed counts the family's largest Holm-adjusted p is at least 0.100, not below 0.05: " \
           "this campaign cannot show it)" in campaign_section(tmp_path)
    _campaign(tmp_path, {"glso": finals["glso"]}, planned=5, rung="s16_h16_e48")
    text = campaign_section(tmp_path)
    assert "4 objective calls each at rung s16_h16_e48 (the fidelity search rule's)" in text
    assert "partial" not in text and "Only GLSO has runs yet: nothing to compare." in text


def test_the_campaign_section_judges_under_held_out_scoring_from_its_tests_and_says_what_is_missing(tmp_path):
    from robocompose.report.glso import campaign_section

    _campaign(tmp_path, FINALS, planned=31)  # nothing measured yet: GLSO's 5 runs x 1 design, 26 others' x 3
    held = campaign_section(tmp_path).split("#### Under held-out scoring")[1]
    assert "0 of 31 runs have their held-out pieces complete (0 of 332 held-out evaluations measured); missing: " \
           "332 of the held-out evaluations" in held and "`robocompose glso-campaign heldout" in held
    assert "| GLSO | flat | 0 / 5 | - | - | - | - | - | - |" in held
    assert "No verdict under held-out scoring yet" in held and "under held-out scoring: GLSO" not in held

    # MCTS's search bests beat GLSO's, but they were lucky: 1.0 above their fresh seeds, GLSO's 0.1
    _campaign(tmp_path, FINALS, planned=31, inflation={m: 0.1 if m == "glso" else 1.0 for m in FINALS})
    text = campaign_section(tmp_path)
    held = text.split("#### Under held-out scoring")[1]
    assert "30 of 31 runs have their held-out pieces complete (331 of 332 held-out evaluations measured); " \
           "missing: 1 of the held-out evaluations, 0 thesis re-scores" in held and "interim" in held
    assert "| GLSO | flat | 4 / 5 | 5.150 [5.075, 5.225] (n=4) | 5.055 [4.980, 5.130] (n=4) | +0.095 | 0.006 | " \
           "5.055 [4.980, 5.130] (n=4) | 5.150 [5.075, 5.225] (n=4) |" in held
    assert "| MCTS | flat | 5 / 5 | 5.050 [5.000, 5.500] (n=5) | 4.055 [4.005, 4.505] (n=5) | +0.995 | 0.006 |" in held
    assert "| flat | held-out best | MCTS | 4 / 5 |" in held
    assert "- flat, under held-out scoring: GLSO best of Fig. 8.1: **holds** (Random p = 0.032; GA p = 0.032; " \
           "MCTS p = 0.032; GHS p = 0.032)." in held
    assert "- flat, under held-out scoring: all ablations worse than GLSO (Fig. 8.2): **not shown**" in held
    assert "- flat, re-scored at the thesis setting: GLSO best of Fig. 8.1: **not shown**" in text  # per call

    summary = json.loads((tmp_path / "metrics" / "glso_campaign.json").read_text())
    del summary["heldout_progress"]  # a record of older code: the stage reruns
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps(summary))
    with pytest.raises(ArtifactError, match=r"glso_campaign\.json: no record of the held-out scoring"):
        campaign_section(tmp_path)

    summary["heldout_progress"] = {}
    for method in summary["methods"]:
        del method["families"]  # the record older code wrote: the report does not guess a method's family
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps(summary))
    with pytest.raises(ArtifactError, match=r"glso_campaign\.json: no record of each method's comparison families"):
        campaign_section(tmp_path)


def test_the_thesis_protocol_arm_gets_its_own_verdicts_naming_each_protocol(tmp_path):
    """The arm's search bests beat every baseline's, but they are maxima over lucky draws (2.0 above their
    designs' fresh seeds): "best" appears under the thesis's protocol and disappears under held-out scoring."""
    from robocompose.report.glso import campaign_section

    finals = FINALS | {"glso_thesis": [6.0, 6.1, 6.2, 6.3, 6.4]}
    _campaign(tmp_path, finals, planned=36, inflation={m: 2.0 if m == "glso_thesis" else 0.1 for m in finals},
              methods=METHODS)
    text = campaign_section(tmp_path)
    arm = text.split("##### GLSO, thesis protocol")[1]
    assert "| flat | final best at the search rung | Random | 5 / 5 | 4 / 4 calls, 4 / 4 distinct |" in arm
    assert ("- flat, under the thesis's protocol (a fresh controller seed per call: its reported best): GLSO, thesis "
            "protocol best of Fig. 8.1: **holds** (Random p = 0.016; GA p = 0.016; MCTS p = 0.016; GHS p = 0.016).") \
        in arm
    assert "- flat, under held-out scoring: GLSO, thesis protocol best of Fig. 8.1: **not shown**" in arm
    assert "all ablations worse" not in arm  # the ablations are GLSO's family, not the arm's
    assert text.index("#### Under held-out scoring") < text.index("#### GLSO's arms against the baselines")


def test_the_pilot_names_its_winner_among_the_variants_reaching_150_distinct_designs_by_held_out_best(tmp_path):
    from robocompose.report.glso import campaign_section

    _campaign(tmp_path, FINALS, planned=31)
    assert "Not run yet (`robocompose glso-campaign pilot`" in campaign_section(tmp_path)
    summary = json.loads((tmp_path / "metrics" / "glso_campaign.json").read_text())
    summary["pilot"] = {"directory": "measured/glso_pilot", "rung": "s8_h8_e48", "budget": 200,
                        "distinct_target": 150, "runs": 5, "planned": 6, "heldout_progress": {"complete": 4},
                        "methods": [
                            {"method": "glso_nodr", "runs": 3, "distinct": 160.0, "search": 4.5,
                             "reported_heldout": 4.4, "heldout": 4.45, "reaches": True},
                            {"method": "glso", "runs": 2, "distinct": 150.0, "search": 4.6,
                             "reported_heldout": float("nan"), "heldout": float("nan"), "reaches": True}]}
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps(summary))
    pilot = campaign_section(tmp_path).split("#### The pilot")[1]
    assert "5 of 6 pilot runs committed (measured/glso_pilot), 200 objective calls each at rung s8_h8_e48" in pilot
    assert "| GLSO, no domain reduction | 3 | 160 | 4.500 | 4.400 | 4.450 |" in pilot
    assert "| GLSO | 2 | 150 | 4.600 | - | - |" in pilot  # no held-out mean yet: no number made up
    assert ("Winner: **GLSO, no domain reduction** (160 distinct designs, held-out best 4.450); variants reaching "
            "150 distinct designs per 200 calls: GLSO, no domain reduction; GLSO. Interim") in pilot
    for row in summary["pilot"]["methods"]:  # the pilot's own order put a variant short of the target first
        row["reaches"] = False
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps(summary))
    assert ("Winner: **GLSO, no domain reduction** (160 distinct designs, held-out best 4.450); it does not reach "
            "the target, and no variant does; variants reaching 150 distinct designs per 200 calls: none.") in (
        campaign_section(tmp_path))
    summary["pilot"]["methods"][0]["heldout"] = float("nan")  # runs finished, none held-out scored yet
    (tmp_path / "metrics" / "glso_campaign.json").write_text(json.dumps(summary))
    assert "No winner yet: no variant has held-out scores" in campaign_section(tmp_path)
