import json

import pytest
import torch

from robocompose.cli import main
from robocompose.evaluation.references import REFERENCE_DESIGNS
from robocompose.grammar.derivation import derive
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import save_model


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    torch.manual_seed(0)
    return str(save_model(GraphVAE(VAEConfig(hidden=16, latent=4, max_nodes=30)),
                          tmp_path_factory.mktemp("m") / "vae.pt"))


def _lines(capsys) -> list[dict]:
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_sample_prints_designs_whose_rules_derive_them(model_path, capsys):
    assert main(["sample", "--model", model_path, "--n", "5", "--seed", "3"]) == 0
    designs = _lines(capsys)
    assert len(designs) == 5
    for d in designs:
        assert derive(d["rules"]).tree.design_id == d["design_id"]
    assert main(["sample", "--model", model_path, "--n", "5", "--seed", "3"]) == 0
    assert _lines(capsys) == designs  # seeded


def test_encode_then_decode_round_trips_through_the_cli(model_path, capsys):
    rules = REFERENCE_DESIGNS["robogrammar_flat"]
    assert main(["encode", "--model", model_path, "--rules", rules]) == 0
    encoded = _lines(capsys)[0]
    assert encoded["design_id"] == derive([int(r) for r in rules.split(",")]).tree.design_id
    assert len(encoded["z"]) == 4
    assert main(["decode", "--model", model_path, "--z=" + ",".join(map(str, encoded["z"]))]) == 0  # may start with -
    decoded = _lines(capsys)[0]
    assert derive(decoded["rules"]).tree.design_id == decoded["design_id"]


@pytest.mark.parametrize(("argv", "message"), [
    (["decode", "--z", "0.1,0.2"], "latent space has 4"),
    (["decode", "--z", "a,b"], "comma-separated numbers"),
    (["sample", "--n", "0"], "positive integer"),
    (["encode", "--rules", "0,7,1"], "incomplete"),
])
def test_bad_input_names_the_problem(model_path, capsys, argv, message):
    assert main([*argv, "--model", model_path]) == 2
    assert message in capsys.readouterr().err


def test_missing_model_is_reported(tmp_path, capsys):
    assert main(["sample", "--model", str(tmp_path / "none.pt"), "--n", "1"]) == 2
    assert "no such model file" in capsys.readouterr().err
