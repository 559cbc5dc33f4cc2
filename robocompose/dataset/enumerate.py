"""The GLSO dataset: random grammar derivations with rest-contact features, enumerated in parallel.

A candidate is kept as GLSO's `collect_data.py` keeps it: a uniform random derivation that completes
within 40 rules (`depth_limit`), has at least 11 links (`too_few_links`), and passes the rest-contact
rule of `sim.contacts` (`self_collision`, `unstable`, `too_few_contacts`, `midline_contact`); each
rejected candidate is counted under the first rule it fails. Unlike GLSO, designs are deduplicated by
design id (`duplicates`).

Candidate k is derived from its own random stream (seed, k), so which designs are kept depends only on
the seed, never on the number of workers: candidates are processed in chunks through the project's
executor (`robocompose.fanout`: local processes or a Dask cluster) and taken in index order until `n`
distinct valid designs are found.
"""

from __future__ import annotations

import gc
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from robocompose.fanout.executor import Executor
from robocompose.grammar.derivation import MAX_DEPTH, random_derivation
from robocompose.grammar.tree import DesignTree
from robocompose.io.errors import InputError

MIN_LINKS = 11  # the thesis keeps designs with at least 11 links
# Candidates in a row without a kept design before an enumeration gives up: the default profile keeps ~1 in 30
# (min_links 25: ~1 in 200); a min_links no derivation of max_depth rules reaches (40 rules make ~30 links at
# most) would otherwise loop forever. ~10 s on two cores.
MAX_BARREN = 5_000


@dataclass(frozen=True)
class EnumerateConfig:
    """Settings of one enumeration run."""

    n: int  # distinct valid designs to collect
    seed: int = 0  # base seed; candidate k uses the random stream (seed, k)
    min_links: int = MIN_LINKS  # smaller designs are rejected
    max_depth: int = MAX_DEPTH  # rule-sequence length limit of a derivation
    chunk: int = 64  # candidates per task sent to a worker

    def __post_init__(self) -> None:
        for name in ("n", "chunk", "min_links", "max_depth"):
            if getattr(self, name) < 1:
                raise InputError(f"{name} must be a positive integer, got {getattr(self, name)}")


@dataclass
class EnumerateStats:
    candidates: int = 0
    kept: int = 0
    duplicates: int = 0
    rejected: Counter = field(default_factory=Counter)  # rule -> candidates it rejected
    dropped_points: int = 0  # off-floor contact points dropped from kept designs
    designs_with_dropped_points: int = 0

    def as_dict(self) -> dict:
        return {"candidates": self.candidates, "kept": self.kept, "duplicates": self.duplicates,
                "rejected": dict(sorted(self.rejected.items())), "dropped_points": self.dropped_points,
                "designs_with_dropped_points": self.designs_with_dropped_points}


# A candidate's outcome: (reason, row, off-floor points dropped); reason "" means valid.
Outcome = tuple[str, dict | None, int]
_CLIENT: int | None = None


def _client() -> int:
    """One pybullet client per worker process, made on first use."""
    global _CLIENT
    if _CLIENT is None:
        from robocompose.sim.physics import connect

        _CLIENT = connect()
        # Derivation makes many short-lived objects, whose collections would rescan every imported module
        # (~20% of a worker's time): what exists now is long-lived, so the collector may skip it.
        gc.freeze()
    return _CLIENT


def design_row(tree: DesignTree, rules: tuple[int, ...], contacts: np.ndarray) -> dict:
    return {"design_id": tree.design_id, "rules": list(rules), "parents": list(tree.parents),
            "tokens": list(tree.tokens), "n_links": tree.n_links, "n_joints": tree.n_joints,
            "contacts": [float(x) for x in contacts]}


