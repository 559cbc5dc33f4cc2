import dataclasses

import numpy as np
import pytest
import torch

from robocompose.eggan.learners import LEARNERS
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import model_code_digest
from robocompose.eggan.train import TrainConfig, train
from robocompose.io import InputError
from robocompose.io.provenance import ROOT
from robocompose.io.torch_file import load_torch, save_torch
from robocompose.params import load_section
from robocompose.search.nsga2 import non_dominated
from robocompose.teams.chips import synthetic_chip
from robocompose.teams.compose import SHIPPED_MODEL
from robocompose.teams.decompose import DecomposeConfig, decompose_chip
from robocompose.teams.eggan_problem import EvolutionConfig, TeamsProblem
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.evaluator import AllocationEvaluator, chip_coverage
from robocompose.teams.generative import (
    query_front,
    save_teams_generator,
    split_validation,
    teams_generator_info,
    training_summary,
)
from robocompose.teams.nsga2 import deployment_share_draws, team_hypervolume
from robocompose.teams.params import EgganConfig, TeamsParams
from robocompose.teams.species import allocation_to_counts

TINY = CoverageConfig(iterations=3, n_observations=5)


@pytest.fixture(scope="module")
def trained_problem():
    chips = [synthetic_chip(6, index, size=40) for index in range(2)]
    problem = TeamsProblem([(chip, decompose_chip(chip, DecomposeConfig(n_regions=3))) for chip in chips], TINY)
    trained = train(problem, NetworkConfig(latent=4, hidden=8),
                    TrainConfig(iterations=2, batch=8, tasks=2, evolution="nsga2", log_every=1, checkpoint_every=2))
    return trained, problem


def test_generator_file_round_trips_weights_settings_and_metrics(tmp_path, trained_problem):
    trained, problem = trained_problem
    path = save_teams_generator(trained, problem, {"coverage": {"iterations": 2}}, {"mean_hypervolume": 1.5},
                                tmp_path / "g.pt")
    info = teams_generator_info(path)
    assert info["n_regions"] == 3 and info["problem"] == "teams" and info["design_shape"] == [4, 3]
    assert info["params"] == {"coverage": {"iterations": 2}} and info["metrics"]["mean_hypervolume"] == 1.5
    assert info["model_code"] == model_code_digest() and info["run_key"] == trained.key
    generator, loaded_info = LEARNERS["teams"]["eggan"].load(path, problem)
    for name, tensor in trained.generator.state_dict().items():
        assert torch.equal(tensor, generator.state_dict()[name])
    assert loaded_info == info and not generator.training
    with pytest.raises(InputError, match="no such file"):
        teams_generator_info(tmp_path / "missing.pt")
    save_torch({"weights": 1}, tmp_path / "other.pt")
    with pytest.raises(InputError, match="not an EG-GAN generator file"):
        teams_generator_info(tmp_path / "other.pt")
    saved = load_torch(path)
    save_torch(saved | {"info": saved["info"].replace('"teams"', '"modular"')}, tmp_path / "modular.pt")
    with pytest.raises(InputError, match="not a teams generator file \\(a generator for 'modular'\\)"):
        teams_generator_info(tmp_path / "modular.pt")
    save_torch(saved | {"info": saved["info"].replace("share-split", "softmax-depot")}, tmp_path / "old.pt")
    with pytest.raises(InputError, match="trained with design head 'softmax-depot'.*retrain"):
        teams_generator_info(tmp_path / "old.pt")
    data = bytearray(path.read_bytes())
    data[len(data) * 3 // 4] ^= 0xFF  # a flipped byte inside the weights: torch.load alone would not notice
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=f"{path}: checksum mismatch"):
        teams_generator_info(path)


def test_query_front_is_the_learners_draws_measured_and_non_dominated(trained_problem):
    trained, problem = trained_problem
    chip, decomposition = problem.chips[1]
    query = query_front(LEARNERS["teams"]["eggan"].answer(trained.generator, 32), chip, decomposition, TINY, seed=0)
    assert 1 <= len(query.front) <= query.distinct <= 32
    assert non_dominated(query.front).tolist() == list(range(len(query.front)))
    measured, _, _ = chip_coverage(chip, decomposition, TINY).evaluate(query.counts, seed=0)
    np.testing.assert_allclose(query.front[:, 0], measured, rtol=1e-5)
    assert query.hypervolume == team_hypervolume(query.front) and query.generator_seconds > 0
    one = query_front(lambda problem, task, seed: [np.full((3, 3), 0.1)] * 4, chip, decomposition, TINY, seed=0)
    assert one.distinct == 1 and one.counts.tolist() == [[[2, 2, 2]] * 3]  # 10% of 20 robots of each species


