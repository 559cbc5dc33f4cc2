"""Running a DVC stage script: bad input ends it with one clear line, not a traceback."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path


def run_stage(main: Callable[[], None]) -> None:
    """Call a stage's `main`; a ValueError/FileNotFoundError (bad params or artifacts) exits 1 with its message."""
    name = Path(sys.argv[0]).stem
    try:
        main()
    except (ValueError, FileNotFoundError) as err:
        print(f"stage {name}: error: {err}", file=sys.stderr)
        sys.exit(1)
