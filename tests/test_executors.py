"""Executors (mjchar.controllers.sampling.executors): local threads and Ray give the same results as
a direct rollout; bad names, options and Ray addresses raise project errors instead of hanging."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mjchar.bvh.bundled.assets import humanoid_path
from mjchar.bvh.errors import MjcharError
from mjchar.controllers.sampling.executors import (
    ExecutorError,
    LocalExecutor,
    RayConnectionError,
    RayUnavailableError,
    add_executor_arguments,
    executor_from_args,
    make_executor,
)
from mjchar.controllers.sampling.rollout import RolloutModel, RolloutRequest, rollout

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ("states", "com", "com_vel", "sites", "contacts", "ok", "failed_step")


def assert_identical(a, b) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.fixture(scope="module")
def request_() -> RolloutRequest:
    """9 samples of 2 controls x 10 steps from the rest pose, with a push on some samples."""
    rm = RolloutModel.from_source(humanoid_path())
    m = rm.model
    rng = np.random.default_rng(11)
    targets = m.qpos0[m.jnt_qposadr[m.actuator_trnid[:, 0]]] + rng.normal(0, 0.3, (9, 2, m.nu))
    xfrc = np.zeros((9, 1, m.nbody, 6))
    xfrc[::3, 0, 1, :2] = rng.normal(0, 200, (3, 2))
    return RolloutRequest(rm, rm.initial_state(), targets, 10, xfrc)


def test_local_executor_matches_direct_rollout(request_):
    expected = rollout(request_, threads=1)
    for threads in (1, 2):
        with LocalExecutor(threads=threads, chunk=4) as ex:
            assert ex.parallelism == threads
            assert_identical(ex.evaluate(request_), expected)
            assert_identical(ex.evaluate(request_), expected)  # cached runner, same answer
    with LocalExecutor() as ex:
        assert ex.threads == (os.cpu_count() or 1)


def test_make_executor_and_cli_options(request_):
    with make_executor("local", threads=2) as ex:
        assert isinstance(ex, LocalExecutor) and ex.threads == 2
    with pytest.raises(ExecutorError, match="unknown executor 'dask'"):
        make_executor("dask")
    with pytest.raises(ExecutorError, match="bad option"):
        make_executor("local", workers=3)
    with pytest.raises(ExecutorError, match="threads"):
        make_executor("local", threads=0)
    parser = argparse.ArgumentParser()
    add_executor_arguments(parser)
    args = parser.parse_args(["--threads", "1"])
    assert args.executor == "local" and args.ray_address is None
    with executor_from_args(args) as ex:
        assert isinstance(ex, LocalExecutor) and ex.threads == 1
        assert_identical(ex.evaluate(request_), rollout(request_, threads=2))


def test_ray_missing_gives_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    with pytest.raises(RayUnavailableError, match=r"mjchar\[ray\]"):
        make_executor("ray")


@pytest.fixture(scope="module")
def local_ray():
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'mjchar[ray]'); "
                                            "the Ray executor tests need it")
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    if started:
        ray.shutdown()


def test_ray_executor_matches_local(local_ray, request_):
    expected = rollout(request_, threads=2)
    with make_executor("ray", num_workers=2) as ex:
        assert ex.parallelism == 2
        assert_identical(ex.evaluate(request_), expected)
        ex.chunks_per_worker = 3  # other chunking, same answer
        assert_identical(ex.evaluate(request_), expected)
        one = request_.take(slice(4, 5))  # fewer samples than workers
        assert_identical(ex.evaluate(one), rollout(one, threads=1))
    assert local_ray.is_initialized()  # it joined the test's Ray instance and left it running


def test_unreachable_ray_address_fails_fast():
    # nothing listens on port 1: the error comes from the connection check, not from Ray
    with pytest.raises(RayConnectionError, match="no Ray cluster answers") as info:
        make_executor("ray", address="127.0.0.1:1", connect_timeout=2)
    assert isinstance(info.value, MjcharError)
    with pytest.raises(RayConnectionError, match="host:port"):
        make_executor("ray", address="localhost:notaport", connect_timeout=2)


def test_silent_ray_address_times_out():
    """A port that accepts connections but never speaks Ray: error after connect_timeout. Runs
    in a subprocess because Ray's connecting thread cannot be stopped."""
    pytest.importorskip("ray", reason="ray is not installed (pip install 'mjchar[ray]')")
    script = textwrap.dedent("""
        import os, socket, sys
        from mjchar.controllers.sampling.executors import RayConnectionError, make_executor
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen()
        port = server.getsockname()[1]
        try:
            make_executor("ray", address=f"127.0.0.1:{port}", connect_timeout=3)
            print("CONNECTED")
        except RayConnectionError as e:
            print("ERROR", e)
        sys.stdout.flush()
        os._exit(0)
    """)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, cwd=ROOT, env=env)
    assert "ERROR" in proc.stdout and "did not answer within 3 s" in proc.stdout, proc.stderr
