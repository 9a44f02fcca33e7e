"""Progress of long work on a terminal: one mechanism for every long command (the
application's; the layers below take any object with its methods, or a plain callback).

A :class:`Progress` is handed to the run (``Run.progress``, :mod:`~mjchar.controllers.core.
scenarios.registry`); :func:`~mjchar.controllers.core.scenarios.shared.simulate`, which every
scenario and replay runs through, reports the simulated time to it (``start``, ``update``,
``close``), so ``mjchar run``, ``mjchar gait`` and anything else built by the run builder show
the same bar::

    MPC track:  42%|████▏     | 1.26/3.02 sim s [00:31<00:43]

Other long work reports amounts of its own (``convert --verify`` and a long clip followed by a
hinge model: the frames of the IK correction) with :meth:`Progress.start` and
:meth:`Progress.update`, or through :meth:`Progress.counter` from a layer below that only takes
a callback. Lines of progress (a protocol's force
levels) go through :meth:`Progress.__call__`, which writes them without breaking the bar.

Bars only on a terminal: ``enabled=None`` shows them only when standard error is one;
commands give no Progress at all with ``--json`` (and nothing ever goes to standard output).
"""

from __future__ import annotations

import sys


class Progress:
    """A progress bar on standard error, for one piece of long work at a time.

    Args:
        enabled: ``True`` always, ``False`` never, ``None`` when standard error is a terminal.
        desc: the bar's label (``start`` may replace it).
    """

    def __init__(self, enabled: bool | None = None, desc: str = ""):
        if enabled is None:
            enabled = bool(getattr(sys.stderr, "isatty", lambda: False)())
        self.enabled = bool(enabled)
        self.desc = desc
        self._bar = None
        self._next = 0.0
        self._step = 0.0

    def start(self, total: float | None, unit: str = "sim s", desc: str | None = None) -> None:
        """Begin a bar of ``total`` units (``None``: unknown, a counter)."""
        self.close()
        if not self.enabled:
            return
        from tqdm import tqdm

        fmt = ("{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total:.2f} " + unit +
               " [{elapsed}<{remaining}]") if total else ("{desc}: {n:.2f} " + unit +
                                                          " [{elapsed}]")
        self._bar = tqdm(total=total, desc=self.desc if desc is None else desc,
                         bar_format=fmt, leave=False, file=sys.stderr, dynamic_ncols=True)
        self._step = (total or 0.0) / 1000.0
        self._next = 0.0

    def update(self, done: float) -> None:
        """``done`` units so far (cheap: a call that moves the bar by less than a thousandth
        of its total returns at once)."""
        if self._bar is None or done < self._next:
            return
        self._next = done + self._step
        if self._bar.total:
            done = min(done, self._bar.total)
        self._bar.update(done - self._bar.n)  # redrawn at most every 0.1 s (tqdm's mininterval)

    def counter(self, desc: str, unit: str):
        """A ``callback(done, total)`` for a lower layer's loop that reports amounts (frames
        of a clip being prepared): its first call starts a bar of ``total`` ``unit``."""
        def callback(done: float, total: float) -> None:
            if self._bar is None or self._bar.desc != desc:
                self.start(total, unit=unit, desc=desc)
            self.update(done)

        return callback

    def close(self) -> None:
        """End the bar (it leaves no line behind)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __call__(self, line: str) -> None:
        """Write one line of progress (above the bar, if one is showing), whether or not bars
        are enabled: a command that must stay quiet gives no Progress at all."""
        if self._bar is not None:
            from tqdm import tqdm

            tqdm.write(line, file=sys.stderr)
        else:
            print(line, file=sys.stderr, flush=True)
