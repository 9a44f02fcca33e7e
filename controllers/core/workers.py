"""Worker processes that end quietly on Ctrl-C and SIGTERM.

A terminal's Ctrl-C reaches every process of the foreground group: the workers of a process
pool as well as the command. :func:`quiet_worker` (a pool's ``initializer``) gives a worker the
signals' default action, so it ends at once without printing a ``KeyboardInterrupt`` traceback
of its own; the command reports the interruption once. :func:`stop_workers` ends the workers
still running after the command was interrupted or terminated, so it does not wait for them.
:func:`process_pool` is a process pool with both: quiet workers, and an interruption of its
``with`` block that ends the running workers instead of waiting for them.
"""

from __future__ import annotations

import contextlib
import functools
import multiprocessing
import signal
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor

__all__ = ["process_pool", "quiet_worker", "stop_workers"]


def quiet_worker() -> None:
    """Pool initializer: SIGINT and SIGTERM end this worker silently (their default action)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_workers() -> None:
    """Terminate this process's worker processes that are still alive (SIGTERM)."""
    for p in multiprocessing.active_children():
        p.terminate()


def _start_worker(initializer: Callable | None, *args) -> None:
    quiet_worker()
    if initializer is not None:
        initializer(*args)


@contextlib.contextmanager
def process_pool(workers: int, *, initializer: Callable | None = None, initargs: tuple = (),
                 start_method: str | None = "spawn") -> Iterator[ProcessPoolExecutor]:
    """A :class:`~concurrent.futures.ProcessPoolExecutor` of ``workers`` processes started with
    ``start_method`` (``None``: the platform's default), each running :func:`quiet_worker`
    then ``initializer(*initargs)``.

    Leaving the block normally waits for the queued work, as the executor does. Leaving it on
    Ctrl-C or SIGTERM (a ``KeyboardInterrupt``) ends the workers at once and drops what is
    queued, so the command reports the interruption without waiting for running jobs (a
    ``multiprocessing.Pool`` torn down after a worker died holding its queue's lock can wait
    forever)."""
    ctx = multiprocessing.get_context(start_method)
    pool = ProcessPoolExecutor(workers, mp_context=ctx,
                               initializer=functools.partial(_start_worker, initializer),
                               initargs=initargs)
    try:
        yield pool
    except KeyboardInterrupt:
        stop_workers()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