def candidate(seed: int, k: int, min_links: int, max_depth: int) -> Outcome:
    """Derive candidate k, filter it and measure its contacts."""
    from robocompose.sim.contacts import contact_features

    derivation = random_derivation(np.random.default_rng([seed, k]), max_depth)
    if derivation is None:
        return "depth_limit", None, 0
    tree = derivation.tree
    if tree.n_links < min_links:
        return "too_few_links", {"n_links": tree.n_links}, 0  # the links it had, for `collect`'s give-up message
    contacts = contact_features(tree, _client(), rest_self_penetrating=False)
    if not contacts.valid:
        return contacts.reason, None, 0
    return "", design_row(tree, derivation.rules, contacts.features), contacts.dropped


def _chunk(task: tuple[Callable[..., Outcome], int, int, int, tuple]) -> list[Outcome]:
    make, seed, start, stop, args = task
    return [make(seed, k, *args) for k in range(start, stop)]


def collect(make: Callable[..., Outcome], n: int, seed: int, args: tuple, executor: Executor, chunk: int,
            progress: str | None = None, give_up: Callable[[EnumerateStats, int], str] | None = None,
            max_barren: int = MAX_BARREN) -> tuple[pd.DataFrame, EnumerateStats]:
    """Run `make(seed, k, *args)` for k = 0, 1, ... through `executor`; keep the first `n` distinct
    valid rows in index order. `make` must be a module-level function (it is pickled).

    After `max_barren` candidates in a row without a kept row, InputError(`give_up(stats, most links seen)`):
    settings no candidate meets end with one line instead of running forever."""
    from tqdm import tqdm

    stats, rows, seen = EnumerateStats(), [], set()
    barren, most_links = 0, 0
    # no bar when stderr is no terminal (a log, a test): an error then stays the one line on stderr
    bar = tqdm(total=n, desc=progress, unit="design", disable=True if progress is None else None, mininterval=1.0)
    per_round = 4 * executor.workers if executor.backend != "dask" else 64

    def submit(round_index: int):
        first = round_index * per_round * chunk
        return executor.imap(_chunk, [(make, seed, first + i * chunk, first + (i + 1) * chunk, args)
                                      for i in range(per_round)])

    current, round_index = submit(0), 0
    while len(rows) < n:
        round_index += 1
        following = submit(round_index)  # queued now, so no worker idles while this round is read
        for reason, row, dropped in (outcome for batch in current for outcome in batch):
            if len(rows) == n:
                break
            stats.candidates += 1
            barren += 1
            if reason:
                stats.rejected[reason] += 1
                most_links = max(most_links, (row or {}).get("n_links", 0))
            elif row["design_id"] in seen:
                stats.duplicates += 1
            else:
                barren = 0
                seen.add(row["design_id"])
                rows.append(row)
                stats.dropped_points += dropped
                stats.designs_with_dropped_points += dropped > 0
                bar.update(1)
            if barren >= max_barren:
                bar.close()
                stats.kept = len(rows)
                raise InputError(give_up(stats, most_links) if give_up is not None else
                                 f"enumeration: no new valid design among {barren:,} candidates in a row")
        current = following
    bar.close()
    stats.kept = len(rows)
    return pd.DataFrame(rows), stats


def enumerate_designs(config: EnumerateConfig, executor: Executor | None = None,
                      progress: str | None = "enumerate") -> tuple[pd.DataFrame, EnumerateStats]:
    """`config.n` distinct valid grammar designs with their contact features, and run statistics
    (`executor` None: in this process)."""
    def give_up(stats: EnumerateStats, most_links: int) -> str:
        found = (f"no new valid design among the last {MAX_BARREN:,} candidates (kept so far: {stats.kept}; "
                 f"rejected: {dict(stats.rejected.most_common(3))})")
        if stats.rejected["depth_limit"] > stats.rejected["too_few_links"]:
            return (f"enumerate.max_depth: {config.max_depth} rules, expected enough for derivations to complete "
                    f"(the default is {MAX_DEPTH}); {found}")
        return (f"enumerate.min_links: {config.min_links} links, expected a size the grammar's derivations of at "
                f"most enumerate.max_depth={config.max_depth} rules reach (the most links of a rejected one: "
                f"{most_links}); {found}")

    return collect(candidate, config.n, config.seed, (config.min_links, config.max_depth),
                   executor or Executor(workers=1), config.chunk, progress, give_up)
