"""pybullet without its banner: once `quiet_pybullet()` has run, importing pybullet prints nothing.

Importing pybullet prints `pybullet build time: ...` from C straight to file descriptor 2, so a command's one
error line would come after it. `quiet_pybullet` puts a finder in front of the import system that loads pybullet,
when something imports it, with descriptors 1 and 2 pointed at /dev/null (at the OS level, where the C code
writes). It imports nothing itself, so `robocompose --help` stays light. The packages that import pybullet call it
in their `__init__`; the project's own `import pybullet` lines stay as they are (the result digests that key
committed tables read them).
"""

from __future__ import annotations

import contextlib
import importlib.abc
import importlib.util
import os
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def _silenced() -> Iterator[None]:
    """Descriptors 1 and 2 at /dev/null for the duration (what C code writes there is dropped)."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for descriptor in (*saved, null):
            os.close(descriptor)


class _QuietLoader(importlib.abc.Loader):
    def __init__(self, loader: importlib.abc.Loader):
        self.loader = loader

    def create_module(self, spec):  # an extension module runs its C initialiser (the banner) here
        with _silenced():
            return self.loader.create_module(spec)

    def exec_module(self, module) -> None:
        with _silenced():
            self.loader.exec_module(module)


class _QuietFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name != "pybullet":
            return None
        sys.meta_path.remove(self)  # the real spec, from the other finders
        try:
            spec = importlib.util.find_spec(name)
        finally:
            sys.meta_path.insert(0, self)
        if spec is not None and spec.loader is not None:
            spec.loader = _QuietLoader(spec.loader)
        return spec


def quiet_pybullet() -> None:
    """From now on pybullet imports without its banner (idempotent; imports nothing)."""
    if not any(isinstance(finder, _QuietFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _QuietFinder())
