import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.evaluate import INVALID_SCORE, ROBOGRAMMAR_INVALID_SCORE, EvaluationConfig, objective
from robocompose.fanout.cache import EvaluationCache
from robocompose.glso import runs
from robocompose.glso.designs import self_colliding
from robocompose.glso.ghs import GHSConfig
from robocompose.glso.registry import METHODS
from robocompose.glso.runs import FRESH_SEEDS, GLSOConfig, Objective, RunSpec, call_seeds, run_search, summarise
from robocompose.grammar.tree import DesignTree
from robocompose.io import read_table
from robocompose.params import build_config
from tests.glso.conftest import fake_objective

EVALUATION = EvaluationConfig()
TINY = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2))


@pytest.mark.parametrize("method", METHODS)
def test_every_method_spends_exactly_the_budget_with_a_non_decreasing_best(method, small_config, tmp_path):
    steps = run_search(RunSpec("flat", method, 0), small_config, EVALUATION, objective_fn=fake_objective,
                       table=tmp_path / "steps.parquet")
    assert list(steps["step"]) == list(range(small_config.budget))
    ok = steps["status"] == "ok"
    best = steps["best_so_far"]
    assert best[~ok.cummax()].isna().all() and best[ok.cummax()].notna().all()  # NaN until the first simulated
    assert (np.diff(best.dropna()) >= 0).all() and best.iloc[-1] == steps.loc[ok, "reward"].max()
    invalid = METHODS[method].invalid_score
    assert list(steps["score"]) == [objective(fake_objective_row(r), invalid) for r in steps.itertuples()]
    assert (steps["rejected"] >= 0).all()
    first_seen = ~steps["design_id"].duplicated()
    assert list(steps["repeat"]) == list(~first_seen)
    on_disk = read_table(tmp_path / "steps.parquet", "glso_steps")
    assert list(on_disk["design_id"]) == list(steps["design_id"]) and list(on_disk["score"]) == list(steps["score"])


def fake_objective_row(row) -> dict:
    return fake_objective(DesignTree(tuple(row.parents), tuple(row.tokens)))


def test_latent_methods_record_their_latent_points_and_grammar_methods_their_rules(small_config):
    glso = run_search(RunSpec("flat", "glso", 0), small_config, EVALUATION, objective_fn=fake_objective)
    assert all(len(z) == 3 and max(abs(v) for v in z) <= 3.0 for z in glso["latent"])
    mcts = run_search(RunSpec("flat", "mcts", 0), small_config, EVALUATION, objective_fn=fake_objective)
    assert all(len(z) == 0 for z in mcts["latent"]) and all(len(r) > 0 for r in mcts["rules"])
    for row in mcts.itertuples():  # grammar methods redraw designs that cannot be simulated (pybullet's verdict)
        assert not self_colliding(DesignTree(tuple(row.parents), tuple(row.tokens)))


@pytest.mark.parametrize("method, score", [("random", ROBOGRAMMAR_INVALID_SCORE["self_collision"]),
                                           ("glso", INVALID_SCORE["self_collision"])])
def test_a_design_that_cannot_be_simulated_costs_a_call_and_scores_its_originals_invalid_score(
        method, score, small_config):
    steps = run_search(RunSpec("flat", method, 0), dataclasses.replace(small_config, budget=12), EVALUATION,
                       objective_fn=fake_objective)  # a quarter of the designs "self-collide"
    invalid = steps[steps["status"] == "self_collision"]
    assert len(steps) == 12 and len(invalid) > 0
    assert (invalid["score"] == score).all() and invalid["reward"].isna().all()
    assert steps["best_so_far"].max() == steps["reward"].max()  # an invalid score is never a best


def test_random_search_counts_the_candidates_its_filters_discard():
    """Random search draws the dataset's enumeration stream: the candidates between two proposals failed its
    filters (depth, links, self-penetration, rest contacts) and are the proposal's `rejected`."""
    from robocompose.dataset.enumerate import MIN_LINKS, candidate
    from robocompose.glso.designs import random_grammar_design

    proposal, k = random_grammar_design(7, 0)
    assert proposal.rejected == k - 1
    assert all(candidate(7, j, MIN_LINKS, 40)[0] for j in range(k - 1))  # each discarded one has a reason
    assert not candidate(7, k - 1, MIN_LINKS, 40)[0]
    after, k2 = random_grammar_design(7, k)
    assert after.rejected == k2 - 1 - k


def test_runs_are_reproducible_and_seeds_differ(small_config):
    a, b, c = (run_search(RunSpec("flat", "random", s), small_config, EVALUATION, objective_fn=fake_objective)
               for s in (0, 0, 1))
    assert a.equals(b)
    assert list(a["design_id"]) != list(c["design_id"])


