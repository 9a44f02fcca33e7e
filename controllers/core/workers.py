"""Worker processes that end quietly on Ctrl-C and SIGTERM.

A terminal's Ctrl-C reaches every process of the foreground group: the workers of a process
pool as well as the command. :func:`quiet_worker` (a pool's ``initializer``) gives a worker the
signals' default action, so it ends at once without printing a ``KeyboardInterrupt`` traceback
of its own; the command reports the interruption once. :func:`stop_workers` ends the workers
still running after the command was interrupted or terminated, so it does not wait for them.
"""

from __future__ import annotations

import multiprocessing
import signal

__all__ = ["quiet_worker", "stop_workers"]


def quiet_worker() -> None:
    """Pool initializer: SIGINT and SIGTERM end this worker silently (their default action)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_workers() -> None:
    """Terminate this process's worker processes that are still alive (SIGTERM)."""
    for p in multiprocessing.active_children():
        p.terminate()
