import numpy as np
import pytest
from bayes_opt import BayesianOptimization, acquisition

from robocompose.glso import bo as bo_module
from robocompose.glso.bo import (
    BOConfig,
    ExpectedImprovement,
    LatentBO,
    NoReductionConfig,
    ReaskConfig,
    WideFloorConfig,
    decode,
)
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.grammar.tree import DesignTree
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import load_model

LATENT_2 = SearchEnv("flat", GraphVAE(VAEConfig(hidden=8, latent=2, max_nodes=20)))  # BO sizes itself by the VAE


def _drive(bo: LatentBO, steps: int) -> list[np.ndarray]:
    points = []
    for _ in range(steps):
        params = bo.optimizer.random_sample(1)[0] if bo.is_random_step() else bo.optimizer.suggest()
        z = np.array([params[k] for k in bo.keys])
        points.append(z)
        bo.tell(Proposal(None, None, z=z), float(-np.sum((z - 1.0) ** 2)))  # best at z = (1, 1)
    return points


def test_random_steps_are_the_initial_points_and_every_tenth_step_after():
    bo = LatentBO(BOConfig(init=5, random_every=10), seed=0, budget=40, env=LATENT_2)
    schedule = []
    for step in range(30):
        bo.step = step
        schedule.append(bo.is_random_step())
    assert [s for s, r in enumerate(schedule) if r] == [0, 1, 2, 3, 4, 14, 24]


def test_domain_reduction_shrinks_the_bounds_after_the_initial_points_only():
    bo = LatentBO(BOConfig(init=4), seed=0, budget=12, env=LATENT_2)
    _drive(bo, 4)
    assert np.allclose(bo.optimizer.space.bounds, [[-3, 3], [-3, 3]])
    points = _drive(bo, 6)
    bounds = bo.optimizer.space.bounds
    assert (bounds[:, 1] - bounds[:, 0] < 6).all()
    assert np.all(np.abs(points[-1]) <= 3)


def test_bo_on_a_smooth_bowl_gets_closer_to_the_optimum_than_random_sampling_of_the_same_budget():
    bo = LatentBO(BOConfig(init=5, random_every=0), seed=1, budget=16, env=LATENT_2)
    points = _drive(bo, 16)
    bo_error = min(np.linalg.norm(z - 1.0) for z in points)
    random = np.random.default_rng(1).uniform(-3, 3, (16, 2))
    assert bo_error < 0.25 < min(np.linalg.norm(random - 1.0, axis=1))
    # domain reduction re-centres on the best point: the current window holds it and is narrower than [-3, 3]
    best = points[int(np.argmax(bo.optimizer.space.target))]
    bounds = bo.optimizer.space.bounds
    assert ((bounds[:, 0] <= best) & (best <= bounds[:, 1])).all() and (bounds[:, 1] - bounds[:, 0] < 3).all()


@pytest.mark.parametrize(("dim", "objective", "window"), [
    (3, lambda x: float(-np.sum((x - 1) ** 2) + np.sin(3 * x).sum()), (-3.0, 3.0)),
    (8, lambda x: float(-np.sum((x - 1) ** 2) + np.sin(3 * x).sum()), (-3.0, 3.0)),
    (4, lambda x: float(np.sum(x)), (-1.0, 0.5)),  # the maximiser lies on the upper bounds: steps turn back
])
def test_batched_expected_improvement_picks_what_stock_bayes_opt_picks_on_the_same_gp(dim, objective, window):
    rng = np.random.default_rng(dim)
    keys = [f"z{i}" for i in range(dim)]
    optimizer = BayesianOptimization(f=None, pbounds={k: (-3, 3) for k in keys}, random_state=0, verbose=0)
    optimizer.set_gp_params(alpha=1e-3)
    for x in np.vstack([rng.uniform(-3, 3, (10, dim)), rng.uniform(*window, (5, dim))]):  # 5 inside the window
        optimizer.register(dict(zip(keys, x, strict=True)), objective(x))
    optimizer.set_bounds({k: window for k in keys})
    gp, space = optimizer._gp, optimizer.space
    stock = acquisition.ExpectedImprovement(xi=0.01)
    stock._fit_gp(gp, space)  # one GP for both; the same seed gives both the same 10,000 random candidates
    expected = stock.suggest(gp, space, fit_gp=False, random_state=7)
    batched = ExpectedImprovement(xi=0.01).suggest(gp, space, fit_gp=False, random_state=7)
    np.testing.assert_allclose(batched, expected, atol=1e-4)
    acq = stock._get_acq(gp)  # the negated EI of the same incumbent
    assert float(acq(batched)[0]) == pytest.approx(float(acq(expected)[0]), rel=1e-7, abs=1e-12)


