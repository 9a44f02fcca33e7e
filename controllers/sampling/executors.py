"""Where batches of rollouts run: this machine's cores, or a Ray cluster.

An :class:`Executor` turns a :class:`~mjchar.controllers.sampling.rollout.RolloutRequest` into a
:class:`~mjchar.controllers.sampling.rollout.RolloutResult`; SAMCON and CMA-ES only ever call
``executor.evaluate(request)`` and read ``executor.parallelism`` to size their batches. Every
executor gives bit-identical results for the same request, because each sample is simulated
independently from its own initial state by the same C rollout (see
:mod:`mjchar.controllers.sampling.rollout`).

- :class:`LocalExecutor` (the default): ``mujoco.rollout``'s own thread pool, GIL released.
- :class:`RayExecutor` (optional ``ray`` extra): ships the compiled model once per model (MJB
  bytes through Ray's object store) and contiguous chunks of samples to Ray actors, each running
  the same rollout on one thread; the chunks' results are joined in order.
- :func:`make_executor` builds either by name, for the CLI (see :func:`add_executor_arguments`).

Usage::

    with make_executor("local", threads=2) as ex:
        result = ex.evaluate(RolloutRequest(rmodel, states, targets, steps_per_control=50))
"""

from __future__ import annotations

import abc
import argparse
import os
import socket
import threading
import uuid
from pathlib import Path
from typing import Any

from mjchar.bvh.errors import MjcharError

from .rollout import RolloutModel, RolloutRequest, RolloutResult, RolloutRunner, pool_size

__all__ = [
    "ExecutorError", "RayUnavailableError", "RayConnectionError", "Executor", "LocalExecutor",
    "RayExecutor", "make_executor", "add_executor_arguments", "executor_from_args", "EXECUTORS",
    "connect_ray", "release_ray", "worker_pythonpath",
]

EXECUTORS = ("local", "ray")
"""Names :func:`make_executor` accepts."""

_PROJECT_ROOT = str(Path(__file__).resolve().parents[2])


class ExecutorError(MjcharError):
    """An executor cannot be built or a batch could not be evaluated."""


class RayUnavailableError(ExecutorError):
    """The Ray backend was asked for but ``ray`` is not installed."""


class RayConnectionError(ExecutorError):
    """The Ray cluster at the given address did not answer within the time limit."""


class Executor(abc.ABC):
    """Evaluates rollout requests. Close it (or use ``with``) to release threads or workers."""

    name: str = "executor"

    @property
    @abc.abstractmethod
    def parallelism(self) -> int:
        """How many samples run at once (threads or workers); batches of a multiple of it (and
        much larger) keep everything busy."""

    @abc.abstractmethod
    def evaluate(self, request: RolloutRequest) -> RolloutResult:
        """Simulate every sample of ``request``; results in the request's sample order."""

    def close(self) -> None:  # noqa: B027  (optional hook)
        """Release threads, workers or connections (idempotent)."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class LocalExecutor(Executor):
    """Rollouts on this machine's cores through ``mujoco.rollout``'s thread pool.

    Keeps one :class:`~mjchar.controllers.sampling.rollout.RolloutRunner` (thread pool, per-thread
    ``MjData``) per model it has seen. Use it from one Python thread at a time.

    Args:
        threads: worker threads; ``None`` uses ``os.cpu_count()``.
        chunk: samples per ``mujoco.rollout`` call (bounds memory; does not change results).
    """

    name = "local"

    def __init__(self, threads: int | None = None, chunk: int = 256):
        self.threads, self.chunk = pool_size(threads, chunk, ExecutorError)
        self._runners: dict[int, RolloutRunner] = {}

    @property
    def parallelism(self) -> int:
        return self.threads

    def evaluate(self, request: RolloutRequest) -> RolloutResult:
        runner = self._runners.get(id(request.model))
        if runner is None or runner.model is not request.model:
            runner = RolloutRunner(request.model, threads=self.threads, chunk=self.chunk)
            self._runners[id(request.model)] = runner  # the runner keeps the model alive
        return runner.run(request)

    def close(self) -> None:
        for runner in self._runners.values():
            runner.close()
        self._runners.clear()

    def __repr__(self) -> str:
        return f"LocalExecutor(threads={self.threads})"


class _RolloutWorker:
    """The Ray actor's body: one single-threaded runner per model it has been sent."""

    def __init__(self, threads: int):
        self._threads = threads
        self._runners: dict[str, RolloutRunner] = {}

    def run(self, key, boxed_model, initial_states, controls, steps_per_control, xfrc_applied):
        runner = self._runners.get(key)
        if runner is None:
            import ray  # present on every Ray worker

            model = ray.get(boxed_model[0])  # boxed: a bare ObjectRef argument would be
            runner = RolloutRunner(model, threads=self._threads)  # fetched on every call
            self._runners[key] = runner
        return runner.run(RolloutRequest(runner.model, initial_states, controls,
                                         steps_per_control, xfrc_applied))


