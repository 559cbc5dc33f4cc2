import dataclasses

import pytest
import torch

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.train import TrainConfig, train
from robocompose.io import InputError
from robocompose.io.provenance import ROOT
from robocompose.io.torch_file import load_torch, save_torch
from robocompose.params import load_section
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.compose import SHIPPED_MODEL
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.eggan_problem import TeamsProblem
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.generative import load_generator, model_code_digest, save_generator
from robocompose.teams.params import TeamsParams


def test_generator_file_round_trips_weights_settings_and_metrics(tmp_path):
    chips = [synthetic_chip(6, 0, size=40)]
    problem = TeamsProblem([(chips[0], decompose_chip(chips[0], DecomposeConfig(n_regions=3)))],
                           CoverageConfig(iterations=2, n_observations=4))
    trained = train(problem, NetworkConfig(latent=4, hidden=8),
                    TrainConfig(iterations=1, batch=4, tasks=1, evolution="nsga2", log_every=1, checkpoint_every=1))
    save_generator(trained, 3, {"coverage": {"iterations": 2}}, {"mean_hypervolume": 1.5}, tmp_path / "g.pt")
    generator, saved = load_generator(tmp_path / "g.pt")
    for name, tensor in trained.generator.state_dict().items():
        assert torch.equal(tensor, generator.state_dict()[name])
    assert saved["params"] == {"coverage": {"iterations": 2}} and saved["metrics"]["mean_hypervolume"] == 1.5
    assert saved["code_digest"] == model_code_digest() and not generator.training
    with pytest.raises(InputError, match="no such generator file"):
        load_generator(tmp_path / "missing.pt")
    save_torch({"weights": 1}, tmp_path / "other.pt")
    with pytest.raises(InputError, match="not a teams generator file"):
        load_generator(tmp_path / "other.pt")
    save_torch(load_torch(tmp_path / "g.pt") | {"design_head": "softmax-depot"}, tmp_path / "old.pt")
    with pytest.raises(InputError, match="trained with design head 'softmax-depot'.*retrain"):
        load_generator(tmp_path / "old.pt")
    data = bytearray((tmp_path / "g.pt").read_bytes())
    data[len(data) * 3 // 4] ^= 0xFF  # a flipped byte inside the weights: torch.load alone would not notice
    (tmp_path / "g.pt").write_bytes(bytes(data))
    with pytest.raises(InputError, match=f"{tmp_path / 'g.pt'}: checksum mismatch"):
        load_generator(tmp_path / "g.pt")


def test_the_shipped_generator_is_the_default_profiles_and_matches_the_model_code():
    _, saved = load_generator(ROOT / SHIPPED_MODEL)
    assert saved["code_digest"] == model_code_digest(), "retrain and ship: the network code changed"
    default = load_section(TeamsParams, "teams", ROOT / "profiles" / "default.yaml")
    for name in ("chips", "decompose", "coverage", "eggan"):
        assert saved["params"][name] == dataclasses.asdict(getattr(default, name)), name
    assert saved["n_regions"] == default.decompose.n_regions
    assert (ROOT / SHIPPED_MODEL).stat().st_size < 1_000_000  # a small file in the repository
