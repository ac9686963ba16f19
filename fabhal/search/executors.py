"""Where the members are solved: worker processes on this machine or a Dask
cluster. Both are `concurrent.futures` executors, so the search hands out
work and collects it the same way."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from urllib.parse import urlparse


class ExecutorError(Exception):
    """The executor asked for cannot be used (a bad address, Dask not installed)."""


def default_jobs() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def warm_worker() -> None:
    """Once per worker process: import the solver and read the part library, so
    the first member costs what every other does."""
    from fabhal import api
    from fabhal.solve import solve  # noqa: F401  (the import is the warm-up)

    api.part_library()


@contextmanager
def open_executor(spec: str | None, jobs: int) -> Iterator[Executor]:
    """`spec` None: `jobs` local worker processes (started fresh, `spawn`, so no
    thread of the caller is copied into them); `dask://HOST:PORT`: the workers
    of that Dask scheduler. (One local job needs no executor: the caller
    solves in its own process.)"""
    if spec is not None:
        with _dask_executor(spec) as executor:
            yield executor
        return
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=warm_worker)
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


@contextmanager
def _dask_executor(spec: str) -> Iterator[Executor]:
    address = urlparse(spec)
    if address.scheme != "dask" or not address.hostname or address.port is None:
        raise ExecutorError(f"--executor takes dask://HOST:PORT, e.g. dask://127.0.0.1:8786; got {spec!r}")
    try:
        from distributed import Client
    except ImportError:
        raise ExecutorError(
            "--executor dask://... needs Dask's distributed scheduler: pip install 'fabhal[dask]'"
        ) from None
    try:
        client = Client(f"tcp://{address.hostname}:{address.port}", timeout="10s")
    except OSError as exc:
        raise ExecutorError(
            f"cannot reach the Dask scheduler at {address.hostname}:{address.port}: {exc}; start one with "
            "`dask scheduler` and workers with `dask worker HOST:PORT`"
        ) from None
    try:
        yield client.get_executor()
    finally:
        client.close()