def test_objective_goes_through_the_real_evaluator_and_its_cache(tmp_path):
    from robocompose.grammar.derivation import derive, parse_rules
    from tests.conftest import FLAT_REFERENCE

    evaluation = TINY
    cache = EvaluationCache(tmp_path / "cache.parquet")
    fn = Objective("flat", evaluation, cache)
    tree = derive(parse_rules(FLAT_REFERENCE)).tree
    row = fn(tree)
    assert row["status"] == "ok" and row["sim_steps"] > 0
    again = Objective("flat", evaluation, EvaluationCache(tmp_path / "cache.parquet"))  # saved to the file
    key = (tree.design_id, "flat", evaluation.settings_hash("flat"), 0)  # the key every stage has written
    assert (row["design_id"], row["task"], row["settings_hash"], row["seed"]) == key
    assert again.cache.get(key) == {k: row[k] for k in ("reward", "status", "sim_steps", "seconds")}
    assert again(tree) == row


def test_summary_takes_the_final_best_over_seeds():
    steps = pd.DataFrame({"task": ["flat"] * 4, "method": ["ga"] * 4, "seed": [0, 0, 1, 1], "step": [0, 1, 0, 1],
                          "best_so_far": [4.0, 4.5, 4.1, 4.2]})
    assert summarise(steps) == {"flat": {"ga": {"mean": 4.35, "min": 4.2, "max": 4.5, "seeds": 2, "budget": 2}}}


@pytest.mark.parametrize("values, message", [
    ({"methods": ["bogus"]}, "methods: expected some of"),
    ({"tasks": ["moon"]}, "moon"),
    ({"budget": 0}, r"budget: expected 1 \.\. 10000 objective calls"),
    ({"bo": {"xi": "big"}}, "glso.bo.xi"),
    ({"rung": "fast"}, r"glso.rung: expected \"\" \(the evaluator's evaluation.mppi\) or a fidelity rung of "
                       r"\['thesis', 's8_h8_e48', .*\], found 'fast'$"),
    ({"rung": "thesis_seed1"}, "glso.rung: .*found 'thesis_seed1'"),  # a repeat's seed offset would be lost
])
def test_bad_config_names_the_field(values, message):
    with pytest.raises((ValueError, KeyError), match=message):
        build_config(GLSOConfig, values, "glso")


def test_the_runs_evaluator_is_the_evaluation_section_at_glso_rung():
    from robocompose.evaluation.fidelity import rung_config

    evaluation = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2), seed=3)
    assert GLSOConfig().evaluator(evaluation) == evaluation  # rung "": the evaluator's own setting
    cheap = GLSOConfig(rung="s8_h8_e48").evaluator(evaluation)
    assert cheap == EvaluationConfig(mppi=rung_config("s8_h8_e48"), seed=3)  # the controller seed is kept
    assert cheap.settings_hash("flat") != evaluation.settings_hash("flat")


def test_the_stage_scores_and_replays_at_glso_rung_and_records_it(tiny_models, tmp_path, monkeypatch):
    """glso.rung set: every call and the best design's replay run at the rung's MPPI, not evaluation.mppi, and
    reports/metrics/glso.json (which the report reads) records the rung, its MPPI settings and its hash."""
    import json
    import runpy

    import yaml

    from robocompose.evaluation import fidelity
    from robocompose.evaluation.evaluate import evaluate
    from robocompose.io.provenance import ROOT
    from robocompose.params import merge, read_params
    from robocompose.report.glso import section

    monkeypatch.setitem(fidelity.LADDER, "tiny", (2, 2, 2, 3))
    monkeypatch.chdir(tmp_path)
    Path("params.yaml").write_text(yaml.safe_dump(merge(read_params(ROOT / "profiles" / "default.yaml"), {
        "compute": {"workers": 1, "cache": "data/cache.parquet"},
        "glso": {"tasks": ["flat"], "methods": ["random"], "seeds": [0], "budget": 2, "models": tiny_models,
                 "rung": "tiny"},
        "evaluation": {"mppi": {"samples": 2, "first_samples": 2, "horizon": 2, "episode": 2}}})))
    runpy.run_path(str(ROOT / "stages" / "glso.py"), run_name="__main__")
    at_rung = EvaluationConfig(mppi=fidelity.rung_config("tiny"))
    metrics = json.loads(Path("reports/metrics/glso.json").read_text())
    assert metrics["rung"] == "tiny" and metrics["mppi"] == at_rung.mppi.as_dict()
    assert metrics["settings_hash"] == {"flat": at_rung.settings_hash("flat")}
    cached = EvaluationCache("data/cache.parquet").frame()
    assert len(cached) > 0 and set(cached["settings_hash"]) == {at_rung.settings_hash("flat")}
    best = read_table("data/glso/steps.parquet", "glso_steps").sort_values("reward").iloc[-1]
    tree = DesignTree(tuple(best["parents"]), tuple(best["tokens"]))
    row = cached[cached["design_id"] == best["design_id"]].iloc[0]
    assert row["sim_steps"] == evaluate(tree, "flat", at_rung, 0)["sim_steps"] != evaluate(
        tree, "flat", TINY, 0)["sim_steps"]  # episodes of 3 control steps, not evaluation.mppi's 2
    assert "Every call scored at fidelity rung **tiny** (`glso.rung`: MPPI 2 samples, horizon 2, 3 control " \
           "steps), not the evaluator's `evaluation.mppi`." in section(Path("reports"), Path("data"))


