import dataclasses
import json

import numpy as np
import pytest

from robocompose.cli import main
from robocompose.fanout.cache import EvaluationCache
from robocompose.io import read_table
from robocompose.io.errors import InputError
from robocompose.modular import family_truth
from robocompose.modular.evaluate import EvalSettings, FitnessRule, Result
from robocompose.modular.family_truth import (
    design_set,
    evaluate_world,
    family_digest,
    gate_directories,
    make_world,
    mean_result,
    probe,
)
from robocompose.modular.gate import GateConfig
from robocompose.modular.robot import valid_in_original
from robocompose.modular.truth import physics_digest

TINY = EvalSettings(control_steps=3, settle_steps=10)
RULE = FitnessRule()


def test_the_block_worlds_physics_digest_is_unchanged():
    """The committed exhaustive tables (pool, test, h02) carry this digest: the families add code beside the block
    world's rollout, never inside it."""
    assert physics_digest() == "b5f96e99a7f92e90"
    assert family_digest() != physics_digest()


def test_worlds_key_their_rollouts_apart_from_the_block_world():
    walls, steps = make_world("walls", TINY), make_world("steps", TINY)
    assert walls.task_id(3, None) == "walls-3" and walls.task_id(3, 1) == "walls-3~p1"
    assert make_world("blocks", TINY).task_id(3, 0) == "blocks-3~p0"  # perturbed: never the block world's key
    hashes = {w.settings_hash() for w in (walls, steps, dataclasses.replace(walls, shift=0.01),
                                          make_world("walls", TINY, {"spread": 0.5}))}
    assert len(hashes) == 4 and TINY.settings_hash() not in hashes


def test_a_mean_over_perturbations_needs_a_distance_from_each():
    ok = [Result(1.0, "ok", 10, 0.1), Result(2.0, "stalled", 10, 0.1)]
    assert mean_result(ok) == Result(1.5, "stalled", 20, 0.2)
    assert mean_result([*ok, Result(None, "unstable", 5, 0.1)]).distance is None


@pytest.fixture
def fake_rollouts(monkeypatch):
    """Rollouts faked: wheels go far on low terrains and legs on tall ones (the terrain decides); the terrains
    terrain of every rollout is recorded."""
    seen = []

    def fake(designs, terrain, settings):
        seen.extend([terrain] * len(designs))
        tall = terrain.max_height > 0.08
        return [Result(float(d.count("l" if tall else "w")) + terrain.centers[0, 0] / 100, "ok", 7, 0.01)
                for d in designs]

    monkeypatch.setattr(family_truth, "rollouts", fake)
    return seen


def test_a_perturbed_fitness_is_the_mean_over_its_terrains_and_cached_per_perturbation(fake_rollouts):
    world, cache = make_world("walls", TINY), EvaluationCache()
    plain = evaluate_world(["wwwwww", "nnnnnn"], 4, world, RULE, 0, cache)
    assert plain[1].status == "invalid" and len(fake_rollouts) == 1
    perturbed = evaluate_world(["wwwwww"], 4, world, RULE, 3, cache)[0]
    centres = [t.centers[0, 0] for t in fake_rollouts[1:]]
    assert len(centres) == 3 and len(set(centres)) == 3
    wheels = 0 if fake_rollouts[0].max_height > 0.08 else 6
    assert perturbed.distance == pytest.approx(np.mean([wheels + c / 100 for c in centres]))
    assert perturbed.sim_steps == 21
    evaluate_world(["wwwwww"], 4, world, RULE, 2, cache)  # P = 2 reuses P = 3's first two rollouts
    assert len(fake_rollouts) == 4 and len(cache) == 4


