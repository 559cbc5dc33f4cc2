"""The learner registry: every learner reads its own files and answers a task with k candidates, best first;
the baselines train through their registry entry. The toy problem of conftest.py stands in for both worlds."""

import inspect
import json
import os
import subprocess
import sys

from robocompose.eggan.dqn import DQNConfig
from robocompose.eggan.fit2form import Fit2formConfig
from robocompose.eggan.learners import LEARNERS, baselines, import_ref, ref_modules, training_order, variants
from robocompose.eggan.molgan import MolganConfig
from robocompose.eggan.networks import NetworkConfig
from robocompose.eggan.query import load_generator
from robocompose.eggan.train import TrainConfig, train
from robocompose.io.provenance import ROOT, import_closure

NETWORK = NetworkConfig(latent=8, hidden=16)


def test_the_registry_holds_each_worlds_learners_eggan_and_table_5_1s_three_learned_baselines():
    assert list(LEARNERS) == ["modular", "teams"]
    modular = LEARNERS["modular"]
    assert list(modular) == ["fit2form", "dqn", "molgan", "ga", "crowding"]  # Table 5.1's order
    assert list(baselines("modular")) == ["fit2form", "dqn", "molgan"]
    assert {name: (v.title, v.evolution, v.training) for name, v in variants("modular").items()} == {
        "ga": ("EG-GAN", "ga", None), "crowding": ("EG-GAN-crowding", "crowding", None)}
    assert training_order("modular") == ("molgan", "ga", "crowding", "dqn", "fit2form")  # costliest first
    assert [modular[n].training.settings for n in baselines("modular")] == [Fit2formConfig, DQNConfig, MolganConfig]
    assert list(LEARNERS["teams"]) == ["eggan"] and baselines("teams") == {}
    for learner in baselines("modular").values():
        assert list(inspect.signature(learner.training.train).parameters)[:4] == ["problem", "network", "config",
                                                                                  "progress"]


def test_a_trained_eggan_generator_answers_through_its_registry_entry(tmp_path, match_problem):
    from robocompose.eggan.query import save_generator

    trained = train(match_problem, NETWORK, TrainConfig(iterations=4, batch=16, tasks=4, samples=4, log_every=2,
                                                        checkpoint_every=2))
    path = save_generator(trained.generator, match_problem, tmp_path / "g.pt", {})
    learner = LEARNERS["modular"]["crowding"]
    answer = learner.answer(learner.load(path, match_problem)[0], 16)
    designs = answer(match_problem, 1, 0, 3)
    assert len(designs) == len(set(map(match_problem.design_id, designs))) == 3
    assert answer(match_problem, 1, 0, 3) == designs  # the query seed fixes the draws


def test_a_generator_baseline_trains_saves_loads_and_answers_through_its_entry(tmp_path, match_problem):
    """Fit2form on the toy problem (MolGAN and DQN need a modular problem:
    tests/modular/experiments/test_generative.py)."""
    name, learner = "fit2form", LEARNERS["modular"]["fit2form"]
    config = learner.training.settings(iterations=2, tasks=2)
    model, rows = learner.training.train(match_problem, NETWORK, config, False)
    assert rows[-1]["real_evaluations"] == match_problem.real_evaluations == 2 * config.tasks * config.samples
    path = learner.training.save(model, match_problem, tmp_path / f"{name}.pt", {"metrics": {}})
    assert learner.load is load_generator
    designs = learner.answer(learner.load(path, match_problem)[0], 8)(match_problem, 2, 5, 2)
    assert len(designs) == 2 and designs == learner.answer(model, 8)(match_problem, 2, 5, 2)  # the file round trip


def test_a_teams_learner_draws_one_design_per_noise_vector_fixed_by_the_query_seed(tmp_path, match_problem):
    """The teams world's EG-GAN entry: the draws its front is measured on (the toy problem stands in for teams)."""
    from robocompose.eggan.query import generate, save_generator

    trained = train(match_problem, NETWORK, TrainConfig(iterations=2, batch=8, tasks=2, samples=4, log_every=1,
                                                        checkpoint_every=2))
    learner = LEARNERS["teams"]["eggan"]
    draws = learner.answer(learner.load(save_generator(trained.generator, match_problem, tmp_path / "g.pt", {}),
                                        match_problem)[0], 12)
    designs = draws(match_problem, 1, 7)
    assert len(designs) == 12 and designs == draws(match_problem, 1, 7)
    assert designs == generate(trained.generator, match_problem, 1, 12, seed=7)[0].designs
    assert designs != draws(match_problem, 1, 8)


LEARNER_MODULES = ("robocompose.eggan.dqn", "robocompose.eggan.fit2form", "robocompose.eggan.molgan")


def test_the_registry_imports_a_learners_module_only_when_the_learner_is_used():
    """Importing the registry imports no learner's own module; reading an entry's trainer imports that learner's
    module alone (in a fresh interpreter: this one has imported them all already)."""
    code = ("import json, sys\n"
            "from robocompose.eggan.learners import LEARNERS\n"
            f"modules = {LEARNER_MODULES!r}\n"
            "before = [m for m in modules if m in sys.modules]\n"
            "settings = LEARNERS['modular']['dqn'].training.settings\n"
            "print(json.dumps([before, [m for m in modules if m in sys.modules], settings.__name__]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == [[], ["robocompose.eggan.dqn"], "DQNConfig"]


def test_a_stage_that_runs_no_learned_baseline_does_not_depend_on_their_code():
    """The registry names its learners' modules as strings, which the import closure (dvc.yaml's code deps) does not
    follow: the teams generator's stages hold none of them, the registry's names are the modules it ships."""
    files = {path.relative_to(ROOT).as_posix() for path in import_closure(ROOT / "stages" / "teams_eggan.py")}
    assert "robocompose/eggan/learners.py" in files
    assert not {m.replace(".", "/") + ".py" for m in LEARNER_MODULES} & files
    assert not {m.replace(".", "/") + ".py" for m in LEARNER_MODULES} & {
        path.relative_to(ROOT).as_posix() for path in import_closure("robocompose.eggan.learners")}
    assert ref_modules("modular") == LEARNER_MODULES and ref_modules("teams") == ()
    assert import_ref("robocompose.eggan.dqn:DQNConfig") is DQNConfig and import_ref(train) is train
