"""Command-line argument types: checked while argparse parses, so a bad flag fails before any work.

`Parser` (the `robocompose` parser and every sub-parser) reports a failed check as one line,
`robocompose: error: argument --flag: <message>`, and exits 2; the usage block is printed only for --help.
`output_file` and `output_directory` check where a command will write before it computes anything: not a
directory (a file), the extension of the format it writes, a parent that is (or can become) a directory, names
the file system accepts, and a location this process can write in (`check_writable`). Checking creates nothing.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from robocompose.io.errors import INPUT_ERROR_EXIT, InputError, error_line

PATH_MAX = 4096  # Linux's limit on a whole path, in bytes
ATOMIC_EXTRA = 22  # bytes robocompose.io.atomic adds to a file's name while writing it: ".NAME.<pid>.<8 hex>.tmp"


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line `robocompose: error: <message>` and exit code 2 (argparse's
    own prints the usage block first). Sub-parsers made by `add_subparsers` are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(INPUT_ERROR_EXIT, error_line(self.prog.split()[0], InputError(message)) + "\n")


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


def _short(name: str, keep: int = 40) -> str:
    return name if len(name) <= keep else f"{name[:keep]}..."


def check_names(path: Path, names: tuple[str, ...] = (), atomic: bool = True) -> tuple[Path, Path]:
    """The absolute `path` and its nearest existing ancestor (or itself), if every name to be created (the missing
    parts of `path`, `names` beside it) fits the file system there; else InputError. Touches no file, so it is
    safe first: a name over NAME_MAX makes even `Path.exists` fail."""
    absolute = Path(os.path.abspath(path))
    existing = next(p for p in (absolute, *absolute.parents) if os.path.lexists(p))
    folder = existing if existing.is_dir() else existing.parent
    try:
        name_max = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    files = (absolute.name, *names) if atomic else names
    for name in (*absolute.relative_to(existing).parts, *names):
        allowed = name_max - (ATOMIC_EXTRA if name in files else 0)
        if len(os.fsencode(name)) > allowed:
            limit = (f"the file system allows {name_max}, less {ATOMIC_EXTRA} for the temporary name it is "
                     "written under" if allowed < name_max else "the file system's limit")
            where = absolute.parent if name in files or name == absolute.name else existing
            raise InputError(f"{where / _short(name)}: a name of {len(os.fsencode(name))} bytes, expected "
                             f"at most {allowed} ({limit})")
    return absolute, existing


def check_writable(path: Path, names: tuple[str, ...] = (), atomic: bool = True) -> Path:
    """`path` if this process can create it (and `names`, files beside it): every name fits the file system
    (NAME_MAX, with room for the temporary name an atomic write uses; PATH_MAX), the nearest existing ancestor is a
    directory in which a file can be created (tried with a temporary file, removed at once), an existing `path` is
    writable. Else InputError naming `path` and why. `atomic`: `path` is a file written under a temporary name.

    Nothing is left behind: missing directories are not made here (the command makes them when it writes)."""
    absolute, existing = check_names(path, names, atomic)
    if existing == absolute and not absolute.is_dir():  # a file the command replaces
        if not os.access(absolute, os.W_OK):
            raise InputError(f"{path}: not writable (permission denied)")
        existing = absolute.parent
    if not existing.is_dir():
        raise InputError(f"{path}: {existing} is a file, expected a directory")
    if len(os.fsencode(str(absolute))) + ATOMIC_EXTRA >= PATH_MAX:
        raise InputError(f"{_short(str(path), 80)}: a path of {len(os.fsencode(str(absolute)))} bytes, expected "
                         f"fewer than {PATH_MAX - ATOMIC_EXTRA}")
    try:
        descriptor, probe = tempfile.mkstemp(prefix=".robocompose-write-check-", dir=existing)
        os.close(descriptor)
        os.unlink(probe)
    except OSError as err:
        raise InputError(f"{path}: cannot create files in {existing} ({err.strerror or type(err).__name__})") from None
    return path


def check_output_file(path: Path, suffix: str, what: str, beside: tuple[str, ...] = ()) -> Path:
    """`path` if a `what` file (extension `suffix`) can be written there; else InputError saying why.

    `beside`: endings of companion files written next to it (`<stem><ending>`), whose names are checked too."""
    if os.path.isdir(path):
        raise InputError(f"{path}: is a directory, expected a file name ending in {suffix}")
    if path.suffix.lower() != suffix:
        raise InputError(f"{path}: expected a {suffix} file name (it is written as {what})")
    beside = tuple(f"{path.stem}{ending}" for ending in beside)
    check_names(path, beside)
    parent = next((p for p in path.parents if p.exists()), Path("."))
    if not parent.is_dir():
        raise InputError(f"{path}: {parent} is not a directory")
    return check_writable(path, beside)


def output_file(suffix: str, what: str, beside: tuple[str, ...] = ()) -> Callable[[str], Path]:
    """argparse type of an output path that must end in `suffix` (e.g. ".png"), not be a directory, and be
    writable (`check_output_file`; `beside`: endings of its companion files)."""
    def parse(text: str) -> Path:
        try:
            return check_output_file(Path(text), suffix, what, beside)
        except InputError as err:
            raise argparse.ArgumentTypeError(str(err)) from None

    parse.__name__ = f"{suffix} file"
    return parse


def output_directory(text: str) -> Path:
    """argparse type of a directory a command writes into: absent (it is created) or a directory, not a file, and
    one this process can write in (`check_writable`)."""
    path = Path(text)
    try:
        check_names(path, atomic=False)
        blocking = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()), None)
        if blocking is not None:
            raise InputError(f"{path}: {blocking} is a file, expected a directory")
        return check_writable(path, atomic=False)
    except InputError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


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


def add_params_argument(parser: argparse.ArgumentParser) -> None:
    """--params: the params file a command reads its settings from (default params.yaml; must exist)."""
    parser.add_argument("--params", type=input_file("a params YAML file"), default=Path("params.yaml"),
                        help="the settings (default: params.yaml)")


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