def test_run_all_fans_the_runs_out_resumes_them_and_replays_each_tasks_best(tiny_models, tmp_path):
    from robocompose.fanout.executor import Executor
    from robocompose.glso.runs import record_best, run_all

    config = GLSOConfig(tasks=["flat"], methods=["random", "mcts"], seeds=[0], budget=2, models=tiny_models)
    evaluation, cache = TINY, str(tmp_path / "cache.parquet")
    with Executor(workers=2) as executor:
        steps, seconds = run_all(config, evaluation, tmp_path / "glso", executor, cache)
        assert sorted(steps.groupby(["method", "seed"]).size().items()) == [(("mcts", 0), 2), (("random", 0), 2)]
        assert set(steps["status"]) == {"ok"} and steps["reward"].notna().all()
        assert sorted(seconds) == ["flat_mcts_seed0", "flat_random_seed0"] and all(s > 0 for s in seconds.values())
        again, _ = run_all(config, evaluation, tmp_path / "glso", executor, cache)  # answered by the checkpoints
        assert again.equals(steps) and len(EvaluationCache(cache)) > 0
        best = record_best(steps, evaluation, tmp_path / "rollouts", executor)
    assert float(best["score"].iloc[0]) == steps["score"].max()
    assert (tmp_path / "rollouts" / "flat.mcap").stat().st_size > 0 and (tmp_path / "rollouts" / "flat.gif").exists()


def test_runs_on_a_dask_cluster_match_local_processes(tiny_models, tmp_path, dask_address):
    from robocompose.fanout.executor import Executor
    from robocompose.glso.runs import run_all

    config = GLSOConfig(tasks=["flat"], methods=["random", "ghs"], seeds=[0], budget=2, models=tiny_models,
                        ghs=GHSConfig(num_samples=2, opt_iter=2, eps_end=1.0))  # random rollouts: fast
    with Executor(workers=2) as executor:
        local, _ = run_all(config, TINY, tmp_path / "local", executor)
    with Executor(address=dask_address) as executor:
        remote, _ = run_all(config, TINY, tmp_path / "dask", executor)
    assert remote.equals(local)


def test_glso_warns_when_its_random_init_fills_the_budget(small_config):
    config = dataclasses.replace(small_config, budget=3)  # init 3: no BO step
    with pytest.warns(UserWarning, match="init 3 >= budget 3"):
        run_search(RunSpec("flat", "glso", 0), config, EVALUATION, objective_fn=fake_objective)


def test_the_thesis_protocol_simulates_every_call_at_a_controller_seed_of_its_own(small_config, monkeypatch,
                                                                                   tmp_path):
    """GLSO as its original runs: the same search, but each call at a fresh controller seed, so a repeat is
    simulated again (another key of the cache) and the best so far is a maximum over noisy re-draws; a resumed run
    continues the seeds where it stopped."""
    assert list(itertools.islice(call_seeds(RunSpec("flat", "glso", 2), EVALUATION), 3)) == [0, 0, 0]
    assert list(itertools.islice(call_seeds(RunSpec("flat", "glso_thesis", 2), EVALUATION, 5), 2)) == [
        FRESH_SEEDS + 20_005, FRESH_SEEDS + 20_006]
    simulated = []

    def noisy(jobs, cache=None, *args, **kwargs):  # the evaluator: a design's reward moves with the seed
        rows = []
        for job in jobs:
            simulated.append((job.tree.design_id, job.seed, job.config.seed))
            rows.append({"design_id": job.tree.design_id, "task": job.task, "settings_hash": "h", "seed": job.seed,
                         "reward": 4.0 + (job.seed % 7) / 100, "status": "ok", "sim_steps": 1, "seconds": 0.0})
        return rows

    monkeypatch.setattr(runs, "cached_evaluations", noisy)
    plain = run_search(RunSpec("flat", "glso", 0), small_config, EVALUATION)
    assert {seed for _, seed, _ in simulated} == {0} and plain.repeat.any()
    simulated.clear()
    thesis = run_search(RunSpec("flat", "glso_thesis", 0), small_config, EVALUATION)
    assert [seed for _, seed, _ in simulated] == list(range(FRESH_SEEDS, FRESH_SEEDS + small_config.budget))
    assert all(seed == config_seed for _, seed, config_seed in simulated)
    assert list(thesis.design_id[:3]) == list(plain.design_id[:3])  # the same random start, then its own scores
    assert thesis.best_so_far.iloc[-1] == thesis.reward.max()
    simulated.clear()
    stopped = {}

    def stop(row):
        if row["step"] == 4:
            stopped["at"] = row["step"]
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_search(RunSpec("flat", "glso_thesis", 0), small_config, EVALUATION, checkpoint=tmp_path / "run.ckpt",
                   on_step=stop)
    simulated.clear()
    resumed = run_search(RunSpec("flat", "glso_thesis", 0), small_config, EVALUATION, checkpoint=tmp_path / "run.ckpt")
    assert [seed for _, seed, _ in simulated] == list(range(FRESH_SEEDS + 5, FRESH_SEEDS + small_config.budget))
    assert resumed.equals(thesis)