def test_a_probe_keeps_a_table_per_terrain_and_the_gate_reads_them(tmp_path, fake_rollouts):
    world, cache = make_world("walls", TINY), EvaluationCache()
    designs = ["wwwwww", "llllll", "wlwwlw", "lwllwl"]
    rows = []
    paths = probe(world, range(8), RULE, 0, "test", designs, cache, None, tmp_path, on_terrain=rows.append)
    assert [p.name for p in paths] == [f"walls-{s}.parquet" for s in range(8)] and len(fake_rollouts) == 32
    record = json.loads(paths[0].with_suffix(".json").read_text())
    assert record["family"] == "walls" and record["digest"] == family_digest() and record["designs"] == 4
    assert read_table(paths[0], "modular_exhaustive").design.tolist() == sorted(designs)
    probe(world, range(8), RULE, 0, "test", designs, cache, None, tmp_path)
    assert len(fake_rollouts) == 32  # kept: nothing simulated again
    assert [r["source"] for r in rows] == ["measured"] * 8
    summary = gate_directories([tmp_path], GateConfig(ks=(1, 2), pass_ks=(1,), neighbours=1)).summary
    assert summary["family"] == "walls" and summary["terrains"] == 8 and summary["designs"] == 4
    other = tmp_path / "other"
    probe(make_world("walls", TINY, {"spread": 0.5}), [9], RULE, 0, "test", designs, cache, None, other)
    with pytest.raises(InputError, match="other settings"):
        gate_directories([tmp_path, other])


def test_real_rollouts_run_on_a_family_terrain_and_a_perturbed_one(tmp_path):
    """Physics: a wheeled design on a walls terrain and on a perturbed one, through the real rollouts."""
    world = make_world("walls", TINY)
    plain, perturbed = (evaluate_world(["wwwwww"], 2, world, RULE, p)[0] for p in (0, 1))
    assert plain.status == "ok" and perturbed.status == "ok" and plain.sim_steps == 10 + 3 * 20


def test_design_sets():
    balanced, top = design_set("balanced"), design_set("top")
    assert len(balanced) == len(top) == 400 and all(valid_in_original(d) for d in balanced)
    assert "llllll" in balanced and "llllll" not in top and "wnwbnb" in top and "wnwbnb" in balanced
    assert len(design_set("all")) == 1296
    with pytest.raises(InputError, match="design set"):
        design_set("best")


@pytest.mark.parametrize(("family", "overrides", "perturbations", "words"), [
    ("lava", None, 0, ["family", "'lava'", "blocks"]),
    ("blocks", {"friction": 0.1}, 0, ["blocks", "no overrides", "friction"]),
    ("walls", None, -1, ["perturbations", "-1"]),
])
def test_bad_worlds_are_refused(family, overrides, perturbations, words):
    with pytest.raises(InputError) as err:
        evaluate_world(["wwwwww"], 0, make_world(family, TINY, overrides), RULE, perturbations)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_the_commands_refuse_bad_input_in_one_line(tmp_path, capsys):
    assert main(["modular", "family-probe", "--family", "lava", "--terrain-seed", "0"]) == 2
    assert "'lava'" in capsys.readouterr().err
    settings = tmp_path / "walls.yaml"
    settings.write_text("height_range: [0.3, 0.1]\n")
    assert main(["modular", "family-probe", "--family", "walls", "--terrain-seed", "0",
                 "--family-settings", str(settings)]) == 2
    assert "height_range" in capsys.readouterr().err
    assert main(["modular", "gate", "--dir", str(tmp_path)]) == 2
    assert "no tables" in capsys.readouterr().err


def test_the_unperturbed_block_world_is_read_from_its_committed_tables(tmp_path, monkeypatch):
    from robocompose.modular.params import ModularParams
    from robocompose.params import load_command_section

    params = load_command_section(ModularParams, "modular", "params.yaml")
    monkeypatch.setattr(family_truth, "rollouts", None)  # any rollout would fail
    monkeypatch.setattr(family_truth, "evaluate_designs", None)
    designs = ["wnwbnb", "llllll"]
    [path] = probe(make_world("blocks", params.eval), [20003], params.fitness, 0, "test", designs,
                   EvaluationCache(), None, tmp_path)
    table = read_table(path, "modular_exhaustive")
    pool = read_table("measured/modular/pool/blocks-20003.parquet", "modular_exhaustive")
    expected = pool[pool.design.isin(designs)].sort_values("design", ignore_index=True)
    assert table.design.tolist() == designs[::-1] and table.distance.tolist() == expected.distance.tolist()
    assert json.loads(path.with_suffix(".json").read_text())["digest"] == physics_digest()
