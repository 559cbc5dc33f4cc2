"""Command-line argument types: checked while argparse parses, so a bad flag fails before any work.

argparse reports a failed check as `usage: ...` + `PROG: error: argument --flag: <message>` and exits 2.
`output_file` checks where a command will write before it computes anything: not a directory, the
extension of the format it writes, a parent that is (or can become) a directory.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from robocompose.io.errors import InputError


def int_at_least(minimum: int) -> Callable[[str], int]:
    """argparse type of an integer >= `minimum`."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, found {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, found {value}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


def int_between(minimum: int, maximum: int, why: str = "") -> Callable[[str], int]:
    """argparse type of an integer in [minimum, maximum]; `why` (e.g. "about 2 GB") says what the limit guards."""
    at_least = int_at_least(minimum)

    def parse(text: str) -> int:
        value = at_least(text)
        if value > maximum:
            reason = f" ({why})" if why else ""
            raise argparse.ArgumentTypeError(f"expected an integer from {minimum} to {maximum:,}{reason}, "
                                             f"found {value}")
        return value

    parse.__name__ = f"integer in [{minimum}, {maximum}]"
    return parse


non_negative_int = int_at_least(0)  # seeds, counts that may be zero
positive_int = int_at_least(1)


def check_output_file(path: Path, suffix: str, what: str) -> Path:
    """`path` if a `what` file (extension `suffix`) can be written there; else InputError saying why."""
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected a file name ending in {suffix}")
    if path.suffix.lower() != suffix:
        raise InputError(f"{path}: expected a {suffix} file name (it is written as {what})")
    parent = next((p for p in path.parents if p.exists()), Path("."))
    if not parent.is_dir():
        raise InputError(f"{path}: {parent} is not a directory")
    return path


def output_file(suffix: str, what: str) -> Callable[[str], Path]:
    """argparse type of an output path that must end in `suffix` (e.g. ".png") and not be a directory."""
    def parse(text: str) -> Path:
        try:
            return check_output_file(Path(text), suffix, what)
        except InputError as err:
            raise argparse.ArgumentTypeError(str(err)) from None

    parse.__name__ = f"{suffix} file"
    return parse


def output_directory(text: str) -> Path:
    """argparse type of a directory a command writes into: absent (it is created) or a directory, not a file."""
    path = Path(text)
    blocking = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise argparse.ArgumentTypeError(f"{path}: {blocking} is a file, expected a directory")
    return path


def input_file(what: str) -> Callable[[str], Path]:
    """argparse type of a file that must exist (a model, a label PNG)."""
    def parse(text: str) -> Path:
        path = Path(text)
        if not path.is_file():
            found = "a directory" if path.is_dir() else "no such file"
            raise argparse.ArgumentTypeError(f"{path}: {found}, expected {what}")
        return path

    parse.__name__ = "file"
    return parse


def dask_address(text: str) -> str:
    """argparse type of a Dask scheduler address (tcp://host:8786), or "" for local processes."""
    from robocompose.fanout.executor import check_address

    try:
        return check_address(text) if text else text
    except InputError as err:
        raise argparse.ArgumentTypeError(str(err).removeprefix("address: ")) from None


def add_compute_arguments(parser: argparse.ArgumentParser) -> None:
    """--workers and --address: override the params' `compute:` section for one command (`ComputeConfig.overridden`)."""
    parser.add_argument("--workers", type=non_negative_int, default=None,
                        help="local processes (0 = all cores, 1 = here; default: compute.workers)")
    parser.add_argument("--address", type=dask_address, default=None,
                        help="a running Dask scheduler (tcp://host:8786) to fan out over "
                             "(default: compute.address; \"\" = local processes)")


def command_compute(args: argparse.Namespace, path: str | Path | None = None):
    """The `compute:` section a command fans out with (`robocompose.params.load_command_section`), overridden by
    its --workers and --address flags."""
    from robocompose.fanout.compute import ComputeConfig
    from robocompose.params import load_command_section

    return load_command_section(ComputeConfig, "compute", path).overridden(args)