def test_the_shipped_generator_is_the_default_profiles_and_matches_the_model_code():
    info = teams_generator_info(ROOT / SHIPPED_MODEL)
    assert info["model_code"] == model_code_digest(), "retrain and ship: the network code changed"
    default = load_section(TeamsParams, "teams", ROOT / "profiles" / "default.yaml")
    for name in ("chips", "decompose", "coverage", "eggan"):
        assert info["params"][name] == dataclasses.asdict(getattr(default, name)), name
    assert info["n_regions"] == default.decompose.n_regions
    chip = synthetic_chip(0, 0)
    problem = TeamsProblem([(chip, decompose_chip(chip, default.decompose))], default.coverage)
    LEARNERS["teams"]["eggan"].load(ROOT / SHIPPED_MODEL, problem)  # its weights fit a problem of its K
    assert (ROOT / SHIPPED_MODEL).stat().st_size < 1_000_000  # a small file in the repository


def test_a_briefly_trained_generator_beats_random_allocations_of_the_same_count():
    chip = synthetic_chip(6, 1, size=40)
    pair = (chip, decompose_chip(chip, DecomposeConfig(n_regions=3)))
    evaluate = AllocationEvaluator(chip_coverage(*pair, TINY), chip.chip_id, 0)
    random = evaluate(allocation_to_counts(deployment_share_draws(np.random.default_rng(1), 64, 3, 3), 20))
    random_hypervolume = team_hypervolume(random[non_dominated(random)])  # 9.39
    fronts = {}
    for iterations in (5, 200):  # barely trained, then trained (archive: X_pop evolves on from the last one)
        trained = train(TeamsProblem([pair], TINY, EvolutionConfig(archive=True)), NetworkConfig(latent=4, hidden=32),
                        TrainConfig(iterations=iterations, batch=16, tasks=1, evolution="nsga2", log_every=5,
                                    checkpoint_every=5, lr_generator=1e-3, lr_discriminator=1e-3, seed=1))
        draws = LEARNERS["teams"]["eggan"].answer(trained.generator, 64)
        fronts[iterations] = query_front(draws, *pair, TINY, 0, evaluate).hypervolume
    assert fronts[5] < random_hypervolume < fronts[200]  # 7.5 < 9.4 < 11.2


def test_the_shipped_generator_beats_random_allocations_of_its_count_on_chips_it_never_saw():
    # the default profile's generator, trained on the training split; two test-split chips of the same synthetic set
    from robocompose.teams.compose import TeamsComposer
    from robocompose.teams.decompose import split_chips

    composer = TeamsComposer.load(SHIPPED_MODEL)
    settings = composer.info["params"]
    chip_ids = [synthetic_chip(settings["chips"]["seed"], index).chip_id
                for index in range(settings["chips"]["n_synthetic"])]
    split = split_chips(chip_ids, settings["decompose"]["test_fraction"], settings["decompose"]["seed"])
    unseen = [index for index, chip_id in enumerate(chip_ids) if split[chip_id] == "test"][:2]
    assert not {chip_ids[index] for index in unseen} & set(composer.info["train_chip_ids"])
    samples = settings["eggan"]["samples"]
    for index in unseen:
        chip = synthetic_chip(settings["chips"]["seed"], index)
        generated = composer.query(chip, seed=0)["hypervolume"]
        decomposition = decompose_chip(chip, composer.decompose)
        evaluate = AllocationEvaluator(chip_coverage(chip, decomposition, composer.coverage), chip.chip_id, 0)
        draws = deployment_share_draws(np.random.default_rng(index), samples, decomposition.n_regions, 3)
        random = evaluate(allocation_to_counts(draws, composer.coverage.robots_per_species))
        assert generated > team_hypervolume(random[non_dominated(random)])


def test_validation_chips_are_held_out_of_training_and_the_summary_flags_a_discriminator_at_chance():
    chips = [(synthetic_chip(6, index, size=40), None) for index in range(3)]
    training, validation = split_validation(chips, EgganConfig(validation_chips=1))
    assert training == chips[:2] and validation == chips[2:]
    with pytest.raises(InputError, match="validation_chips: 3 of 3 training chips leaves none"):
        split_validation(chips, EgganConfig(validation_chips=3))
    rows = [{"d_accuracy": 0.9, "validation_hypervolume": np.nan}] * 9 + [{"d_accuracy": 0.52,
                                                                           "validation_hypervolume": 4.0}]
    assert training_summary(rows) == {"d_accuracy_final": 0.52, "d_at_chance": True,
                                      "validation_hypervolume_first": 4.0, "validation_hypervolume_best": 4.0,
                                      "validation_hypervolume_last": 4.0}
    assert training_summary(rows[:9])["d_at_chance"] is False
