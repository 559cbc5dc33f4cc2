import pytest
import torch

from robocompose.io import ArtifactError
from robocompose.io.torch_file import load_torch, save_torch


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


def test_only_tensors_and_plain_data_load(tmp_path):
    path = save_torch({"f": torch.nn.Linear(1, 1)}, tmp_path / "module.pt")  # a pickled object, not weights
    with pytest.raises(ArtifactError, match=f"{path}: holds Python objects other than tensors"):
        load_torch(path)


def test_a_file_without_the_header_or_not_a_torch_archive_is_named(tmp_path):
    from robocompose.io import write_checked

    plain = tmp_path / "plain.pt"
    torch.save({"w": torch.zeros(2)}, plain)
    with pytest.raises(ArtifactError, match=f"{plain}: no checksum header"):
        load_torch(plain)
    junk = write_checked(tmp_path / "junk.pt", b"PK\x03\x04 checked, but a broken zip archive")
    with pytest.raises(ArtifactError, match=f"{junk}: damaged torch archive"):
        load_torch(junk)
