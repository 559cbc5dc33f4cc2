import argparse
import re
from pathlib import Path

import pytest

from robocompose.arguments import (
    ATOMIC_EXTRA,
    check_output_file,
    check_writable,
    input_file,
    int_at_least,
    int_between,
    non_negative_int,
    output_directory,
    output_file,
)
from robocompose.io.errors import InputError


def test_integers_are_checked_against_their_minimum():
    assert non_negative_int("0") == 0 and int_at_least(2)("2") == 2
    for parse, text, message in [(non_negative_int, "-1", "expected an integer >= 0, found -1"),
                                 (int_at_least(2), "1", "expected an integer >= 2, found 1"),
                                 (non_negative_int, "1.5", "expected an integer, found '1.5'")]:
        with pytest.raises(argparse.ArgumentTypeError, match=message.replace(".", r"\.")):
            parse(text)


def test_output_file_needs_the_format_extension_and_a_file_name(tmp_path):
    assert check_output_file(tmp_path / "new" / "x.PNG", ".png", "PNG") == tmp_path / "new" / "x.PNG"
    with pytest.raises(InputError, match=r"x\.jpg: expected a \.png file name \(it is written as PNG\)"):
        check_output_file(tmp_path / "x.jpg", ".png", "PNG")
    (tmp_path / "d.png").mkdir()
    with pytest.raises(InputError, match="is a directory"):
        check_output_file(tmp_path / "d.png", ".png", "PNG")
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="is not a directory"):
        check_output_file(tmp_path / "file" / "x.png", ".png", "PNG")
    with pytest.raises(argparse.ArgumentTypeError, match="expected a .mcap file name"):
        output_file(".mcap", "MCAP")(str(tmp_path / "x.json"))
    assert not (tmp_path / "new").exists()  # checking creates nothing


def test_input_file_must_exist_and_be_a_file(tmp_path):
    parse = input_file("a trained VAE")
    with pytest.raises(argparse.ArgumentTypeError, match="none.pt: no such file, expected a trained VAE"):
        parse(str(tmp_path / "none.pt"))
    with pytest.raises(argparse.ArgumentTypeError, match="a directory, expected a trained VAE"):
        parse(str(tmp_path))
    (tmp_path / "m.pt").write_bytes(b"x")
    assert parse(str(tmp_path / "m.pt")) == tmp_path / "m.pt"


def test_output_directory_may_be_new_but_not_a_file(tmp_path):
    assert output_directory(str(tmp_path / "new" / "dir")) == tmp_path / "new" / "dir"
    (tmp_path / "file").write_text("")
    for text in (tmp_path / "file", tmp_path / "file" / "sub"):
        with pytest.raises(argparse.ArgumentTypeError, match="file is a file, expected a directory"):
            output_directory(str(text))


def test_an_output_location_is_proven_writable_and_nothing_is_left_behind(tmp_path):
    (tmp_path / "old.png").write_bytes(b"kept")
    assert check_output_file(tmp_path / "old.png", ".png", "PNG") == tmp_path / "old.png"  # replaced later: fine
    assert check_writable(tmp_path / "new" / "deeper" / "x.png") == tmp_path / "new" / "deeper" / "x.png"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.png"] and (tmp_path / "old.png").read_bytes() == b"kept"
    for folder in ("/proc", "/sys"):  # root may write anywhere else; no file can be created in these
        with pytest.raises(InputError, match=f"{folder}/x.png: cannot create files in {folder}"):
            check_output_file(Path(folder) / "x.png", ".png", "PNG")
    with pytest.raises(argparse.ArgumentTypeError, match="/proc/tables: cannot create files in /proc"):
        output_directory("/proc/tables")


def test_names_must_fit_the_file_system_with_room_for_the_temporary_name(tmp_path):
    fits = "a" * (255 - ATOMIC_EXTRA - 4) + ".png"
    assert check_output_file(tmp_path / fits, ".png", "PNG") == tmp_path / fits
    with pytest.raises(InputError, match=f"a name of 256 bytes, expected at most {255 - ATOMIC_EXTRA}"):
        check_output_file(tmp_path / ("a" * 252 + ".png"), ".png", "PNG")
    with pytest.raises(InputError, match="a name of 300 bytes, expected at most 255 \\(the file system's limit\\)"):
        check_output_file(tmp_path / ("d" * 300) / "x.png", ".png", "PNG")
    with pytest.raises(InputError, match="a name of 236 bytes"):  # the companion <stem>_criterion.csv
        check_output_file(tmp_path / ("p" * 222 + ".csv"), ".csv", "CSV", beside=("_criterion.csv",))
    with pytest.raises(argparse.ArgumentTypeError, match="a name of 300 bytes"):
        output_directory(str(tmp_path / ("e" * 300)))
    assert list(tmp_path.iterdir()) == []


def test_a_bounded_integer_states_its_limit():
    parse = int_between(1, 100_000, "about 2 GB")
    assert parse("1") == 1 and parse("100000") == 100_000
    for text, message in [("0", "expected an integer >= 1, found 0"), ("x", "expected an integer, found 'x'"),
                          ("100001", "expected an integer from 1 to 100,000 (about 2 GB), found 100001")]:
        with pytest.raises(argparse.ArgumentTypeError, match=re.escape(message)):
            parse(text)
