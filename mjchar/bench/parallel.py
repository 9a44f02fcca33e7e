"""The bench's worker pool: independent jobs (whole cells, single push runs) on ``jobs`` worker
processes, the most expensive first.

:class:`JobPool` keeps exactly ``jobs`` jobs in flight: ``jobs`` slot threads of the calling
process each take the waiting job of highest priority, hand it to a worker process and wait for
it, so a job submitted later with a higher priority (the next force level of the longest push
search) overtakes the cheap cells still waiting. With ``jobs == 1`` the jobs run in the calling
process, one at a time. Every job is a function of its arguments only (each run builds a fresh
character and controller), so the results do not depend on ``jobs`` or on the order the jobs
finish in.

Each job's CPU time (``time.process_time`` of the process that ran it: a worker runs one job at
a time, so its threads' time is the job's) is added to the job's ``tag``
(:meth:`JobPool.cpu_seconds`).
"""

from __future__ import annotations

import heapq
import itertools
import multiprocessing
import os
import threading
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor

from mjchar.controllers.core.workers import quiet_worker, stop_workers


def default_jobs() -> int:
    """One job per core this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _timed_call(fn: Callable, args: tuple):
    """``(fn(*args), CPU seconds of this process meanwhile)``: runs in the worker."""
    t0 = time.process_time()
    out = fn(*args)
    return out, time.process_time() - t0


class JobPool:
    """``jobs`` worker processes fed highest priority first (see the module docstring).

    Use as a context manager; :meth:`submit` returns a :class:`concurrent.futures.Future`.
    """

    def __init__(self, jobs: int):
        self.jobs = max(1, int(jobs))
        self._heap: list = []
        self._order = itertools.count()
        self._cv = threading.Condition()
        self._closed = False
        self._cpu: dict[str, float] = defaultdict(float)
        self._executor = None
        if self.jobs > 1:
            # forked where possible (workers know what this process registered, e.g. a
            # controller registered at run time), all at once, before any thread of the pool
            methods = multiprocessing.get_all_start_methods()
            ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
            self._executor = ProcessPoolExecutor(self.jobs, mp_context=ctx,
                                                 initializer=quiet_worker)
            started = [self._executor.submit(int) for _ in range(self.jobs)]
            for f in started:
                f.result()
        self._slots = [threading.Thread(target=self._slot, daemon=True, name=f"bench-slot-{i}")
                       for i in range(self.jobs)]
        for t in self._slots:
            t.start()

    def submit(self, priority: float, fn: Callable, *args, tag: str = "") -> Future:
        """Queue ``fn(*args)`` (``fn`` a module-level function, ``args`` picklable); larger
        ``priority`` runs first, equal priorities in submission order."""
        fut: Future = Future()
        with self._cv:
            if self._closed:
                raise RuntimeError("the job pool is closed")
            heapq.heappush(self._heap, (-float(priority), next(self._order), fn, args, tag, fut))
            self._cv.notify()
        return fut

    def map(self, fn: Callable, items: Iterable, priority: float, tag: str = "") -> list:
        """``[fn(x) for x in items]``, the calls spread over the workers (in order)."""
        futures = [self.submit(priority, fn, x, tag=tag) for x in items]
        return [f.result() for f in futures]

    def mapper(self, priority: float, tag: str = "") -> Callable[[Callable, Sequence], list]:
        """``map(fn, items)`` at a fixed priority and tag (what a protocol takes as its
        ``map``)."""
        return lambda fn, items: self.map(fn, items, priority, tag)

    def cpu_seconds(self) -> dict[str, float]:
        """CPU seconds of the finished jobs per tag."""
        with self._cv:
            return dict(self._cpu)

    def _slot(self) -> None:
        while True:
            with self._cv:
                while not self._heap and not self._closed:
                    self._cv.wait()
                if not self._heap:
                    return
                _, _, fn, args, tag, fut = heapq.heappop(self._heap)
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                if self._executor is None:
                    out, cpu = _timed_call(fn, args)
                else:
                    out, cpu = self._executor.submit(_timed_call, fn, args).result()
            except BaseException as e:  # noqa: BLE001  (handed to whoever waits for it)
                fut.set_exception(e)
                continue
            with self._cv:
                self._cpu[tag] += cpu
            fut.set_result(out)

    def close(self) -> None:
        """Let the queued jobs finish, then stop the slots and the workers."""
        with self._cv:
            self._closed = True
            self._cv.notify_all()
        for t in self._slots:
            t.join()
        if self._executor is not None:
            self._executor.shutdown()

    def __enter__(self) -> JobPool:
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is not None:  # drop what has not started
            with self._cv:
                for item in self._heap:
                    item[-1].cancel()
                self._heap.clear()
        if exc[0] is not None and issubclass(exc[0], KeyboardInterrupt):
            # Ctrl-C or SIGTERM: end the running jobs too, rather than wait for them
            if self._executor is not None:
                stop_workers()
                self._executor.shutdown(wait=False, cancel_futures=True)
        self.close()
