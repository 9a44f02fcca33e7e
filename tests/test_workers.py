"""Process pools that end at once on Ctrl-C and SIGTERM (controllers/core/workers.py): the
command's process reports the signal in one line, its workers are gone, nothing waits for the
running jobs."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

SCRIPT = textwrap.dedent("""
    import os, sys, time
    from mjchar.cli import Terminated, _on_sigterm
    import signal
    from mjchar.controllers.core.workers import process_pool

    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        with process_pool(2) as pool:
            pids = set()
            while len(pids) < 2:  # (stdlib functions: a spawned worker can unpickle them)
                pids |= {f.result() for f in [pool.submit(os.getpid) for _ in range(8)]}
            print(*sorted(pids), flush=True)
            for f in [pool.submit(time.sleep, 600) for _ in range(4)]:
                f.result()
    except Terminated:
        print("terminated", file=sys.stderr)
        sys.exit(143)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
""")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie (ended, not yet reaped by its new parent) has ended too
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
@pytest.mark.parametrize("sig,code,word", [(signal.SIGTERM, 143, "terminated"),
                                           (signal.SIGINT, 130, "interrupted")])
def test_a_signal_ends_a_pool_and_its_running_jobs_at_once(sig, code, word):
    p = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        workers = [int(x) for x in p.stdout.readline().split()]
        assert workers, p.stderr.read()
        time.sleep(1.0)  # the sleeping jobs are running
        p.send_signal(sig)  # to the command only (a terminal's Ctrl-C reaches the workers too)
        out, err = p.communicate(timeout=60)  # the jobs would run 600 s
    finally:
        p.kill()
    assert p.returncode == code, err
    assert err.strip() == word
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(w) for w in workers), "a worker outlived the command"
