import math

import numpy as np
import pytest
import torch

from robocompose.glso.ghs import (
    JOINT_KINDS,
    LABELS,
    N_FEATURES,
    GHSConfig,
    GraphHeuristicSearch,
    Heuristic,
    collate,
    exp_decay,
    features,
)
from robocompose.grammar.derivation import derive, unfold
from tests.conftest import FLAT_REFERENCE


def test_epsilon_schedule_runs_from_one_to_about_0_13_over_the_budget():
    assert exp_decay(1.0, 0.1, 0.3, 0, 500) == 1.0
    assert math.isclose(exp_decay(1.0, 0.1, 0.3, 500, 500), 0.1 + 0.9 * math.exp(-1 / 0.3))
    assert 0.13 < exp_decay(1.0, 0.1, 0.3, 500, 500) < 0.135


def test_features_are_robogrammars_link_features_with_world_pose():
    """34 + labels per link of the unfolded robot: the flat reference's mirrored leg pairs sit at mirrored
    world positions (y -> -y), its root is the free-joint link at the origin, and every link is terminal."""
    graph = derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).graph
    x, adj = features(graph)
    links = unfold(graph)
    assert x.shape == (len(links), N_FEATURES) == (len(links), 34 + len(LABELS))
    assert x[0, JOINT_KINDS.index("free")] == 1 and (x[1:, JOINT_KINDS.index("free")] == 0).all()
    pos = x[:, 24:27]  # world position: after joint (12), shape (3), physical (7) and control mode (2)
    assert np.allclose(pos[0], 0.0)
    assert (x[:, 34 + LABELS.index("")] == 1).all()  # a complete design: every link is terminal
    assert (adj == adj.T).all() and adj.sum() == 2 * (len(links) - 1)  # the link tree, symmetric
    for i in range(len(links)):  # every link off the sagittal plane has a mirror image
        if abs(pos[i, 1]) > 1e-6:
            assert np.isclose(pos[:, 0], pos[i, 0]).__and__(np.isclose(pos[:, 1], -pos[i, 1])).any()
    partial = derive((0,), require_complete=False).graph  # rule 0: head, body, tail, all non-terminal
    xp, _ = features(partial)
    assert xp[:, 34 + LABELS.index("")].sum() == 0 and xp.shape[0] == 3


def test_the_heuristic_ignores_padding_and_pools_into_10_then_3_clusters():
    torch.manual_seed(0)
    net = Heuristic(64)
    assert net.pool1.convs[2].rel.out_features == 10 and net.pool2.convs[2].rel.out_features == 3
    big = derive(tuple(int(r) for r in FLAT_REFERENCE.split(","))).graph
    small = derive((0,), require_complete=False).graph
    with torch.no_grad():
        alone = net(*collate([small]))
        batched = net(*collate([small, big]))
    assert torch.allclose(alone[0], batched[0], atol=1e-5)  # zero padding changes nothing


def test_v_hat_is_the_best_reward_below_each_state_and_training_fits_it():
    search = GraphHeuristicSearch(GHSConfig(num_samples=2, opt_iter=25, lr=1e-2), seed=0, budget=8, env=None)
    first = search.propose(None)
    search.tell(first, 5.0)
    second = search.propose(None)
    search.tell(second, 3.0)
    start = first.info[0]
    assert search.v_hat[start] == 5.0  # both derivations start at the start graph: the max is kept
    assert all(search.v_hat[s] == 5.0 for s in first.info)
    assert len(search.pool) == len(set(search.pool))
    before = np.mean([(search.predict([s])[0] - search.v_hat[s]) ** 2 for s in search.pool])
    for _ in range(4):
        search.tell(second, 3.0)
    after = np.mean([(search.predict([s])[0] - search.v_hat[s]) ** 2 for s in search.pool])
    assert after < before


def test_the_proposed_design_is_the_sample_with_the_highest_prediction(monkeypatch):
    search = GraphHeuristicSearch(GHSConfig(num_samples=4, eps_sample_start=0.0, eps_sample_end=0.0, eps_start=1.0,
                                            eps_end=1.0), seed=2, budget=100, env=None)  # 4 random derivations
    rollout, samples = search._rollout, []

    def recorded(eps, memo):
        sample = rollout(eps, memo)
        samples.append(sample)
        return sample

    monkeypatch.setattr(search, "_rollout", recorded)
    picked = []
    for _ in range(6):
        samples.clear()
        proposal = search.propose(None)
        finals = [states[-1] for states, _ in filter(None, samples)]
        predicted = search.predict(finals)
        assert len(finals) == 4 and len(set(predicted)) > 1
        best = int(np.argmax(predicted))
        assert search.predict([proposal.info[-1]])[0] == pytest.approx(predicted[best], abs=1e-6)
        assert proposal.tree.design_id == derive(proposal.rules).tree.design_id
        picked.append(best)
    assert len(set(picked)) > 1  # the pick is the prediction's, not a fixed position among the samples
