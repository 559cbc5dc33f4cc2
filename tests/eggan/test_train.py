"""Algorithm 1 on the toy problem: it learns a task-dependent answer, losses are the thesis's, and a killed
run resumes to the same bytes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import generate, rank_distinct
from robocompose.eggan.train import (
    TrainConfig,
    bgan_generator_loss,
    discriminator_loss,
    gan_generator_loss,
    run_key,
    train,
    write_logs,
)
from robocompose.io.checkpoint import load_checkpoint
from tests.eggan.conftest import MatchProblem, TwoFamilies

NETWORK = NetworkConfig(latent=16)
CONFIG = TrainConfig(iterations=1500, batch=32, tasks=8, samples=8, evolution_steps=3, lr_generator=1e-3,
                     lr_discriminator=1e-3, log_every=50, checkpoint_every=50)


def held_out_matches(trained, problem, tasks=20) -> float:
    """Mean matches of the generator's most probable design on tasks drawn apart from training's streams."""
    rng = np.random.default_rng(999)
    scores = []
    for _ in range(tasks):
        task = problem.sample_task(rng)
        sampled, output = generate(trained.generator, problem, task, 64, seed=1)
        best = rank_distinct(problem, sampled, output, 1)[0].design
        scores.append(sum(a == b for a, b in zip(best, task, strict=True)))
    return float(np.mean(scores))


def test_eggan_learns_a_task_dependent_answer(match_problem):
    trained = train(match_problem, NETWORK, CONFIG)
    # A random design matches 1.5 of 6 ports on average; an unconditioned generator cannot beat that.
    assert held_out_matches(trained, match_problem) > 2.3
    assert trained.rows[-1]["gen_matches_mean"] > trained.rows[0]["gen_matches_mean"] + 0.4
    assert trained.rows[-1]["real_evaluations"] == match_problem.evaluations > 0
    # The top design changes with the task: over 30 held-out tasks it matches its own task better than the
    # other tasks (a task-blind generator's top design matches every task alike: margin 0 +- ~0.2).
    rng = np.random.default_rng(5)
    tasks = [match_problem.sample_task(rng) for _ in range(30)]
    tops = [rank_distinct(match_problem, *generate(trained.generator, match_problem, t, 64, seed=1), 1)[0].design
            for t in tasks]
    matches = np.array([[sum(a == b for a, b in zip(top, t, strict=True)) for t in tasks] for top in tops])
    own, other = np.diag(matches).mean(), matches[~np.eye(30, dtype=bool)].mean()
    assert len(set(tops)) >= 10 and own > other + 0.5, (len(set(tops)), own, other)  # task-blind: 1 top design


def test_evolution_steps_shape_the_real_data_and_are_paid_for(match_problem):
    rows = {}
    for steps in (0, 3):
        problem = MatchProblem()
        config = TrainConfig(iterations=20, batch=32, tasks=4, evolution_steps=steps, log_every=20,
                             checkpoint_every=20)
        rows[steps] = train(problem, NETWORK, config).rows[-1]
        # each generated design is evaluated once, each evolution step evaluates one child per design
        assert problem.evaluations == rows[steps]["real_evaluations"] == 20 * 32 * (1 + steps)
    assert rows[0]["pop_matches_mean"] == rows[0]["gen_matches_mean"]  # no evolution: X_pop is X_gen
    assert rows[3]["pop_matches_mean"] > rows[3]["gen_matches_mean"] + 0.5  # 3 crowding steps: fitter real data
    assert rows[0]["pop_new"] == 0 and 0 < rows[3]["pop_new"] < 1  # the share of X_pop not drawn in X_gen


def test_bgan_weights_are_the_softmax_of_the_logits_without_gradient():
    d = torch.tensor([[0.0, np.log(3.0)]], requires_grad=True)  # weights 1/4, 3/4
    log_prob = torch.tensor([[-1.0, -2.0]], requires_grad=True)
    loss = bgan_generator_loss(d, log_prob)
    assert float(loss.detach()) == pytest.approx(0.25 * 1 + 0.75 * 2)
    loss.backward()
    assert d.grad is None or float(d.grad.abs().sum()) == 0.0
    assert torch.allclose(log_prob.grad, torch.tensor([[-0.25, -0.75]]))


def test_gan_and_discriminator_losses_at_chance():
    zero = torch.zeros(4)
    assert float(discriminator_loss(zero, zero)) == pytest.approx(np.log(2))
    assert float(gan_generator_loss(zero)) == pytest.approx(-np.log(2))  # log(1 - 1/2)
    confident = discriminator_loss(torch.full((4,), 5.0), torch.full((4,), -5.0))
    assert float(confident) < 0.01


def test_bad_config_is_a_clear_error(match_problem):
    with pytest.raises(ValueError, match="even number of noise vectors per task"):
        TrainConfig(batch=24, tasks=8)
    with pytest.raises(ValueError, match="supports"):
        train(match_problem, NETWORK, TrainConfig(iterations=1, evolution="nsga2"))


RESUME_SCRIPT = """
import sys, time
from pathlib import Path
sys.path.insert(0, {root!r})
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.train import TrainConfig, train
import robocompose.eggan.train as T
from tests.eggan.conftest import MatchProblem, TwoFamilies
slow = {slow}
if slow:  # give the parent time to kill us after the first checkpoint
    original = T.train_step
    def step(*args, **kwargs):
        time.sleep(0.05)
        return original(*args, **kwargs)
    T.train_step = step
