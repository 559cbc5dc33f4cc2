import numpy as np

from robocompose.glso.bo import BOConfig, LatentBO, decode
from robocompose.glso.method import Proposal, SearchEnv
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


def test_best_so_far_comes_from_the_whole_history_not_optimizer_max():
    bo = LatentBO(BOConfig(init=3), seed=1, budget=20, env=LATENT_2)
    _drive(bo, 14)
    history = max(bo.optimizer.space.target)
    inside = bo.optimizer.max  # only points inside the current (reduced) bounds
    assert inside is None or inside["target"] <= history


def test_decoding_is_greedy_and_deterministic(tiny_models):
    model = load_model(tiny_models.format(variant="full"))
    z = np.array([0.5, -1.0, 2.0])
    assert decode(model, z) == decode(model, z)
