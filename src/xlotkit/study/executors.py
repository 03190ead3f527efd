"""Where the cases of a study run: a local process pool, a Dask cluster, or in this process.

Each executor runs a picklable top-level function over a sequence of tasks and yields
``(position, outcome)`` pairs as the tasks finish, in whatever order they finish. The task
functions of :mod:`xlotkit.study` catch every error of their own case and return it as a
row, so an exception that reaches the executor means the case never came back (its worker
process died, the cluster lost it): the outcome is then :class:`Lost`, and the case is run
again by the next run of the study.

* :class:`LocalPool` -- :class:`concurrent.futures.ProcessPoolExecutor` with ``workers``
  processes started by ``spawn`` (a fresh interpreter per worker: no state forked from a
  parent that holds threads).
* :class:`DaskCluster` -- a :class:`distributed.Client` connected to a running scheduler
  (``--scheduler tcp://HOST:8786``), or a client given by the caller (e.g. on a
  :class:`distributed.LocalCluster`); the workers need xlotkit installed and the study
  folder on a file system they share with the client.
* :class:`InProcess` -- one task after another in this process (tests, debugging).

No scheduling of our own: the pool and the cluster decide what runs where.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from xlotkit.errors import InputError

__all__ = ["DaskCluster", "Executor", "InProcess", "LocalPool", "Lost", "default_workers"]


@dataclass(frozen=True)
class Lost:
    """A task that did not come back (``message``: why)."""

    message: str


class Executor(Protocol):
    """Runs ``fn(task)`` for every task; yields ``(position, result or Lost)`` as they end.

    If the consumer stops early (an exception in a progress callback, Ctrl-C), the tasks
    not yet started are cancelled before the exception goes on.
    """

    name: str

    def run(self, fn: Callable[[Any], Any], tasks: Sequence[Any]
            ) -> Iterator[tuple[int, Any]]: ...

    def describe(self) -> str: ...


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")


def default_workers() -> int:
    """The CPUs this process may use (the default pool size)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:          # not on Linux
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class InProcess:
    """Every task in this process, in order (an exception in ``fn`` is a :class:`Lost`)."""

    name: str = field(default="in-process", init=False)

    def run(self, fn, tasks):
        for i, t in enumerate(tasks):
            try:
                out = fn(t)
            except Exception as exc:
                out = Lost(_one_line(exc))
            yield i, out

    def describe(self) -> str:
        return "in this process"


@dataclass(frozen=True)
class LocalPool:
    """A local pool of ``workers`` processes (:class:`~concurrent.futures.ProcessPoolExecutor`).

    Raises
    ------
    InputError
        If ``workers`` < 1.
    """

    workers: int
    name: str = field(default="local", init=False)

    def __post_init__(self) -> None:
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) \
                or self.workers < 1:
            raise InputError(f"{self.workers!r} workers", key="--workers",
                             expected="an integer >= 1")

    def run(self, fn, tasks):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        if not tasks:
            return
        pool = ProcessPoolExecutor(max_workers=min(self.workers, len(tasks)),
                                   mp_context=multiprocessing.get_context("spawn"))
        try:
            futures = {pool.submit(fn, t): i for i, t in enumerate(tasks)}
            for fut in as_completed(futures):
                try:
                    out = fut.result()
                except Exception as exc:    # BrokenProcessPool: a worker died
                    out = Lost(f"the worker did not return ({_one_line(exc)})")
                yield futures[fut], out
        finally:
            # cancel what has not started; the running tasks end (and write their results)
            pool.shutdown(wait=True, cancel_futures=True)

    def describe(self) -> str:
        return f"a local pool of {self.workers} process{'es' if self.workers > 1 else ''}"


@dataclass
class DaskCluster:
    """A Dask distributed cluster.

    Parameters
    ----------
    address : str, optional
        The scheduler (``tcp://host:8786``); a client is made for the run and closed after.
    client : distributed.Client, optional
        A client to use instead (left open).
    timeout : float
        Seconds to wait for the scheduler.
    """

    address: str | None = None
    client: Any = None
    timeout: float = 30.0
    name: str = field(default="dask", init=False)

    def __post_init__(self) -> None:
        if (self.address is None) == (self.client is None):
            raise ValueError("give either a scheduler address or a client")

    def _connect(self):
        if self.client is not None:
            return self.client, False
        from distributed import Client

        try:
            return Client(self.address, timeout=self.timeout), True
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"cannot reach the Dask scheduler {self.address!r}: "
                             f"{_one_line(exc)}", key="--scheduler",
                             expected="the address a running `dask scheduler` prints, "
                                      "e.g. tcp://10.0.0.5:8786") from None

    def run(self, fn, tasks):
        from distributed import as_completed

        if not tasks:
            return
        client, own = self._connect()
        futures = []
        try:
            futures = [client.submit(fn, t, pure=False) for t in tasks]
            pos = {f.key: i for i, f in enumerate(futures)}
            for fut in as_completed(futures):
                try:
                    out = fut.result()
                except Exception as exc:    # KilledWorker, CancelledError, lost data
                    out = Lost(f"the cluster did not return it ({_one_line(exc)})")
                yield pos[fut.key], out
        finally:
            pending = [f for f in futures if not f.done()]
            if pending:
                client.cancel(pending)
            if own:
                client.close()

    def describe(self) -> str:
        if self.address is not None:
            return f"the Dask cluster at {self.address}"
        return f"the Dask cluster of {self.client.scheduler.address}"
