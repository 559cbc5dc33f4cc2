"""One executor interface for every evaluation fan-out: local processes, or an existing Dask cluster.

    from robocompose.fanout.executor import Executor, evaluate_many
    with Executor(workers=0) as ex:                 # local processes (0 = all cores, 1 = in this process)
        rewards = ex.map(fn, items)                 # results in item order; progress="label": a tqdm bar
        for index, reward in ex.as_completed(fn, items): ...   # (item index, result) as each finishes
    with Executor(address="tcp://10.0.0.5:8786") as ex:   # a running dask.distributed scheduler
        rows = evaluate_many(fn, items, key=lambda item: item.key, cache=cache, executor=ex)

`fn` must be a module-level function (it is pickled to the workers) taking one item. An exception in
`fn` propagates to the caller: a failed evaluation is never turned into a score here.

Results are taken as they finish on every backend (`as_completed`; Dask's `distributed.as_completed`), so one
slow item holds up neither the progress bar nor the handling of items finished after it; `map` and `imap`
then put them back in item order, so what a caller builds from them does not depend on the backend.

`evaluate_many` is every world's cached objective: it evaluates only the items whose key is not in the
cache (each distinct key once), stores each result dict with `cache.put(key, **result)` as it arrives
(saving every `save_every` new results, so a long run resumes) and returns the cached row of every item.
`batch` > 0 hands `fn` lists of up to `batch` missing items (an evaluator that batches, e.g. torch).

A malformed address, or one where no scheduler answers within `CONNECT_TIMEOUT` seconds, is an InputError.
Local workers come from a fork server (clean processes, no inherited torch threads) and live as long as the
executor, or until the process that made it is gone: a killed caller runs no shutdown, and its fork server outlives
it, so each worker watches its owner (`_watch_owner`) and exits within `OWNER_POLL` seconds of its end instead of
computing the queued items on and then waiting forever. Results do not depend on the backend or the number of
workers: each item is evaluated on its own.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
import re
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from robocompose.fanout.cache import CacheKey, EvaluationCache
from robocompose.io.errors import InputError
from robocompose.io.quiet import quiet_pybullet

CONNECT_TIMEOUT = 5  # seconds to wait for a Dask scheduler to answer
OWNER_POLL = 0.5  # seconds between a local worker's checks that the process owning its pool is still there
ADDRESS_EXAMPLE = "tcp://host:8786"
_ADDRESS = re.compile(r"(tcp|tls|ucx|ws|wss)://(\[[0-9a-fA-F:]+\]|[^\s:/\[\]]+):(\d{1,5})")


def check_address(address: str) -> str:
    """`address` if it has the form of a Dask scheduler address (scheme://host:port); else InputError."""
    match = _ADDRESS.fullmatch(address)
    if match is None or not 0 < int(match.group(3)) < 65536:
        raise InputError(f"address: expected a Dask scheduler address like {ADDRESS_EXAMPLE}, found {address!r}")
    return address


def connect(address: str):
    """A dask.distributed Client of the scheduler at `address`; InputError within CONNECT_TIMEOUT (+ the Client's
    own start) if no Dask scheduler answers there: nothing listening, a silent socket, another kind of server."""
    check_address(address)
    _probe_scheduler(address)
    from dask.distributed import Client

    try:
        return Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as err:
        raise _no_scheduler(address, err) from None


def _no_scheduler(address: str, err: BaseException) -> InputError:
    reason = "no answer" if isinstance(err, TimeoutError) else f"{type(err).__name__}"
    return InputError(f"address: no Dask scheduler answered at {address!r} within {CONNECT_TIMEOUT} s ({reason}); "
                      f"expected a running scheduler like {ADDRESS_EXAMPLE}")


def _probe_scheduler(address: str) -> None:
    """Ask whoever listens at `address` who it is (Dask's handshake, then `identity`), all within CONNECT_TIMEOUT.

    dask's Client bounds each step by its timeout but retries a failed handshake and waits once more per step: a
    silent listener held it ~80 s, an HTTP server ~5 minutes. This probe has one overall deadline, in a thread
    of its own (an event loop of its own, whatever the caller runs)."""
    import asyncio
    import threading

    outcome: list[BaseException | str] = []

    async def ask() -> str:
        from distributed.comm import connect as open_comm

        comm = await open_comm(address, timeout=CONNECT_TIMEOUT)
        try:
            await comm.write({"op": "identity", "reply": True})
            answer = await comm.read()
        finally:
            comm.abort()
        return answer.get("type", "") if isinstance(answer, dict) else ""

    def run() -> None:
        try:
            outcome.append(asyncio.run(asyncio.wait_for(ask(), CONNECT_TIMEOUT)))
        except BaseException as err:  # noqa: BLE001 - any failure means: no scheduler there
            outcome.append(err)

    thread = threading.Thread(target=run, name="dask-probe", daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT + 2)
    if not outcome:
        raise _no_scheduler(address, TimeoutError())
    if isinstance(outcome[0], BaseException):
        raise _no_scheduler(address, outcome[0])
    if outcome[0] != "Scheduler":
        raise InputError(f"address: {address!r} answered as {outcome[0] or 'something else'!r}, not a Dask "
                         f"scheduler; expected a running scheduler like {ADDRESS_EXAMPLE}")


def _alive(pid: int) -> bool:
    """Whether process `pid` is running and ours: not gone, not another user's (the number reused), not a zombie."""
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):
        return False
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:  # no /proc (not Linux): the signal said it is there
        return True