def test_decoding_is_greedy_and_deterministic(tiny_models):
    model = load_model(tiny_models.format(variant="full"))
    z = np.array([0.5, -1.0, 2.0])
    assert decode(model, z) == decode(model, z)



def test_reasking_sends_no_repeat_of_a_bo_step_until_its_bound_then_a_random_point(monkeypatch):
    """A decoder that maps the 2-D latent box onto a 4 x 4 grid of designs: plain GLSO's suggestions land on
    designs it has scored; the re-asking variant registers such a suggestion at its known score for free and asks
    again, `reask` times at most (the proposal's `rejected`), then spends the call on a random point."""
    def cell(z: np.ndarray) -> int:
        i, j = np.clip(((z + 3.0) / 1.5).astype(int), 0, 3)
        return int(4 * i + j)

    monkeypatch.setattr(bo_module, "decode", lambda model, z: DesignTree((-1,), (cell(z),)))

    def run(config: BOConfig) -> list[tuple[str, int]]:
        bo, sent = LatentBO(config, seed=0, budget=20, env=LATENT_2), []
        for _ in range(20):
            proposal = bo.propose(LATENT_2)
            sent.append((proposal.tree.design_id, proposal.rejected, bo.is_random_step()))
            bo.tell(proposal, float(-abs(cell(proposal.z) - 9)))  # best cell 9
        return sent

    plain, reask = run(BOConfig(init=5)), run(ReaskConfig(init=5))

    def distinct(sent: list) -> int:
        return len({design for design, _, _ in sent})

    assert distinct(reask) > distinct(plain)  # more designs for the same calls
    assert max(rejected for _, rejected, _ in reask) > 0 and all(rejected == 0 for _, rejected, _ in plain)
    seen = set()
    for design, rejected, random_step in reask:  # a repeat is sent only by a random point: the bound or scheduled
        assert design not in seen or random_step or rejected == 3
        seen.add(design)


@pytest.mark.slow  # three 30-call BO runs (~1 min)
def test_the_window_setting_bounds_the_designs_a_run_can_still_reach(monkeypatch):
    """The collapse (issue 42): a decoder that maps the 2-D latent box onto a 24 x 24 grid of designs (cells 0.25
    wide) and a bowl with its best at (1, 1). GLSO's domain reduction narrows the window to its 0.5 floor, which
    holds at most 3 x 3 cells, so its last calls can only send those few designs; a floor of 2 keeps a 9 x 9
    block reachable and no reduction the whole grid."""
    def cell(z: np.ndarray) -> tuple[int, int]:
        i, j = np.clip(((z + 3.0) / 0.25).astype(int), 0, 23)
        return int(i), int(j)

    monkeypatch.setattr(bo_module, "decode", lambda model, z: DesignTree((-1, 0), cell(z)))

    def run(config: BOConfig, calls: int = 30) -> tuple[list[str], np.ndarray]:
        bo, sent = LatentBO(config, seed=0, budget=calls, env=LATENT_2), []
        for _ in range(calls):
            proposal = bo.propose(LATENT_2)
            sent.append(proposal.tree.design_id)
            bo.tell(proposal, float(-np.sum((proposal.z - 1.0) ** 2)))
        bounds = bo.optimizer.space.bounds
        return sent, bounds[:, 1] - bounds[:, 0]

    windows, late = {}, {}
    for config in (BOConfig(init=5), WideFloorConfig(init=5), NoReductionConfig(init=5)):
        sent, windows[type(config)] = run(config)
        late[type(config)] = len(set(sent[-10:]))
    assert np.allclose(windows[BOConfig], 0.5) and late[BOConfig] <= 9  # collapsed onto its floor
    assert np.allclose(windows[WideFloorConfig], 2.0) and np.allclose(windows[NoReductionConfig], 6.0)
    assert late[NoReductionConfig] > late[BOConfig]
