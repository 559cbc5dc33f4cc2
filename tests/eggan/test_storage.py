import json

import pytest
import torch

from robocompose.eggan.storage import load_model, save_model
from robocompose.io.errors import InputError
from robocompose.io.torch_file import save_torch


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
