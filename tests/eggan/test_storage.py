import json

import pytest
import torch

from robocompose.eggan.storage import load_model, load_torch, save_model, save_torch
from robocompose.io import ArtifactError
from robocompose.io.errors import InputError


def test_round_trip_and_the_bytes_do_not_depend_on_the_file_name(tmp_path):
    obj = {"w": torch.arange(6.0).reshape(2, 3), "rows": [{"iteration": 1, "loss": 0.5}]}
    a, b = save_torch(obj, tmp_path / "a.pt"), save_torch(obj, tmp_path / "other_name.pt")
    assert a.read_bytes() == b.read_bytes()
    loaded = load_torch(a)
    assert torch.equal(loaded["w"], obj["w"]) and loaded["rows"] == obj["rows"]


@pytest.mark.parametrize("damage", ["flip", "cut"])
def test_a_flipped_or_cut_file_is_an_error_naming_it(tmp_path, damage):
    path = save_torch({"w": torch.zeros(1000)}, tmp_path / "m.pt")
    data = bytearray(path.read_bytes())
    if damage == "flip":
        data[len(data) * 3 // 4] ^= 0xFF  # inside the tensor data: torch.load alone reads it without complaint
    else:
        del data[len(data) // 2:]
    path.write_bytes(bytes(data))
    with pytest.raises(ArtifactError, match=f"{path}: checksum mismatch"):
        load_torch(path)


def test_only_tensors_and_plain_data_load_by_default(tmp_path):
    path = save_torch({"f": torch.nn.Linear(1, 1)}, tmp_path / "module.pt")  # a pickled object, not weights
    with pytest.raises(Exception, match="Weights only load failed"):
        load_torch(path)
    assert isinstance(load_torch(path, weights_only=False)["f"], torch.nn.Linear)


def test_a_model_file_holds_info_and_state_and_a_file_of_another_kind_is_refused(tmp_path):
    path = save_model({"problem": "toy", "hidden": 4}, {"w": torch.ones(2)}, tmp_path / "model.pt")
    info, state = load_model(path, "a toy model")
    assert info == json.loads((tmp_path / "model.json").read_text()) == {"problem": "toy", "hidden": 4}
    assert torch.equal(state["w"], torch.ones(2))
    other = save_torch({"weights": torch.ones(2)}, tmp_path / "other.pt")  # checked, but not a model file
    with pytest.raises(InputError, match=f"{other}: not a toy model file"):
        load_model(other, "a toy model")
    with pytest.raises(InputError, match="no such file"):
        load_model(tmp_path / "missing.pt", "a toy model")


def test_a_model_files_bytes_do_not_depend_on_which_equal_strings_are_one_object(tmp_path):
    """A run resumed from a checkpoint holds equal but distinct string objects where a straight run shares one;
    pickle's memo would write them differently, the file must not."""
    import copy

    from robocompose.eggan.storage import load_model, save_model

    key = "real_evaluations"
    shared = {key: 3, "final": {key: 3}}  # one string object twice
    distinct = {"".join(["real_", "evaluations"]): 3, "final": copy.deepcopy({"".join(["real_", "evaluations"]): 3})}
    state = {"w": torch.ones(2)}
    a, b = save_model(shared, state, tmp_path / "a.pt"), save_model(distinct, state, tmp_path / "b.pt")
    assert a.read_bytes() == b.read_bytes()
    assert load_model(a, "a test model")[0] == shared
