import json

import pytest

from robocompose.cli import main


@pytest.fixture
def params(tmp_path, tiny_models):
    import yaml

    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump({
        "glso": {"tasks": ["flat"], "seeds": [0], "budget": 9, "models": tiny_models, "bo": {"init": 2}},
        "evaluation": {"mppi": {"samples": 2, "first_samples": 2, "horizon": 2, "episode": 2}},
        "compute": {"cache": ""}}))
    return str(path)


def test_cli_prints_a_json_line_per_step_and_the_best_design_last(params, tiny_models, capsys):
    model = tiny_models.format(variant="full")
    assert main(["glso", "--task", "flat", "--method", "glso", "--budget", "3", "--seed", "0", "--model", model,
                 "--params", params]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    steps, best = lines[:-1], lines[-1]["best"]
    assert [s["step"] for s in steps] == [0, 1, 2]
    assert set(steps[0]) == {"step", "design_id", "rules", "score", "status", "best_so_far"}
    assert best["score"] == steps[-1]["best_so_far"] == max(s["score"] for s in steps)


@pytest.mark.parametrize("argv, message", [
    (["--method", "nelder_mead"], "--method: unknown method 'nelder_mead'"),
    (["--method", "mcts", "--model", "m.pt"], "--model: method mcts does not use a VAE"),
    (["--budget", "0"], "--budget: expected a positive number"),
    (["--task", "moon"], "moon"),
])
def test_cli_bad_input_exits_2_with_one_line(argv, message, params, capsys):
    assert main(["glso", "--params", params, *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_cli_runs_the_search_on_a_dask_worker_and_prints_what_a_local_run_prints(params, capsys, dask_address):
    argv = ["glso", "--task", "flat", "--method", "random", "--budget", "3", "--params", params]
    assert main(argv) == 0
    local = capsys.readouterr().out
    assert main([*argv, "--address", dask_address]) == 0
    assert capsys.readouterr().out == local and len(local.splitlines()) == 4
