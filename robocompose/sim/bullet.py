"""pybullet without its banner: `from robocompose.sim.bullet import pb` wherever the project uses pybullet.

Importing pybullet prints `pybullet build time: ...` from C straight to file descriptor 2, so a command's one
error line would come after it. Here it is imported once with descriptors 1 and 2 pointed at /dev/null (at the OS
level, where the C code writes); later imports find it in sys.modules and print nothing.
"""

from __future__ import annotations

import os
import sys
from types import ModuleType


def quiet_import() -> ModuleType:
    """The pybullet module, imported (the first time) with its banner sent to /dev/null."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        import pybullet
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for descriptor in (*saved, null):
            os.close(descriptor)
    return pybullet


pb = quiet_import()
