"""Model selection on validation for the learned baselines: the best validated weights return, training unchanged."""

import pytest
import torch

from robocompose.eggan.dqn import DQNConfig, train_dqn
from robocompose.eggan.fit2form import Fit2formConfig, train_fit2form
from robocompose.eggan.molgan import MolganConfig, train_molgan
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.selection import ModelSelection
from robocompose.io.errors import InputError
from tests.eggan.conftest import MatchProblem
from tests.eggan.test_molgan import ValidMatchProblem

NETWORK = NetworkConfig(latent=8, filters=4, hidden=16)
TRAINERS = {  # name -> trainer, settings, problem class (MolGAN's needs real designs)
    "fit2form": (train_fit2form, Fit2formConfig(iterations=40, tasks=2, samples=4), MatchProblem),
    "dqn": (train_dqn, DQNConfig(iterations=40, tasks=2, episodes=4, updates=2, batch=8, start=8, replay=32,
                                 hidden=16, layers=1), MatchProblem),
    "molgan": (train_molgan, MolganConfig(iterations=40, tasks=2, samples=4, n_critic=1, wgan_only_iterations=1),
               ValidMatchProblem),
}


@pytest.mark.parametrize("name", sorted(TRAINERS))
def test_the_best_validated_weights_are_returned_and_training_is_untouched(name):
    trainer, config, problem = TRAINERS[name]
    plain_model, plain_rows = trainer(problem(), NETWORK, config)
    scores = iter([0.1, 0.7, 0.3, 0.7])  # the peak at the second validation; a tie later keeps the earlier
    states = []

    def validate(model: torch.nn.Module) -> dict:
        states.append({k: v.clone() for k, v in model.state_dict().items()})
        return {"val_score": next(scores), "val_other": 0.0}

    select = ModelSelection(validate, 10, "val_score")
    model, rows = trainer(problem(), NETWORK, config, select=select)
    assert [row["iteration"] for row in rows if "val_score" in row] == [10, 20, 30, 40]
    assert [row["best_iteration"] for row in rows] == [10, 20, 20, 20]
    for key, value in model.state_dict().items():  # the weights validated at iteration 20, not the last ones
        assert torch.equal(value, states[1][key]), key
    assert any(not torch.equal(value, states[3][key]) for key, value in model.state_dict().items())
    strip = {"val_score", "val_other", "best_iteration"}
    assert [{k: v for k, v in row.items() if k not in strip} for row in rows] == plain_rows  # same training
    assert all(torch.equal(v, states[3][k]) for k, v in plain_model.state_dict().items())


def test_a_cadence_off_the_log_rows_and_an_unknown_score_are_refused(match_problem):
    with pytest.raises(InputError, match="validate_every: expected a positive multiple of 10"):
        ModelSelection(lambda model: {}, 15, "val_score")
    select = ModelSelection(lambda model: {"val_max": 1.0}, 10, "val_score")
    with pytest.raises(InputError, match=r"best_by: expected one of the validation scores \['val_max'\]"):
        train_fit2form(match_problem, NETWORK, Fit2formConfig(iterations=10, tasks=2, samples=4), select=select)
