"""Running a DVC stage script: the pinned CPU dispatch, and bad input ending it with one clear line and exit code 2."""

from __future__ import annotations

import inspect
import sys
from collections.abc import Callable
from pathlib import Path

from robocompose.io.dispatch import pin_dispatch
from robocompose.io.errors import INPUT_ERROR_EXIT, INTERRUPTED_EXIT, InputError, error_line, interrupted_line
from robocompose.io.quiet import quiet_pybullet

_VALUED_OPTIONS = ("-W", "-X", "--check-hash-based-pycs")  # interpreter options whose value is the next argument


def process_script() -> Path | None:
    """The script this interpreter was started with (`python [options] SCRIPT ...`); None for -m, -c or stdin.

    Read from sys.orig_argv, which no test patches and no runner (runpy, pytest) changes.
    """
    arguments = iter(sys.orig_argv[1:])
    for argument in arguments:
        if argument in _VALUED_OPTIONS:
            next(arguments, None)
        elif argument.startswith(("-c", "-m")) or argument == "-":
            return None
        elif not argument.startswith("-"):
            return Path(argument).resolve()
    return None


def run_stage(main: Callable[[], None]) -> None:
    """Call a stage's `main`; an InputError (bad params or artifacts) prints `stage NAME: error: ...` and exits 2.

    A process started for the stage script first re-executes itself with the pinned CPU dispatch (io.dispatch)
    unless it has it, so `dvc repro` and `python stages/x.py` give the same bytes on every machine.
    Exit code 2 as for the `robocompose` command; Ctrl-C prints `stage NAME: interrupted` and exits 130 (outputs
    are written atomically); any other exception is a bug and keeps its traceback.
    """
    if process_script() == Path(inspect.getsourcefile(main) or "").resolve():
        pin_dispatch()
    quiet_pybullet()  # before the stage imports it: nothing may come before a stage's one error line
    try:
        main()
    except InputError as err:
        print(error_line(f"stage {Path(sys.argv[0]).stem}", err), file=sys.stderr)
        sys.exit(INPUT_ERROR_EXIT)
    except KeyboardInterrupt:
        print(interrupted_line(f"stage {Path(sys.argv[0]).stem}"), file=sys.stderr)
        sys.exit(INTERRUPTED_EXIT)
