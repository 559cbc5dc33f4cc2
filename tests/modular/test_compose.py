"""`robocompose compose modular`: k distinct valid designs as JSON, caps, bad inputs, the shipped generator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from robocompose.cli import main
from robocompose.eggan.networks import Generator, NetworkConfig
from robocompose.eggan.query import load_generator, model_code_digest, save_generator
from robocompose.io import InputError
from robocompose.io.torch_file import save_torch
from robocompose.modular.compose import SHIPPED_MODEL, parse_caps
from robocompose.modular.evaluate import EvalSettings, FitnessRule, rollout
from robocompose.modular.params import ExperimentsConfig, ModularParams
from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem
from robocompose.modular.terrain import generate_terrain

PARAMS = ModularParams(EvalSettings(), FitnessRule(), ExperimentsConfig())
TINY = """
modular:
  eval: {control_steps: 3, settle_steps: 10, terrain: {}}
  fitness: {}
  experiments: {}
compute: {workers: 1, cache: ""}
"""


@pytest.fixture
def model(tmp_path):
    torch.manual_seed(0)
    problem = ModularEgganProblem(PARAMS, FitnessConfig())
    generator = Generator(problem.task_shape, problem.design_shape, NetworkConfig(latent=8, hidden=16)).eval()
    return save_generator(generator, problem, tmp_path / "g.pt", {"run_key": "test"})


def test_compose_prints_k_distinct_valid_designs_within_the_caps(tmp_path, model, capsys):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    code = main(["compose", "modular", "--terrain-seed", "1000", "--k", "5", "--max", "leg=1,wheel=2",
                 "--model", str(model), "--params", str(params)])
    out = json.loads(capsys.readouterr().out)
    designs = [d["design"] for d in out["designs"]]
    assert code == 0 and len(designs) == len(set(designs)) == 5
    scores = [d["score"] for d in out["designs"]]
    assert scores == sorted(scores, reverse=True) and all(s > 0 for s in scores)
    for design in designs:
        assert design.count("l") <= 1 and design.count("w") <= 2 and not PARAMS.fitness.skips(design)


def test_compose_simulate_adds_each_designs_rollout_on_the_terrain(tmp_path, model, capsys):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    assert main(["compose", "modular", "--terrain-seed", "3", "--k", "2", "--model", str(model), "--simulate",
                 "--params", str(params)]) == 0
    settings = EvalSettings(control_steps=3, settle_steps=10)
    for entry in json.loads(capsys.readouterr().out)["designs"]:
        result = rollout(entry["design"], generate_terrain(3, settings.terrain), settings)
        assert (entry["distance"], entry["status"]) == (result.distance, result.status)


@pytest.mark.parametrize("heights, message", [
    (np.zeros((20, 50)), "expected shape (50, 20) (x by y), found (20, 50)"),
    (np.full((50, 20), np.nan), "expected finite numbers (metres), found nan"),
    (np.full((50, 20), 1e9), "heights expected in [0, 0.3] m (the ground and the highest block of {params}: "
                             "modular.eval.terrain.max_height_range), found [1e+09, 1e+09]"),
    (np.full((50, 20), -5.0), "heights expected in [0, 0.3] m"),
    (np.zeros((50, 20), dtype=complex), "expected real numbers (metres), found dtype complex128"),
    (np.array(["x"] * 1000).reshape(50, 20), "expected real numbers (metres), found dtype <U1"),
])
def test_a_bad_heightmap_exits_2_with_a_clear_line(tmp_path, monkeypatch, model, cli_error, heights, message):
    # relative names: the line (cut at LINE_LIMIT) names both files, and tmp_path's length varies (user, xdist worker)
    monkeypatch.chdir(tmp_path)
    path, params = Path("map.npy"), Path("p.yaml")
    params.write_text("modular:\n  eval: {terrain: {max_height_range: [0.1, 0.3]}}\n  fitness: {}\n  experiments: {}\n")
    np.save(path, heights)
    cli_error(["compose", "modular", "--heightmap", str(path), "--model", str(model), "--params", str(params)],
              f"--heightmap {path}: {message.format(params=params)}")


@pytest.mark.parametrize("make, message", [
    (lambda path: None, "no such file, expected a .npy height map"),
    (lambda path: path.mkdir(), "a directory, expected a .npy height map"),
    (lambda path: path.write_text("0 0 0\n"), "not a .npy array file (numpy.save format)"),
    (lambda path: np.save(path, np.array([{"a": 1}], dtype=object), allow_pickle=True), "not a .npy array file"),
    (lambda path: np.savez(path.with_suffix(".npz"), np.zeros((50, 20))) or path.with_suffix(".npz").rename(path),
     "a .npz archive, expected a .npy array file"),
])
def test_a_heightmap_that_is_no_npy_file_exits_2_naming_it(tmp_path, model, cli_error, make, message):
    path = tmp_path / "map.npy"
    make(path)
    cli_error(["compose", "modular", "--heightmap", str(path), "--model", str(model)], f"--heightmap {path}: {message}")


def test_compose_without_a_params_file_uses_the_defaults_and_their_height_range(tmp_path, model, cli_error, capsys,
                                                                                monkeypatch):
    monkeypatch.chdir(tmp_path)  # no params.yaml here: the built-in defaults, blocks up to 0.2 m
    path = tmp_path / "map.npy"
    np.save(path, np.full((50, 20), 0.2))
    assert main(["compose", "modular", "--heightmap", str(path), "--k", "2", "--model", str(model)]) == 0
    assert len(json.loads(capsys.readouterr().out)["designs"]) == 2
    np.save(path, np.full((50, 20), 0.25))
    cli_error(["compose", "modular", "--heightmap", str(path), "--model", str(model)],
              "heights expected in [0, 0.2] m (the ground and the highest block of the built-in defaults: "
              "modular.eval.terrain.max_height_range), found [0.25, 0.25]")


@pytest.mark.parametrize("flags, fragments", [
    (["--terrain-seed", "-3"], ["argument --terrain-seed", "expected an integer >= 0, found -3"]),
    (["--terrain-seed", "3", "--k", "0"], ["argument --k", "expected an integer >= 1, found 0"]),
    (["--terrain-seed", "3", "--samples", "-1"], ["argument --samples", "expected an integer >= 1"]),
    (["--terrain-seed", "3", "--seed", "-1"], ["argument --seed", "expected an integer >= 0"]),
    (["--terrain-seed", "3", "--model", "."], ["argument --model", ".: a directory, expected an EG-GAN generator"]),
])
def test_bad_compose_flags_exit_2_naming_the_flag(cli_error, flags, fragments):
    cli_error(["compose", "modular", *flags], *fragments)


def test_ship_rejects_a_directory_naming_it(tmp_path, cli_error):
    cli_error(["compose", "ship-modular", "--from", str(tmp_path)],
              "argument --from", f"{tmp_path}: a directory, expected an EG-GAN generator file")


def test_a_heightmap_query_works(tmp_path, model, capsys):
    path = tmp_path / "map.npy"
    np.save(path, np.zeros((50, 20)))
    assert main(["compose", "modular", "--heightmap", str(path), "--k", "3", "--model", str(model)]) == 0
    assert len(json.loads(capsys.readouterr().out)["designs"]) == 3


def test_bad_caps_and_foreign_model(tmp_path):
    with pytest.raises(ValueError, match="--max"):
        parse_caps("arm=2")
    assert parse_caps("leg=2, legwheel=0") == {"l": 2, "b": 0}
    problem = ModularEgganProblem(PARAMS, FitnessConfig())
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a model")
    with pytest.raises(InputError, match=f"{junk}: no checksum header"):
        load_generator(junk, problem)
    other = save_torch({"weights": torch.zeros(3)}, tmp_path / "other.pt")
    with pytest.raises(InputError, match="not an EG-GAN generator file"):
        load_generator(other, problem)


def test_a_cut_or_flipped_generator_file_is_an_error_naming_it_and_the_cli_exits_2(tmp_path, capsys):
    model = tmp_path / "g.pt"
    model.write_bytes(SHIPPED_MODEL.read_bytes())
    data = bytearray(model.read_bytes())
    data[len(data) * 3 // 4] ^= 0xFF  # inside the tensor data, where torch.load alone would not notice
    model.write_bytes(bytes(data))
    assert main(["compose", "modular", "--terrain-seed", "3", "--model", str(model)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{model}: checksum mismatch, the file is truncated or corrupted" in err


def test_the_shipped_generator_matches_the_current_model_code():
    info = json.loads(SHIPPED_MODEL.with_suffix(".json").read_text())
    assert info["model_code"] == model_code_digest(), "retrain: the network code changed since the model was shipped"
    generator, saved = load_generator(SHIPPED_MODEL, ModularEgganProblem(PARAMS, FitnessConfig()))
    assert saved == info and info["problem"] == "modular" and "metrics" in info
    assert SHIPPED_MODEL.stat().st_size < 2_000_000  # small enough for the repository


def test_the_shipped_generator_answers_a_low_and_a_high_block_terrain_differently():
    """Issue 22's acceptance: terrains never seen (no table), the lowest and highest blocks of 20 seeds."""
    from robocompose.eggan.learners import generator_answer
    from robocompose.modular.terrain import generate_terrain

    problem = ModularEgganProblem(PARAMS, FitnessConfig())
    generator = load_generator(SHIPPED_MODEL, problem)[0]
    heights = {seed: generate_terrain(seed, PARAMS.eval.terrain).max_height for seed in range(30_000, 30_020)}
    low, high = min(heights, key=heights.get), max(heights, key=heights.get)
    answer = generator_answer(generator, 64)
    assert answer(problem, low, 0, 3) != answer(problem, high, 0, 3)
