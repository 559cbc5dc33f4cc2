import hashlib
import math
import os
import pickle
import warnings

import pytest
import torch

from robocompose.io import ArtifactError, InputError
from robocompose.io.checkpoint import load_checkpoint, save_checkpoint

KEY = "0123456789abcdef"


class Marker:
    """Unpickling this creates the file at `path` (what a crafted checkpoint would do instead, e.g. rm -rf)."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return os.system, (f"touch {self.path}",)


def test_a_checkpoint_round_trips_and_its_bytes_depend_only_on_key_and_state(tmp_path):
    state = {"step": 3, "model": {"w": torch.arange(4.0)}, "rows": [{"step": 3, "loss": 0.5}]}
    a, b = save_checkpoint(tmp_path / "a.pt", KEY, state), save_checkpoint(tmp_path / "other_name.pt", KEY, state)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes().startswith(b"robocompose-checkpoint torch " + KEY.encode() + b" ")
    loaded = load_checkpoint(a, KEY)
    assert torch.equal(loaded["model"]["w"], state["model"]["w"]) and loaded["rows"] == state["rows"]


def test_a_json_checkpoint_round_trips_plain_rows_exactly(tmp_path):
    rows = [{"step": 0, "design_id": "ab12", "latent": [0.1, -2.5e-17, 1 / 3], "reward": None, "repeat": False,
             "best_so_far": float("nan"), "score": -2}, {"step": 1, "rules": [3, 1], "score": 4.000000000000001}]
    a, b = (save_checkpoint(tmp_path / name, KEY, rows, kind="json") for name in ("a.ckpt", "b.ckpt"))
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes().startswith(b"robocompose-checkpoint json " + KEY.encode() + b" ")
    loaded = load_checkpoint(a, KEY)
    assert math.isnan(loaded[0].pop("best_so_far")) and math.isnan(rows[0].pop("best_so_far"))
    assert loaded == rows and type(loaded[0]["score"]) is int and loaded[0]["latent"][2] == 1 / 3  # floats exact
    with pytest.raises(ValueError, match="checkpoint format 'pickle'"):
        save_checkpoint(tmp_path / "p.ckpt", KEY, rows, kind="pickle")


def test_no_file_means_no_checkpoint(tmp_path):
    assert load_checkpoint(tmp_path / "missing.pt", KEY) is None and load_checkpoint(None, KEY) is None
    assert load_checkpoint(tmp_path / "missing.pt", KEY, named=True) is None  # a new file: the run writes it


def test_a_checkpoint_of_another_key_is_ignored_with_a_warning_or_refused_when_named(tmp_path):
    path = save_checkpoint(tmp_path / "ck.pt", "fedcba9876543210", {"step": 1})
    with pytest.warns(UserWarning, match="a checkpoint of another run or other code .*starting afresh"):
        assert load_checkpoint(path, KEY) is None
    with pytest.raises(InputError, match=f"{path}: a checkpoint of another run"):
        load_checkpoint(path, KEY, named=True)


@pytest.mark.parametrize("content", [b"hello, I am a text file\n", b"", b"x" * 10_000, pickle.dumps({"step": 1})])
def test_a_file_that_is_not_a_checkpoint_is_one_clear_line(tmp_path, content):
    path = tmp_path / "ck.pt"
    path.write_bytes(content)
    with pytest.raises(InputError, match=f"{path}: not a robocompose checkpoint") as error:
        load_checkpoint(path, KEY, named=True)
    assert "\n" not in str(error.value)
    with pytest.warns(UserWarning, match="not a robocompose checkpoint"):
        assert load_checkpoint(path, KEY) is None
    assert path.read_bytes() == content  # left alone until the fresh run overwrites it


def test_a_directory_is_one_clear_line(tmp_path):
    with pytest.raises(InputError, match="is a directory"):
        load_checkpoint(tmp_path, KEY)


def test_a_crafted_pickle_never_runs(tmp_path):
    """A pickle whose __reduce__ runs a command: as a bare file, behind a header of another key, behind a right
    header with a forged payload hash, and (issue 43: the key is no secret) behind a header with the right key
    and the right hash, as the former pickle format or claiming a torch or JSON payload. Named, each is one line
    naming the file; as the project's own checkpoint, each is set aside, ignored or refused; none is run."""
    marker = tmp_path / "marker"
    payload = pickle.dumps(Marker(marker))
    digest = hashlib.sha256(payload).hexdigest()
    files = {"bare": (payload, "not a robocompose checkpoint"),
             "other_key": (f"robocompose-checkpoint json fedcba9876543210 {digest}\n".encode() + payload,
                           "a checkpoint of another run"),
             "bad_hash": (f"robocompose-checkpoint json {KEY} {'0' * 64}\n".encode() + payload, "checksum mismatch"),
             "pickle_format": (f"robocompose-checkpoint pickle {KEY} {digest}\n".encode() + payload,
                               "a checkpoint in the pickle format, which is not read"),
             "torch_claimed": (f"robocompose-checkpoint torch {KEY} {digest}\n".encode() + payload,
                               "holds Python objects other than tensors"),
             "json_claimed": (f"robocompose-checkpoint json {KEY} {digest}\n".encode() + payload,
                              "JSON payload does not parse")}
    for name, (data, reason) in files.items():
        path = tmp_path / f"{name}.ckpt"
        path.write_bytes(data)
        with pytest.raises(InputError) as error:  # ArtifactError is an InputError: one line naming the file
            load_checkpoint(path, KEY, named=True)
        assert str(error.value).startswith(f"{path}: ") and reason in str(error.value), name
        assert "\n" not in str(error.value)
        try:
            with warnings.catch_warnings(record=True):
                assert load_checkpoint(path, KEY) is None
        except ArtifactError as unloadable:  # the right key and hash, a payload that is not plain data
            assert name in ("torch_claimed", "json_claimed") and reason in str(unloadable)
        assert not marker.exists(), name
    pickle.loads(payload)  # the control: this payload does run its command when unpickled
    assert marker.exists()


def test_a_damaged_checkpoint_is_moved_aside_or_refused_when_named(tmp_path):
    path = save_checkpoint(tmp_path / "ck.pt", KEY, {"w": torch.zeros(1000)})
    data = bytearray(path.read_bytes())
    data[len(data) * 3 // 4] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(ArtifactError, match=f"{path}: checksum mismatch"):
        load_checkpoint(path, KEY, named=True)
    with pytest.warns(UserWarning, match="checksum mismatch"):
        assert load_checkpoint(path, KEY) is None
    assert (tmp_path / "ck.pt.corrupt").exists() and not path.exists()
