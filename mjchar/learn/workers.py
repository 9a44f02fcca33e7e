"""Where the episodes of ``mjchar learn`` run: worker processes on this machine (the default)
or Ray actors on a cluster.

Both hold one :class:`~.collect.Collector` per worker (an env and an MPC labeller on the clip)
and run :class:`~.collect.Episode` jobs with :meth:`EpisodePool.map`, which returns the results
in the jobs' order. An episode's result depends only on its job (its seed, start, pushes and
policy; the labeller's plans start cold in every episode), so a run gives the same data set
whichever pool ran it and however the jobs fell on the workers.

Usage::

    with episode_pool(setup, workers=4) as pool:                      # this machine
        results = pool.map(jobs)
    with episode_pool(setup, executor="ray", address="head:6379") as pool:  # a Ray cluster
        results = pool.map(jobs)

On Ray, each actor takes one CPU (its labeller runs its rollouts on one thread); ``workers``
defaults to the cluster's CPU count. The workers must be able to import mjchar (a local Ray
instance started from a source checkout gets the checkout on its ``PYTHONPATH``; install mjchar
on a remote cluster's nodes).
"""

from __future__ import annotations

import abc
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from mjchar.controllers.core.workers import process_pool

from .collect import Collector, Episode, EpisodeResult, LearnSetup, init_worker, run_episode

__all__ = ["EXECUTORS", "EpisodePool", "LocalEpisodePool", "RayEpisodePool", "episode_pool"]

#: where episodes can run
EXECUTORS = ("local", "ray")


class EpisodePool(abc.ABC):
    """Workers that run episodes (module docstring)."""

    #: how many episodes run at once
    parallelism: int

    @abc.abstractmethod
    def map(self, jobs: Sequence[Episode]) -> list[EpisodeResult]:
        """Run every job; the results in the jobs' order."""


class LocalEpisodePool(EpisodePool):
    """Worker processes on this machine (``process_pool``: Ctrl-C ends them at once)."""

    def __init__(self, pool, workers: int):
        self._pool = pool
        self.parallelism = workers

    def map(self, jobs: Sequence[Episode]) -> list[EpisodeResult]:
        return list(self._pool.map(run_episode, jobs))


class _RayCollector:
    """A Ray actor: one collector, its episodes one after another."""

    def __init__(self, setup: LearnSetup):
        self.collector = Collector(setup)

    def run(self, job: Episode) -> EpisodeResult:
        return self.collector.run(job)


class RayEpisodePool(EpisodePool):
    """Ray actors, each with its own collector; jobs go to whichever actor is free."""

    def __init__(self, setup: LearnSetup, workers: int | None = None, *,
                 address: str | None = None, connect_timeout: float = 30.0):
        from mjchar.controllers.sampling.executors import (
            _import_ray,
            connect_ray,
            worker_pythonpath,
        )

        ray = _import_ray()
        self._ray = ray
        self._owns = connect_ray(address, num_cpus=workers, connect_timeout=connect_timeout)
        if workers is None:
            workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        actor = ray.remote(_RayCollector).options(
            num_cpus=1, runtime_env={"env_vars": {"PYTHONPATH": worker_pythonpath()}})
        self._actors = [actor.remote(setup) for _ in range(workers)]
        self.parallelism = workers

    def map(self, jobs: Sequence[Episode]) -> list[EpisodeResult]:
        from ray.util import ActorPool

        from mjchar.controllers.sampling.executors import ExecutorError

        try:
            return list(ActorPool(self._actors).map(lambda a, job: a.run.remote(job), jobs))
        except self._ray.exceptions.RayError as e:
            raise ExecutorError(f"Ray labelling workers failed (is mjchar importable on the "
                                f"workers?): {e}") from e

    def close(self) -> None:
        from mjchar.controllers.sampling.executors import release_ray

        release_ray(self._ray, self._actors, self._owns)
        self._actors = []
        self._owns = False


@contextmanager
def episode_pool(setup: LearnSetup, workers: int | None = None, *, executor: str = "local",
                 address: str | None = None) -> Iterator[EpisodePool]:
    """A pool of ``workers`` labelling workers (``None``: every local core, or every CPU of
    the Ray cluster) on ``executor`` (:data:`EXECUTORS`); ``address``: the Ray cluster
    (``None``: start a local Ray instance)."""
    from mjchar.controllers.sampling.executors import ExecutorError

    if executor == "local":
        if address is not None:
            raise ExecutorError("a Ray address needs the ray executor (--executor ray)")
        n = workers or os.cpu_count() or 1
        with process_pool(n, initializer=init_worker, initargs=(setup,)) as pool:
            yield LocalEpisodePool(pool, n)
    elif executor == "ray":
        pool = RayEpisodePool(setup, workers, address=address)
        try:
            yield pool
        finally:
            pool.close()
    else:
        raise ExecutorError(f"unknown executor {executor!r}; expected one of "
                            f"{', '.join(EXECUTORS)}")
