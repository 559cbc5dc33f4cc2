import json

import pytest
import torch

from robocompose.cli import main
from robocompose.grammar.derivation import derive
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.io.torch_file import save_torch
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
    (["decode", "--z", "0.1,0.2"], "--z: expected 4 coordinates (the model's latent space), found 2"),
    (["decode", "--z", "a,b"], "--z: expected 4 comma-separated numbers, found 'a,b'"),
    (["decode", "--z", "nan,0,0,0"], "--z: expected finite numbers, found nan"),
    (["decode", "--z", "0,inf,0,0"], "--z: expected finite numbers, found inf"),
    (["sample", "--n", "0"], "argument --n: expected an integer >= 1, found 0"),
    (["sample", "--n", "1", "--seed", "-1"], "argument --seed: expected an integer >= 0, found -1"),
    (["encode", "--rules", "0,7,1"], "incomplete"),
])
def test_bad_input_names_the_problem(model_path, cli_error, argv, message):
    cli_error([*argv, "--model", model_path], message)


class Opaque:  # a pickled object that is not a tensor: weights_only=True refuses it
    pass


def _model_files(folder, model_path) -> dict:
    good = open(model_path, "rb").read()
    files = {"text.pt": b"hello\n", "truncated.pt": good[: len(good) // 2], "legacy.pt": b"\x80\x04K\x01."}
    for name, data in files.items():
        (folder / name).write_bytes(data)
    save_torch({"weights": torch.zeros(2)}, folder / "other_dict.pt")
    save_torch({"x": Opaque()}, folder / "object.pt")
    torch.save({"weights": torch.zeros(2)}, folder / "plain_torch.pt")  # a torch file without our checksum header
    return {"text.pt": "no checksum header", "truncated.pt": "checksum mismatch", "legacy.pt": "no checksum header",
            "plain_torch.pt": "no checksum header", "other_dict.pt": "not a robocompose model",
            "object.pt": "holds Python objects other than tensors"}


def test_every_bad_model_file_is_one_clear_error_naming_it(tmp_path, model_path, cli_error):
    for name, message in _model_files(tmp_path, model_path).items():
        line = cli_error(["sample", "--model", str(tmp_path / name), "--n", "1"], f"{tmp_path / name}: ", message)
        assert "weights_only=False" not in line


def test_missing_model_is_reported(tmp_path, cli_error):
    cli_error(["sample", "--model", str(tmp_path / "none.pt"), "--n", "1"], "argument --model", "none.pt: no such file")
