"""Running a DVC stage script: bad input ends it with one clear line and exit code 2, not a traceback."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from robocompose.io.errors import INPUT_ERROR_EXIT, InputError, error_line


def run_stage(main: Callable[[], None]) -> None:
    """Call a stage's `main`; an InputError (bad params or artifacts) prints `stage NAME: error: ...` and exits 2.

    Exit code 2 as for the `robocompose` command; any other exception is a bug and keeps its traceback.
    """
    try:
        main()
    except InputError as err:
        print(error_line(f"stage {Path(sys.argv[0]).stem}", err), file=sys.stderr)
        sys.exit(INPUT_ERROR_EXIT)
