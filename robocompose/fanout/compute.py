"""The `compute:` section of params.yaml: where every stage and command fans out, and its evaluation cache.

    compute = load_section(ComputeConfig, "compute")        # robocompose.params
    compute = compute.overridden(args)                       # --workers / --address (arguments.py)
    with compute.executor("label") as executor:
        rows = evaluate_many(fn, items, key, compute.open_cache(), executor)
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

from robocompose.fanout.cache import DEFAULT_CACHE_PATH, EvaluationCache
from robocompose.fanout.executor import Executor, check_address
from robocompose.io.errors import InputError, check_field, shown


@dataclass(frozen=True)
class ComputeConfig:
    """The `compute:` section: local processes or a Dask scheduler, and the shared evaluation cache."""

    workers: int = 0  # local processes; 0 = all cores, 1 = in the calling process. No result depends on it
    address: str = ""  # a running Dask scheduler (tcp://host:8786) to fan out over; "" = local processes
    cache: str = str(DEFAULT_CACHE_PATH)  # the shared evaluation cache, not a DVC output ("" = memory only)

    def __post_init__(self) -> None:
        check_field(self.workers >= 0, "workers", "an integer >= 0 (0 = all cores)", self.workers)
        if self.address:
            check_address(self.address)
        if self.cache and Path(self.cache).exists() and not Path(self.cache).is_file():
            raise InputError(f'cache: expected a parquet file or a path not yet taken ("" = memory only), found '
                             f"{shown(self.cache)}, a directory")

    def executor(self, progress: str | None = None) -> Executor:
        """The executor these settings name; `progress` labels a progress bar of its maps."""
        return Executor(workers=self.workers, address=self.address, progress=progress)

    def open_cache(self) -> EvaluationCache:
        """The shared `eval_cache` table at `cache` (memory only if "")."""
        return EvaluationCache(self.cache or None)

    def overridden(self, args: argparse.Namespace) -> ComputeConfig:
        """These settings with the command line's --workers / --address (`add_compute_arguments`) where given."""
        flags = {name: getattr(args, name, None) for name in ("workers", "address")}
        return dataclasses.replace(self, **{name: value for name, value in flags.items() if value is not None})