def _import_ray():
    try:
        import ray
    except ImportError as e:
        raise RayUnavailableError("the Ray executor needs ray: pip install 'mjchar[ray]' (or "
                                  "'ray[default]')") from e
    return ray


def _host_port(address: str) -> tuple[str, int]:
    """``host:port`` of a Ray address (``host:port`` or ``ray://host:port``)."""
    rest = address.removeprefix("ray://")
    host, sep, port = rest.rpartition(":")
    if not sep:
        host, port = rest, "10001" if address.startswith("ray://") else "6379"
    try:
        return host.strip("[]"), int(port)
    except ValueError:
        raise RayConnectionError(f"Ray address {address!r} is not host:port or "
                                 "ray://host:port") from None


def connect_ray(address: str | None = None, *, num_cpus: int | None = None,
                connect_timeout: float = 30.0) -> bool:
    """Join Ray: ``None`` joins the instance this process is connected to or starts a local one
    (``num_cpus``, no dashboard); ``"host:port"``, ``"ray://host:port"`` or ``"auto"`` connects
    to a running cluster, failing within ``connect_timeout`` s when it does not answer. Returns
    whether this call connected (the caller then shuts Ray down when done).

    Raises:
        RayUnavailableError, RayConnectionError, ExecutorError (a local instance failed)."""
    ray = _import_ray()
    if address is None:
        if ray.is_initialized():
            return False
        # on the calling thread: Ray ties the processes it starts to the starting thread
        try:
            ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False,
                     configure_logging=False)
        except Exception as e:  # noqa: BLE001 (Ray raises many kinds)
            raise ExecutorError(f"cannot start a local Ray instance: {e}") from e
        return True
    if address not in ("auto", "local"):
        host, port = _host_port(address)
        try:  # a dead or firewalled address: fail fast instead of Ray's endless retries
            socket.create_connection((host, port), timeout=connect_timeout).close()
        except OSError as e:
            raise RayConnectionError(f"no Ray cluster answers at {address!r} ({e}); start "
                                     "one with `ray start --head` or check the "
                                     "address") from None
    if ray.is_initialized():
        return False  # already connected (to whatever this process joined before)
    outcome: dict[str, BaseException | bool] = {}

    def _init():
        try:
            ray.init(address=address, log_to_driver=False, configure_logging=False)
            outcome["ok"] = True
        except BaseException as e:  # noqa: BLE001 (reported below)
            outcome["error"] = e

    thread = threading.Thread(target=_init, name="mjchar-ray-connect", daemon=True)
    thread.start()
    thread.join(connect_timeout)
    if thread.is_alive():
        raise RayConnectionError(f"the Ray cluster at {address!r} did not answer within "
                                 f"{connect_timeout:g} s (is it a Ray GCS / client port?)")
    if "error" in outcome:
        raise RayConnectionError(f"cannot connect to Ray at {address!r}: "
                                 f"{outcome['error']}") from outcome["error"]
    return True


def release_ray(ray, actors, owns: bool) -> None:
    """Kill ``actors`` (those already gone are passed over); shut Ray down when this process
    connected it for them (``owns``: what :func:`connect_ray` returned)."""
    for actor in actors:
        try:
            ray.kill(actor)
        except Exception:  # noqa: BLE001 (already gone)
            pass
    if owns and ray.is_initialized():
        ray.shutdown()


def worker_pythonpath() -> str:
    """``PYTHONPATH`` for Ray workers: this checkout first (a source checkout imports as on the
    driver), then the driver's own."""
    return os.pathsep.join(p for p in (_PROJECT_ROOT, os.environ.get("PYTHONPATH")) if p)


