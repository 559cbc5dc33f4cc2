"""One executor interface for every evaluation fan-out: local processes, or an existing Dask cluster.

    from robocompose.evaluation.executor import Executor, evaluate_many
    with Executor(workers=0) as ex:                 # local processes (0 = all cores, 1 = in this process)
                                                    # progress="label": a tqdm bar for every map
        rewards = ex.map(fn, items)                 # results in item order
    with Executor(address="tcp://10.0.0.5:8786") as ex:   # a running dask.distributed scheduler
        rows = evaluate_many(fn, items, key=lambda item: item.key, cache=cache, executor=ex)

`fn` must be a module-level function (it is pickled to the workers) taking one item. An exception in
`fn` propagates to the caller: a failed evaluation is never turned into a score here. Functions that
can fail physically (a simulation blowing up) return that as their status instead.

`evaluate_many(fn, items, key, cache, executor, save_every)` evaluates only the items whose key is not
in the cache (each distinct key once), stores each result dict with `cache.put(key, **result)` as it
arrives (saving the cache every `save_every` new results, so a long run resumes where it stopped) and
returns the cached row of every item, in order. With the default `eval_cache` table the result dict is
{reward, status, sim_steps, seconds}; see `robocompose.evaluation.cache`.

Local workers are started from a fork server (clean processes, no inherited torch threads) and kept for
the executor's lifetime, so many small `map` calls (a BO loop) pay the start-up once. Results do not
depend on the backend or the number of workers: each item is evaluated on its own.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from robocompose.evaluation.cache import CacheKey, EvaluationCache
from robocompose.io.errors import InputError


class Executor:
    """Runs `fn(item)` for many items: in this process, on local processes, or on a Dask cluster."""

    def __init__(self, workers: int = 0, address: str | None = None, progress: str | None = None):
        """`progress`: a label; every map then shows a tqdm bar (on stderr) of the items done."""
        if workers < 0:
            raise InputError(f"executor: workers must be >= 0 (0 = all cores), got {workers}")
        self.address = address
        self.progress = progress
        self.workers = workers or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None
        self._client = None
        if address is not None:
            from dask.distributed import Client

            self._client = Client(address)

    @property
    def backend(self) -> str:
        return "dask" if self._client is not None else ("inline" if self.workers == 1 else "processes")

    def imap(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        """Results of `fn` over `items`, yielded in item order as they become available."""
        items = list(items)
        if not items:
            return iter(())
        if self.progress is None:
            return self._results(fn, items)
        from tqdm import tqdm

        return iter(tqdm(self._results(fn, items), total=len(items), desc=self.progress, unit="task",
                         mininterval=5.0))

    def _results(self, fn: Callable[[Any], Any], items: list[Any]) -> Iterator[Any]:
        if self._client is not None:
            futures = self._client.map(fn, items, pure=False)
            return (future.result() for future in futures)
        if self.workers == 1:
            return (fn(item) for item in items)
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("forkserver"))
        return self._pool.map(fn, items)

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
        """Results of `fn` over `items`, in item order."""
        return list(self.imap(fn, items))

    def close(self) -> None:
        """Stop the local workers / disconnect from the cluster (the cluster itself keeps running)."""
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def evaluate_many(fn: Callable[[Any], dict], items: Iterable[Any], key: Callable[[Any], CacheKey],
                  cache: EvaluationCache | None = None, executor: Executor | None = None,
                  save_every: int = 0) -> list[dict]:
    """The cache row of every item, evaluating with `fn` only the keys not yet cached (each once).

    `save_every` > 0 saves the cache after that many new results (and at the end); 0 saves at the end.
    """
    items = list(items)
    cache = EvaluationCache() if cache is None else cache
    keys = [tuple(key(item)) for item in items]
    missing: dict[CacheKey, Any] = {}
    for k, item in zip(keys, items, strict=True):
        if k not in cache and k not in missing:
            missing[k] = item
    own = executor is None and bool(missing)
    executor = Executor(workers=1) if executor is None else executor
    try:
        for done, (k, result) in enumerate(zip(missing, executor.imap(fn, missing.values()), strict=True), 1):
            cache.put(k, **result)
            if save_every and done % save_every == 0:
                cache.save()
    finally:  # keep what was evaluated, also when an evaluation raised
        if missing:
            cache.save()
        if own:
            executor.close()
    return [cache.get(k) for k in keys]