config = TrainConfig(iterations=40, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=10)
train(MatchProblem(), NetworkConfig(latent=8, hidden=16), config, Path(sys.argv[1]), Path(sys.argv[2]))
"""


def _checkpoint(path: Path) -> dict:
    """The script's checkpoint at `path` (read with the key of the script's run)."""
    config = TrainConfig(iterations=40, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=10)
    return load_checkpoint(path, run_key(MatchProblem(), NetworkConfig(latent=8, hidden=16), config), named=True)


def _run(tmp: Path, name: str, slow: bool, kill_after_checkpoint: bool) -> Path:
    script = tmp / f"{name}.py"
    script.write_text(RESUME_SCRIPT.format(root=str(Path(__file__).resolve().parents[2]), slow=slow))
    checkpoint, csv = tmp / f"{name}.pt", tmp / f"{name}.csv"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    process = subprocess.Popen([sys.executable, str(script), str(checkpoint), str(csv)], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if kill_after_checkpoint:
        deadline = time.time() + 120
        while not checkpoint.exists() and time.time() < deadline:
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
        process.wait()
        assert _checkpoint(checkpoint)["iteration"] < 40  # really interrupted
        process = subprocess.Popen([sys.executable, str(script), str(checkpoint), str(csv)], env=env,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    assert process.wait(timeout=300) == 0
    return checkpoint


def test_killed_training_resumes_to_the_same_checkpoint(tmp_path):
    straight = _checkpoint(_run(tmp_path, "straight", False, False))
    resumed = _checkpoint(_run(tmp_path, "resumed", True, True))
    assert straight["iteration"] == resumed["iteration"] == 40
    for part in ("generator", "discriminator"):
        for name, value in straight[part].items():
            assert torch.equal(value, resumed[part][name]), f"{part}.{name}"
    assert straight["rows"] == resumed["rows"]
    assert straight["problem"] == resumed["problem"]
    assert (tmp_path / "straight.csv").read_bytes() == (tmp_path / "resumed.csv").read_bytes()


def test_a_checkpoint_of_other_settings_is_not_resumed(tmp_path, match_problem):
    checkpoint = tmp_path / "run.pt"
    small = TrainConfig(iterations=10, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=5)
    train(match_problem, NetworkConfig(latent=8, hidden=16), small, checkpoint)
    other = TrainConfig(**{**small.__dict__, "seed": 1})
    with pytest.warns(UserWarning, match="a checkpoint of another run or other code .*starting afresh"):
        resumed = train(MatchProblem(), NetworkConfig(latent=8, hidden=16), other, checkpoint)
    assert resumed.rows == train(MatchProblem(), NetworkConfig(latent=8, hidden=16), other).rows


def test_training_log_validates_against_its_schema(tmp_path, valid_foxglove_log):
    rows = [{"iteration": i, "d_loss": 0.5, "g_loss": float("nan"), "gen_distinct": 3} for i in (1, 2)]
    write_logs(rows, None, tmp_path / "log.mcap", "/eggan/train")
    assert valid_foxglove_log(tmp_path / "log.mcap") == 2


def test_a_corrupt_checkpoint_is_moved_aside_and_training_starts_afresh(tmp_path, match_problem):
    checkpoint = tmp_path / "run.pt"
    small = TrainConfig(iterations=10, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=5)
    first = train(match_problem, NetworkConfig(latent=8, hidden=16), small, checkpoint)
    data = bytearray(checkpoint.read_bytes())
    data[len(data) * 3 // 4] ^= 0xFF  # a flipped byte in the weights: torch.load alone would resume from it
    checkpoint.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="checksum mismatch"):
        again = train(MatchProblem(), NetworkConfig(latent=8, hidden=16), small, checkpoint)
    assert (tmp_path / "run.pt.corrupt").exists() and again.rows == first.rows
    for name, value in first.generator.state_dict().items():
        assert torch.equal(value, again.generator.state_dict()[name]), name


def test_an_archive_keeps_x_pop_evolved_and_evaluates_only_the_evolutions_children():
    """Without an archive X_pop is 2 steps from X_gen; with one it is the fittest of the evolution on X_gen and the
    task's K fittest designs so far (the two-family world's 20 training terrains come back): more of it is new and
    fitter, the discriminator can tell it apart, and archived designs are not evaluated again."""
    rows, asked = {}, {}
    for archive in (0, 8):
        problem = TwoFamilies()
        calls = []
        evaluate = problem.evaluate
        problem.evaluate = lambda task, designs, evaluate=evaluate, calls=calls: calls.append(len(designs)) or \
            evaluate(task, designs)
        config = TrainConfig(iterations=100, batch=16, tasks=2, samples=4, evolution_steps=2, archive=archive,
                             lr_generator=3e-3, lr_discriminator=3e-3, log_every=50, checkpoint_every=50)
        rows[archive] = train(problem, NetworkConfig(latent=8, hidden=32, encoder="features", segments=3),
                              config).rows[-1]
        asked[archive] = sorted(set(calls))
    assert rows[8]["pop_new"] > rows[0]["pop_new"] + 0.1  # 0.74 vs 0.54
    assert rows[8]["d_accuracy"] > rows[0]["d_accuracy"] + 0.1  # 0.81 vs 0.53
    assert rows[8]["pop_distance_mean"] > rows[0]["pop_distance_mean"] + 1  # 5.4 vs 3.2
    assert asked[0] == [8]  # X_gen, then one child per design and step
    assert asked[8] == [8, 16]  # children of X_gen + archive (8 once the task has been seen); X_gen alone first


def test_early_stopping_keeps_the_best_validated_generator_and_resumes_with_it(tmp_path):
    scores = iter([1.0, 3.0, 2.0, 2.5])  # validation at iterations 10, 20, 30, 40: the best is at 20
    kept = {}

    def validate(generator):
        score = next(scores)
        kept[score] = {k: v.clone() for k, v in generator.state_dict().items()}
        return {"val_score": score}

    config = TrainConfig(iterations=40, batch=16, tasks=4, samples=4, log_every=10, checkpoint_every=10,
                         validate_every=10, best_by="val_score", archive=4)
    network = NetworkConfig(latent=8, hidden=16)
    trained = train(MatchProblem(), network, config, tmp_path / "run.pt", validate=validate)
    assert trained.best_iteration == 20 and [r["best_iteration"] for r in trained.rows] == [10, 20, 20, 20]
    for name, value in trained.generator.state_dict().items():
        assert torch.equal(value, kept[3.0][name]), name
    assert not all(torch.equal(v, kept[2.5][k]) for k, v in trained.generator.state_dict().items())
    saved = load_checkpoint(tmp_path / "run.pt", trained.key)
    assert saved["best"]["iteration"] == 20 and saved["archive"]  # the best weights and the archive resume
    again = train(MatchProblem(), network, config, tmp_path / "run.pt", validate=validate)  # finished: no step
    assert again.best_iteration == 20 and again.rows == trained.rows
    for name, value in again.generator.state_dict().items():
        assert torch.equal(value, kept[3.0][name]), name


def test_a_run_with_an_archive_resumes_to_the_same_bytes(tmp_path):
    config = TrainConfig(iterations=20, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=5, archive=4)
    network = NetworkConfig(latent=8, hidden=16)
    straight = train(MatchProblem(), network, config)
    half = tmp_path / "half.pt"
    train(MatchProblem(), network, TrainConfig(**{**config.__dict__, "iterations": 10}), half)
    resumed = train(MatchProblem(), network, config, half)  # iterations are bookkeeping: the run continues
    assert resumed.rows == straight.rows
    for name, value in straight.generator.state_dict().items():
        assert torch.equal(value, resumed.generator.state_dict()[name]), name


def test_bad_archive_and_early_stopping_settings_are_refused_naming_the_field(match_problem):
    with pytest.raises(ValueError, match=r"^archive: expected 0 or a positive even number .*found 3"):
        TrainConfig(archive=3)
    with pytest.raises(ValueError, match=r"^best_by: expected \"\" or a validation score with validate_every > 0, "
                       r"found 'val_score' \(validate_every 0\)"):
        TrainConfig(best_by="val_score")
    config = TrainConfig(iterations=10, batch=16, tasks=4, samples=4, log_every=5, checkpoint_every=5,
                         validate_every=5, best_by="val_score")
    with pytest.raises(ValueError, match=r"^best_by: 'val_score' needs a validation callback"):
        train(match_problem, NETWORK, config)
    with pytest.raises(ValueError, match=r"^best_by: expected one of the validation scores .*'val_other'.*found "
                       r"'val_score'"):
        train(MatchProblem(), NETWORK, config, validate=lambda generator: {"val_other": 1.0})
    match_problem.objectives = (*match_problem.objectives, match_problem.objectives[0])
    with pytest.raises(ValueError, match=r"^archive: expected 0 for problem match"):
        train(match_problem, NETWORK, TrainConfig(iterations=1, batch=16, tasks=4, archive=2))
    assert run_key(MatchProblem(), NETWORK, TrainConfig(archive=2)) != run_key(MatchProblem(), NETWORK, TrainConfig())
    assert run_key(MatchProblem(), NETWORK, TrainConfig(validate_every=10, best_by="v")) != \
        run_key(MatchProblem(), NETWORK, TrainConfig(validate_every=10))
    assert run_key(MatchProblem(), NetworkConfig(latent=16, encoder="features"), TrainConfig()) != \
        run_key(MatchProblem(), NETWORK, TrainConfig())