class RayExecutor(Executor):
    """Rollouts on Ray actors, one thread each, in contiguous chunks of samples.

    Results are bit-identical to :class:`LocalExecutor`'s for the same request. The workers must
    be able to import mjchar (true for a local Ray instance started from a source checkout: the
    checkout is put on the workers' ``PYTHONPATH``; install mjchar on a remote cluster's nodes).

    Args:
        address: ``None`` joins the Ray instance this process is already connected to, or starts a
            local one (``num_cpus=num_workers``, no dashboard); ``"host:port"`` (GCS) or
            ``"ray://host:port"`` (Ray Client) connects to a running cluster, ``"auto"`` to the
            local machine's running cluster.
        num_workers: actors to start (default: the cluster's CPU count / ``threads_per_worker``).
        threads_per_worker: rollout threads (and Ray CPUs) per actor.
        connect_timeout: seconds to wait for a cluster at ``address`` to answer.
        task_timeout: seconds to wait for a batch (``None``: no limit).
        chunks_per_worker: chunks each worker gets per batch (more evens out uneven workers).

    Raises:
        RayUnavailableError: ray is not installed.
        RayConnectionError: ``address`` is malformed or did not answer within
            ``connect_timeout`` seconds.
    """

    name = "ray"

    def __init__(self, address: str | None = None, num_workers: int | None = None, *,
                 threads_per_worker: int = 1, connect_timeout: float = 30.0,
                 task_timeout: float | None = None, chunks_per_worker: int = 1):
        for label, value in (("num_workers", num_workers), ("threads_per_worker",
                             threads_per_worker), ("chunks_per_worker", chunks_per_worker)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                      or value < 1):
                raise ExecutorError(f"{label} must be a positive integer, got {value!r}")
        ray = _import_ray()
        self._ray = ray
        self._owns_ray = False
        self.address = address
        self.task_timeout = task_timeout
        self.chunks_per_worker = chunks_per_worker
        self._connect(address, num_workers, threads_per_worker, float(connect_timeout))
        if num_workers is None:
            cpus = int(ray.cluster_resources().get("CPU", 1))
            num_workers = max(1, cpus // threads_per_worker)
        self.num_workers, self.threads_per_worker = num_workers, threads_per_worker
        actor = ray.remote(_RolloutWorker).options(
            num_cpus=threads_per_worker,
            runtime_env={"env_vars": {"PYTHONPATH": worker_pythonpath()}})
        self._workers = [actor.remote(threads_per_worker) for _ in range(num_workers)]
        self._models: dict[int, tuple[RolloutModel, str, Any]] = {}

    def _connect(self, address, num_workers, threads_per_worker, timeout) -> None:
        cpus = None if num_workers is None else num_workers * threads_per_worker
        self._owns_ray = connect_ray(address, num_cpus=cpus, connect_timeout=timeout)

    @property
    def parallelism(self) -> int:
        return self.num_workers * self.threads_per_worker

    def _model_ref(self, model: RolloutModel) -> tuple[str, Any]:
        entry = self._models.get(id(model))
        if entry is None or entry[0] is not model:
            entry = (model, uuid.uuid4().hex, self._ray.put(model))
            self._models[id(model)] = entry  # keeps the model alive, so its id stays unique
        return entry[1], entry[2]

    def evaluate(self, request: RolloutRequest) -> RolloutResult:
        if not self._workers:
            raise ExecutorError("this RayExecutor is closed")
        ray = self._ray
        key, ref = self._model_ref(request.model)
        parts = request.split(self.num_workers * self.chunks_per_worker)
        futures = [self._workers[i % self.num_workers].run.remote(
                       key, [ref], p.initial_states, p.controls, p.steps_per_control,
                       p.xfrc_applied)
                   for i, p in enumerate(parts)]
        try:
            results = ray.get(futures, timeout=self.task_timeout)
        except ray.exceptions.GetTimeoutError as e:
            raise ExecutorError(f"Ray rollouts did not finish within {self.task_timeout} "
                                "s") from e
        except ray.exceptions.RayError as e:
            raise ExecutorError(f"Ray rollout workers failed (is mjchar importable on the "
                                f"workers?): {e}") from e
        return RolloutResult.concatenate(results)

    def close(self) -> None:
        release_ray(self._ray, self._workers, self._owns_ray)
        self._workers = []
        self._models.clear()
        self._owns_ray = False

    def __repr__(self) -> str:
        return f"RayExecutor(address={self.address!r}, num_workers={self.num_workers})"


def make_executor(name: str = "local", **options) -> Executor:
    """Build an executor by name: ``"local"`` (:class:`LocalExecutor`, options ``threads``,
    ``chunk``) or ``"ray"`` (:class:`RayExecutor`, options ``address``, ``num_workers``, ...).

    Raises:
        ExecutorError: unknown name or option.
    """
    classes = {"local": LocalExecutor, "ray": RayExecutor}
    if name not in classes:
        raise ExecutorError(f"unknown executor {name!r}; expected one of {', '.join(EXECUTORS)}")
    try:
        return classes[name](**options)
    except TypeError as e:
        raise ExecutorError(f"bad option for the {name} executor: {e}") from e


def add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--executor``, ``--threads``, ``--ray-address``, ``--ray-workers`` to a CLI parser."""
    group = parser.add_argument_group("rollout executor")
    group.add_argument("--executor", choices=EXECUTORS, default="local",
                       help="where batched rollouts run (default: local threads)")
    group.add_argument("--threads", type=int, default=None,
                       help="local rollout threads (default: all cores)")
    group.add_argument("--ray-address", default=None,
                       help="Ray cluster (host:port, ray://host:port, auto); default: start a "
                            "local Ray instance")
    group.add_argument("--ray-workers", type=int, default=None,
                       help="Ray actors (default: one per cluster CPU)")


def executor_from_args(args: argparse.Namespace) -> Executor:
    """The executor that the options of :func:`add_executor_arguments` describe."""
    if args.executor == "ray":
        return make_executor("ray", address=args.ray_address, num_workers=args.ray_workers)
    return make_executor("local", threads=args.threads)
