"""pybullet without its banner: the entry points (`robocompose`, stage scripts, pool workers) import it here first.

Importing pybullet prints `pybullet build time: ...` from C straight to file descriptor 2, so a command's one
error line would come after it. `quiet_pybullet` imports it once with descriptors 1 and 2 pointed at /dev/null (at
the OS level, where the C code writes); the project's own `import pybullet` lines then find it in sys.modules and
print nothing. (Those lines stay as they are: the result digests that key committed tables read them.)
"""

from __future__ import annotations

import os
import sys


def quiet_pybullet() -> None:
    """Import pybullet (the first time) with its banner sent to /dev/null."""
    if "pybullet" in sys.modules:
        return
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        import pybullet  # noqa: F401
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for descriptor in (*saved, null):
            os.close(descriptor)
