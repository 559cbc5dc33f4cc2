import argparse
import socket
import time

import pytest

from robocompose.arguments import add_compute_arguments
from robocompose.fanout.compute import ComputeConfig
from robocompose.io.errors import InputError
from robocompose.params import build_config, load_section


def closed_port() -> int:
    """A loopback port nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_compute_section_is_built_and_checked(tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("compute: {workers: 2, address: 'tcp://10.0.0.5:8786', cache: ''}\n")
    compute = load_section(ComputeConfig, "compute", params)
    assert compute == ComputeConfig(workers=2, address="tcp://10.0.0.5:8786", cache="")
    assert compute.open_cache().path is None  # "" = memory only
    for values, message in [({"workers": -1}, "compute.workers: expected an integer >= 0"),
                            ({"address": "10.0.0.5"}, "compute.address: expected a Dask scheduler address like "
                                                      "tcp://host:8786, found '10.0.0.5'"),
                            ({"adress": ""}, "compute.adress: unknown field")]:
        with pytest.raises(InputError, match=message):
            build_config(ComputeConfig, values, "params.yaml: compute")


def test_a_cache_path_naming_a_directory_is_refused_never_set_aside(tmp_path):
    from robocompose.fanout.cache import EvaluationCache

    folder = tmp_path / "cache"
    folder.mkdir()
    with pytest.raises(InputError, match=f"cache: expected a parquet file or a path not yet taken .*found '{folder}', "
                                         "a directory"):
        ComputeConfig(cache=str(folder))
    with pytest.raises(InputError, match="the evaluation cache is not a file"):
        EvaluationCache(folder)
    assert folder.is_dir() and not list(tmp_path.glob("*.corrupt"))


def test_command_line_flags_override_the_section():
    parser = argparse.ArgumentParser()
    add_compute_arguments(parser)
    base = ComputeConfig(workers=3, address="tcp://a:1")
    assert base.overridden(parser.parse_args([])) == base
    assert base.overridden(parser.parse_args(["--workers", "1", "--address", ""])) == ComputeConfig(workers=1)
    with pytest.raises(SystemExit):
        parser.parse_args(["--address", "nonsense"])  # argparse's one line, exit 2


@pytest.mark.exclusive
def test_an_unreachable_address_in_the_section_fails_within_ten_seconds_with_one_line():
    compute = ComputeConfig(address=f"tcp://127.0.0.1:{closed_port()}")
    started = time.perf_counter()
    with pytest.raises(InputError, match=f"no Dask scheduler answered at '{compute.address}'") as error:
        compute.executor()
    assert time.perf_counter() - started < 10 and "\n" not in str(error.value)
