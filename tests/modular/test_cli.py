import json

import pytest
from PIL import Image

from robocompose.cli import main
from robocompose.io import read_mcap

TINY = """
modular:
  eval: {control_steps: 3, settle_steps: 10, terrain: {}}
  fitness: {}
  experiments: {generations: 2, random_designs: 3}
compute: {workers: 1, cache: ""}
"""


def test_evaluate_prints_one_json_object_and_writes_logs(tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    code = main(["modular", "evaluate", "--design", "WWWWWW", "--terrain-seed", "3", "--params", str(params),
                 "--mcap", str(tmp_path / "r.mcap"), "--gif", str(tmp_path / "r.gif")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["design"] == "wwwwww" and out["status"] == "ok" and out["distance"] > 0
    assert set(out) >= {"distance", "status", "seconds"}
    tf = [m for m in read_mcap(tmp_path / "r.mcap") if m.topic == "/tf"]  # the params' rollout: 3 control steps
    assert len(tf) == 3 + 1 and Image.open(tmp_path / "r.gif").n_frames == 1  # a GIF frame every 5 steps


def test_invalid_design_scores_the_penalty_and_a_bad_string_exits_2(tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    assert main(["modular", "evaluate", "--design", "nnnnnn", "--terrain-seed", "3", "--params", str(params)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "invalid" and out["distance"] is None and out["fitness"] == -10.0
    assert main(["modular", "evaluate", "--design", "lwx", "--terrain-seed", "3", "--params", str(params)]) == 2
    assert "front-left" in capsys.readouterr().err


def test_ga_prints_the_best_design(tmp_path, capsys):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    assert main(["modular", "ga", "--variant", "random", "--terrain-seed", "3", "--seed", "1",
                 "--params", str(params)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["evaluations"] == 3 and len(out["best_design"]) == 6
    assert set(out) >= {"best_design", "best_fitness", "distinct", "evaluations", "seconds"}


@pytest.mark.parametrize(("flags", "fragments"), [
    (["--params", "missing.yaml"], ["missing.yaml: params file not found"]),
    (["--terrain-seed", "-1"], ["argument --terrain-seed", "expected an integer >= 0, found -1"]),
    (["--mcap", "folder"], ["argument --mcap", "folder: is a directory"]),
    (["--gif", "r.mp4"], ["argument --gif", "r.mp4: expected a .gif file name"]),
    (["--design", "lwx"], ["design 'lwx': expected 6 letters"]),
])
def test_bad_evaluate_input_names_the_flag_or_file(tmp_path, monkeypatch, cli_error, flags, fragments):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    defaults = {"--design": "lwbnlw", "--terrain-seed": "0"}
    given = dict(zip(flags[::2], flags[1::2], strict=True))
    argv = [x for flag, value in {**defaults, **given}.items() for x in (flag, value)]
    cli_error(["modular", "evaluate", *argv], *fragments)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]


@pytest.mark.parametrize(("field", "value", "expected"), [
    ("terrain: {friction: -1.0}", "modular.eval.terrain.friction", "expected a finite number > 0 (pybullet's lateral"),
    ("terrain: {ground_friction: .inf}", "modular.eval.terrain.ground_friction", "expected a finite number > 0"),
    ("terrain: {ground_friction: 0}", "modular.eval.terrain.ground_friction", "> 0 (pybullet's lateral friction "
     "coefficient), found 0"),
    ("terrain: {max_height_range: [-0.1, 0.2]}", "modular.eval.terrain.max_height_range",
     "expected finite numbers >= 0 (m), found [-0.1, 0.2]"),
    ("terrain: {side_range: [0.0, 1.0]}", "modular.eval.terrain.side_range", "expected finite numbers > 0"),
    ("terrain: {x_range: [-1.0, .inf]}", "modular.eval.terrain.x_range", "expected finite numbers (m)"),
    ("time_step: -0.01", "modular.eval.time_step", "expected a finite number > 0 (s per sim step), found -0.01"),
    ("time_step: .nan", "modular.eval.time_step", "found nan"),
    ("settle_steps: -5", "modular.eval.settle_steps", "expected a finite number >= 0 (sim steps), found -5"),
    ("flip_up_z: 2.0", "modular.eval.flip_up_z", "expected a finite number >= -1 and <= 1"),
    ("max_abs_y: 0.0", "modular.eval.max_abs_y", "expected a finite number > 0 (m), found 0.0"),
    ("stall_distance: -0.02", "modular.eval.stall_distance", "expected a finite number >= 0 (m)"),
])
def test_evaluate_rejects_an_unphysical_setting_naming_file_field_and_bound(tmp_path, cli_error, field, value,
                                                                           expected):
    params = tmp_path / "p.yaml"
    params.write_text(f"modular:\n  eval: {{control_steps: 3, {field}}}\n")
    cli_error(["modular", "evaluate", "--design", "wwwwww", "--terrain-seed", "3", "--params", str(params)],
              f"{params}: {value}: expected", expected)


def test_ga_rejects_a_negative_seed(cli_error):
    cli_error(["modular", "ga", "--variant", "ga20", "--terrain-seed", "0", "--seed", "-2"],
              "argument --seed", "expected an integer >= 0, found -2")


def test_exhaustive_commits_one_terrains_table_with_its_provenance(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: ["wwwwww", "llllll", "nnnnnn"])
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    assert main(["modular", "exhaustive", "--terrain-seed", "1003", "--out-dir", str(tmp_path / "truth"),
                 "--params", str(params)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["best_design"] in ("wwwwww", "llllll") and out["table"].endswith("blocks-1003.parquet")
    record = json.loads((tmp_path / "truth" / "blocks-1003.json").read_text())
    assert record["simulated"] == 2 and record["settings"]["control_steps"] == 3 and record["physics_digest"]




def test_verify_committed_checks_every_table_and_an_empty_directory_exits_2(tmp_path, capsys, monkeypatch, cli_error):
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: ["wwwwww", "llllll"])
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    truth = tmp_path / "truth"
    assert main(["modular", "exhaustive", "--terrain-seed", "1003", "1004", "--out-dir", str(truth),
                 "--params", str(params)]) == 0
    capsys.readouterr()
    assert main(["modular", "verify-committed", "--dir", str(truth), "--sample", "2", "--params", str(params)]) == 0
    reports = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["sample"] for r in reports] == [2, 2] and all(r["mismatches"] == [] for r in reports)
    cli_error(["modular", "verify-committed", "--dir", str(tmp_path)], f"--dir {tmp_path}", "no blocks-<seed>.parquet")


def test_exhaustive_measures_a_candidate_distribution_and_skips_terrains_already_kept(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: ["wwwwww", "nnnnnn"])
    params, candidates = tmp_path / "params.yaml", tmp_path / "candidates.yaml"
    params.write_text(TINY)
    candidates.write_text("tall: {max_height_range: [0.3, 0.4]}\n")
    flags = ["modular", "exhaustive", "--terrain-seed", "4", "5", "--out-dir", str(tmp_path / "tall"),
             "--params", str(params), "--candidates", str(candidates), "--distribution", "tall"]
    assert main(flags) == 0
    assert [json.loads(line)["source"] for line in capsys.readouterr().out.splitlines()] == ["measured"] * 2
    record = json.loads((tmp_path / "tall" / "blocks-5.json").read_text())
    assert record["settings"]["terrain"]["max_height_range"] == [0.3, 0.4]
    assert main(flags[:5] + ["6"] + flags[5:]) == 0  # 4 and 5 are kept, 6 is measured
    assert [json.loads(line)["source"] for line in capsys.readouterr().out.splitlines()] == [
        "kept", "kept", "measured"]
    assert main(flags[:-2]) == 2
    assert "expected both" in capsys.readouterr().err
    assert main(flags[:-1] + ["short"]) == 2
    assert "not in" in capsys.readouterr().err

def test_probe_writes_rows_and_criterion_and_criterion_reads_a_table_directory(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("robocompose.modular.truth.all_designs", lambda: ["wwwwww", "llllll"])
    params, candidates = tmp_path / "params.yaml", tmp_path / "candidates.yaml"
    params.write_text(TINY)
    candidates.write_text("low: {max_height_range: [0.0, 0.01]}\ntall: {max_height_range: [0.2, 0.3]}\n")
    assert main(["modular", "probe", "--candidates", str(candidates), "--terrain-seed", "4", "5",
                 "--designs", "WWWWWW", "llllll", "--out", str(tmp_path / "probe.csv"), "--params", str(params)]) == 0
    printed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [row["distribution"] for row in printed] == ["low", "tall"] and printed[0]["terrains"] == 2
    assert (tmp_path / "probe.csv").read_text().count("\n") == 1 + 2 * 2 * 2
    assert (tmp_path / "probe_criterion.csv").read_text().startswith("distribution,terrains,distinct_optima")
    for seed in (4, 5):
        assert main(["modular", "exhaustive", "--terrain-seed", str(seed), "--out-dir", str(tmp_path / "truth"),
                     "--params", str(params)]) == 0
    capsys.readouterr()
    assert main(["modular", "criterion", "--dir", str(tmp_path / "truth")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["terrains"] == 2 and [r["terrain_seed"] for r in out["per_terrain"]] == [4, 5]
    assert main(["modular", "criterion", "--dir", str(tmp_path / "none")]) == 2
    assert "no exhaustive tables" in capsys.readouterr().err


def test_probe_rejects_an_unknown_terrain_field(tmp_path, capsys):
    params, candidates = tmp_path / "params.yaml", tmp_path / "candidates.yaml"
    params.write_text(TINY)
    candidates.write_text("tall: {height: 0.4}\n")
    assert main(["modular", "probe", "--candidates", str(candidates), "--terrain-seed", "4",
                 "--out", str(tmp_path / "probe.csv"), "--params", str(params)]) == 2
    assert "tall.height: unknown terrain field" in capsys.readouterr().err
    assert not (tmp_path / "probe.csv").exists()

def test_ga_on_a_dask_cluster_finds_what_local_processes_find(tmp_path, capsys, dask_address):
    params = tmp_path / "params.yaml"
    params.write_text(TINY)
    outs = []
    for where in (["--workers", "2"], ["--address", dask_address]):
        assert main(["modular", "ga", "--variant", "random", "--terrain-seed", "3", "--seed", "1",
                     "--params", str(params), *where]) == 0
        outs.append(json.loads(capsys.readouterr().out))
    keys = ("best_design", "best_fitness", "distinct", "evaluations")
    assert [outs[0][k] for k in keys] == [outs[1][k] for k in keys]