def _watch_owner(owner: int) -> None:
    """Exit this worker at once (no cleanup: its owner, which would read the results, is gone) when `owner` ends."""
    while _alive(owner):
        time.sleep(OWNER_POLL)
    os._exit(1)


def _start_worker(owner: int) -> None:
    """A local worker's start: pybullet without its banner, and a daemon thread watching the pool's owner."""
    quiet_pybullet()
    threading.Thread(target=_watch_owner, args=(owner,), name="owner-watch", daemon=True).start()


class Executor:
    """Runs `fn(item)` for many items: in this process, on local processes, or on a Dask cluster."""

    def __init__(self, workers: int = 0, address: str | None = None, progress: str | None = None):
        """`address` "" or None: local; `progress`: a label, every map then shows a tqdm bar (on stderr)."""
        if workers < 0:
            raise InputError(f"executor: workers must be >= 0 (0 = all cores), got {workers}")
        self.address = address or None
        self.progress = progress
        self.workers = workers or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None
        self._client = None if self.address is None else connect(self.address)

    @property
    def backend(self) -> str:
        return "dask" if self._client is not None else ("inline" if self.workers == 1 else "processes")

    def imap(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        """Results of `fn` over `items`, yielded in item order as they become available."""
        return _in_order(self.as_completed(fn, items))

    def as_completed(self, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[tuple[int, Any]]:
        """(index of the item, result of `fn`) for every item, in the order the evaluations finish (item order in
        this process). Work starts at the call; the progress bar, if any, counts finished items."""
        items = list(items)
        if not items:
            return iter(())
        completed = self._completed(fn, items)
        if self.progress is None:
            return completed
        from tqdm import tqdm

        return iter(tqdm(completed, total=len(items), desc=self.progress, unit="task", mininterval=5.0))

    def _completed(self, fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
        if self._client is not None:
            from distributed import as_completed

            futures = self._client.map(fn, items, pure=False)
            index = {future.key: i for i, future in enumerate(futures)}
            # this client's loop: as_completed would otherwise wait on the default client's (another Client of
            # the process, e.g. the caller's own)
            completed = as_completed(futures, loop=self._client.loop)
            return ((index[future.key], future.result()) for future in completed)
        if self.workers == 1:
            return ((i, fn(item)) for i, item in enumerate(items))
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("forkserver"),
                                             initializer=_start_worker, initargs=(os.getpid(),))
        pending = {self._pool.submit(fn, item): i for i, item in enumerate(items)}
        return ((pending[future], future.result()) for future in concurrent.futures.as_completed(pending))

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


def _in_order(completed: Iterator[tuple[int, Any]]) -> Iterator[Any]:
    """The results of `completed` ((index, result) pairs, indices 0..n-1 in any order) in index order, each as
    soon as every result before it has arrived."""
    waiting: dict[int, Any] = {}
    following = 0
    for index, result in completed:
        waiting[index] = result
        while following in waiting:
            yield waiting.pop(following)
            following += 1


def evaluate_many(fn: Callable[[Any], Any], items: Iterable[Any], key: Callable[[Any], CacheKey],
                  cache: EvaluationCache | None = None, executor: Executor | None = None,
                  save_every: int = 0, batch: int = 0) -> list[dict]:
    """The cache row of every item, evaluating with `fn` only the keys not yet cached (each once).

    `fn(item)` returns a result dict; with `batch` > 0, `fn(items)` takes up to `batch` items and returns their
    result dicts in order. `save_every` > 0 saves the cache after that many new results (and at the end); 0
    saves at the end.
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
        missing_keys = list(missing)
        for done, (index, result) in enumerate(_completed_rows(fn, list(missing.values()), executor, batch), 1):
            cache.put(missing_keys[index], **result)
            if save_every and done % save_every == 0:
                cache.save()
    finally:  # keep what was evaluated, also when an evaluation raised
        if missing:
            cache.save()
        if own:
            executor.close()
    return [cache.get(k) for k in keys]


def _completed_rows(fn: Callable[[Any], Any], items: list[Any], executor: Executor,
                    batch: int) -> Iterator[tuple[int, dict]]:
    """(index, `fn`'s result) of every item as the evaluations finish: one call per item, or per chunk of `batch`
    items (a chunk's results arrive together)."""
    if batch <= 0:
        yield from executor.as_completed(fn, items)
        return
    chunks = [items[i:i + batch] for i in range(0, len(items), batch)]
    for chunk, results in executor.as_completed(fn, chunks):
        first = chunk * batch
        yield from zip(range(first, first + len(chunks[chunk])), results, strict=True)
