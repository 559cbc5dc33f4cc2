"""The trust-region latent BO (glso_turbo, TuRBO-1 with BoTorch): its settings, its box, its determinism and replay,
and the trust region's doubling, halving and restart."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from torch.quasirandom import SobolEngine

from robocompose.evaluation.evaluate import INVALID_SCORE, EvaluationConfig
from robocompose.glso import campaign
from robocompose.glso import turbo as turbo_module
from robocompose.glso.campaign import CampaignConfig
from robocompose.glso.method import SearchEnv
from robocompose.glso.registry import METHODS
from robocompose.glso.runs import GLSOConfig, RunSpec, make_method, replay, run_search
from robocompose.glso.turbo import SOBOL, TRUST_REGION, TrustRegionBO, TurboConfig
from robocompose.grammar.tree import DesignTree
from robocompose.io.errors import InputError
from robocompose.latent.train import load_model
from tests.glso.conftest import fake_objective

LATENT_2 = SearchEnv("flat", SimpleNamespace(config=SimpleNamespace(latent=2)))  # the method reads only the size
FEW = 256  # Thompson sampling's candidates in these 2-D tests (a tenth of a step's time at the default 2000)


pytestmark = pytest.mark.usefixtures("one_torch_thread")  # tests/conftest.py


@pytest.fixture
def grid(monkeypatch):
    """A decoder that maps the 2-D latent box [-3, 3]^2 onto a 6 x 6 grid of one-link designs."""
    def cell(z: np.ndarray) -> int:
        i, j = np.clip((z + 3.0).astype(int), 0, 5)
        return int(6 * i + j)

    monkeypatch.setattr(turbo_module, "decode", lambda model, z: DesignTree((-1,), (cell(z),)))


OPTIMUM = np.array([1.0, -0.5])


def bowl(z: np.ndarray) -> float:
    return float(-np.sum((z - OPTIMUM) ** 2))


def drive(method: TrustRegionBO, steps: int, score=bowl) -> list:
    """`steps` proposals, each told `score(z)`: (design id, z, kind) of each."""
    sent = []
    for _ in range(steps):
        proposal = method.propose(LATENT_2)
        sent.append((proposal.tree.design_id, proposal.z, proposal.info[0]))
        method.tell(proposal, score(proposal.z))
    return sent


@pytest.mark.parametrize(("bad", "field"), [
    ({"bound": 0.0}, "bound"), ({"init": 0}, "init"), ({"length_init": 2.0}, "length_init"),
    ({"length_min": 0.0}, "length_init"), ({"length_min": 0.9}, "length_init"),
    ({"success_tolerance": 0}, "success_tolerance"), ({"failure_tolerance": -1}, "failure_tolerance"),
    ({"candidates": -5}, "candidates")])
def test_a_bad_setting_names_its_field(bad, field):
    with pytest.raises(InputError, match=rf"^{field}: expected "):
        TurboConfig(**bad)


def test_the_tolerance_and_candidates_default_to_the_tutorials_for_batch_1():
    def sized(latent: int, **settings) -> TrustRegionBO:
        env = SearchEnv("flat", SimpleNamespace(config=SimpleNamespace(latent=latent)))
        return TrustRegionBO(TurboConfig(init=2, **settings), seed=0, budget=4, env=env)

    assert (sized(2).failure_tolerance, sized(28).failure_tolerance) == (4, 28)  # ceil(max(4, dim))
    assert (sized(2, failure_tolerance=7).failure_tolerance, sized(28).candidates) == (7, 2000)
    assert (sized(2, candidates=0).candidates, sized(28, candidates=0).candidates) == (2000, 5000)


def test_it_starts_with_the_seeded_sobol_points_and_proposes_inside_the_box(grid):
    method = TrustRegionBO(TurboConfig(init=4, bound=2.0, candidates=FEW), seed=3, budget=12, env=LATENT_2)
    sent = drive(method, 12)
    assert [kind for _, _, kind in sent] == [SOBOL] * 4 + [TRUST_REGION] * 8
    sobol = SobolEngine(2, scramble=True, seed=3).draw(4, dtype=torch.float64).numpy()
    np.testing.assert_array_equal(np.array([z for _, z, _ in sent[:4]]), (sobol * 2 - 1) * 2.0)
    assert all(np.all(np.abs(z) <= 2.0) for _, z, _ in sent)


def test_it_gets_closer_to_the_optimum_than_its_initial_points(monkeypatch):
    monkeypatch.setattr(turbo_module, "decode", lambda model, z: DesignTree((-1,), (0,)))  # scored by z alone
    sent = drive(TrustRegionBO(TurboConfig(init=5, candidates=FEW), seed=0, budget=25, env=LATENT_2), 25)
    distances = [float(np.linalg.norm(z - OPTIMUM)) for _, z, _ in sent]
    assert min(distances[5:]) < min(distances[:5]) and min(distances[5:]) < 0.3


def test_it_is_deterministic_given_the_seed_and_what_it_was_told_whatever_the_global_generators(grid):
    def run(seed: int, global_seed: int) -> list:
        torch.manual_seed(global_seed)
        np.random.seed(global_seed)
        return drive(TrustRegionBO(TurboConfig(init=3, candidates=FEW), seed=seed, budget=10, env=LATENT_2), 10)

    first, again, other = run(0, 1), run(0, 2), run(1, 1)
    assert [d for d, _, _ in first] == [d for d, _, _ in again]
    assert all(np.array_equal(a, b) for (_, a, _), (_, b, _) in zip(first, again, strict=True))
    assert [d for d, _, _ in first] != [d for d, _, _ in other]
    method = TrustRegionBO(TurboConfig(init=1, candidates=FEW), seed=0, budget=3, env=LATENT_2)
    drive(method, 1)
    state = torch.get_rng_state()
    drive(method, 2)  # two BO steps: GP fits and Thompson draws
    assert torch.equal(torch.get_rng_state(), state)  # the global generator is left as it was


def test_a_run_resumes_by_replay_to_the_same_designs_and_latent_points(small_config, tmp_path):
    spec, checkpoint = RunSpec("flat", "glso_turbo", 0), tmp_path / "run.ckpt"
    whole = run_search(spec, small_config, EvaluationConfig(), objective_fn=fake_objective, checkpoint=checkpoint)
    rows = json.loads(checkpoint.read_bytes().split(b"\n", 1)[1])
    env = SearchEnv("flat", load_model(small_config.model_path("glso_turbo")))
    method = make_method(spec, small_config, env)
    replay(method, rows[:6], env, small_config.budget)  # 3 Sobol points, 3 BO steps
    for row in rows[6:]:
        proposal = method.propose(env)
        assert proposal.tree.design_id == row["design_id"] and proposal.z.tolist() == row["latent"]
        method.tell(proposal, row["score"])
    assert list(whole["design_id"]) == [row["design_id"] for row in rows]


def test_the_region_doubles_after_successes_halves_after_failures_and_restarts_below_its_minimum(grid):
    config = TurboConfig(init=2, length_init=0.4, length_min=0.1, length_max=0.8, success_tolerance=2,
                         failure_tolerance=2, candidates=FEW)
    method = TrustRegionBO(config, seed=0, budget=30, env=LATENT_2)
    scores = iter([0.0, 1.0,  # the Sobol points: best 1
                   1.0005,  # not better by 1e-3 |best|: a failure
                   2.0, 3.0,  # two successes (the failure count starts over): 0.4 -> 0.8
                   4.0, 5.0,  # two more: at length_max already
                   5.0, 5.0,  # two failures: 0.8 -> 0.4
                   5.0, 5.0, 5.0, 5.0,  # 0.4 -> 0.2 -> 0.1 (not below length_min)
                   4.0, 4.0,  # 0.1 -> 0.05 < length_min: a restart
                   -7.0,  # the restart's Sobol point: the new region's best
                   -6.0])  # better than the restart's best (not the run's): a success
    lengths = []
    for _ in range(17):
        proposal = method.propose(LATENT_2)
        method.tell(proposal, next(scores))
        lengths.append((proposal.info[0], method.region.length, method.region.successes, method.region.failures))
    assert [length for _, length, _, _ in lengths] == [0.4, 0.4, 0.4, 0.4, 0.8, 0.8, 0.8, 0.8, 0.4, 0.4, 0.2, 0.2,
                                                        0.1, 0.1, 0.4, 0.4, 0.4]
    assert lengths[2][2:] == (0, 1) and lengths[3][2:] == (1, 0) and lengths[5][2:] == (1, 0)
    assert method.restarts == 1 and lengths[14][0] == TRUST_REGION and lengths[15][0] == SOBOL
    # the restart's point is the run's next Sobol point; its score, not the run's best 5, is the bar to beat
    assert torch.equal(method.x[15], SobolEngine(2, scramble=True, seed=0).draw(3, dtype=torch.float64)[2])
    assert method.region.best == -6.0 and lengths[16][2:] == (1, 0) and method.restart_start == 15


def test_the_registry_entry_resolves_and_the_campaign_sets_its_init():
    entry = METHODS["glso_turbo"]
    assert (entry.cls, entry.settings, entry.section, entry.variant, entry.groups) == (
        TrustRegionBO, TurboConfig, "bo_turbo", "full", ())
    assert entry.invalid_score == INVALID_SCORE and not entry.fresh_seeds
    profile = GLSOConfig(bo_turbo={"init": 6, "candidates": 500})
    assert profile.settings("glso_turbo") == TurboConfig(init=6, candidates=500)
    runs = campaign.search_config(CampaignConfig(budget=200, init=50), profile)
    assert runs.bo_turbo == TurboConfig(init=50, candidates=500)  # the campaign's init, the rest the profile's
    assert runs.bo.init == runs.bo_reask.init == 50
