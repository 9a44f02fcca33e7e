"""Measurement: every speed figure the project reports, importable, one home.

One timing primitive, :func:`~mjchar.perf.timing.timed` (one call, three clocks: wall, process
CPU, thread CPU); every measurement times through it, directly or through
:func:`~mjchar.perf.timing.rounds` (cases taking turns, so a drifting machine load spreads
evenly over them). Every speed is a ratio or a rate measured in the same run, next to bare
``mj_step`` where that makes sense.

Modules, one per concern (those with an entry point print their table and, with ``--write``,
rewrite its block in the docs page named):

- :mod:`~mjchar.perf.timing`: :func:`timed`, :func:`rounds`, :class:`Timing`, :class:`Runs`.
- :mod:`~mjchar.perf.physics`: bare ``mj_step`` (:func:`raw_step_rate`) and a controller's cost
  per physics step over it (:func:`step_cost`).
- :mod:`~mjchar.perf.pd`: the PD stability envelope and per-step cost table
  (``python -m mjchar.perf.pd``, docs/controllers.md).
- :mod:`~mjchar.perf.rollouts`: batched rollouts against a Python ``mj_step`` loop
  (``python -m mjchar.perf.rollouts``, docs/rollouts.md).
- :mod:`~mjchar.perf.envs`: Gymnasium env throughput against ``Humanoid-v5``
  (``python -m mjchar.perf.envs``, docs/envs.md).
- :mod:`~mjchar.perf.bvh`: BVH parsing and FK against ``bvhio`` (``python -m mjchar.perf.bvh``,
  docs/bvh.md).
- :mod:`~mjchar.perf.simbicon`, :mod:`~mjchar.perf.ipm`, :mod:`~mjchar.perf.mpc`,
  :mod:`~mjchar.perf.samcon`: the long runs behind docs/simbicon.md, docs/ipm.md, docs/mpc.md
  and docs/sampling.md (robustness and speed; ``python -m mjchar.perf.<name> --help``).
- :mod:`~mjchar.perf.envelopes`: both walkers on converted bodies (the real exports) at several
  speeds and seeds, and pushed on the chest while walking (``python -m mjchar.perf.envelopes``,
  docs/calibration.md).
- :mod:`~mjchar.perf.report`: paths, the machine line, writing a docs block.
- :mod:`~mjchar.perf.errors`: :class:`PerfError`, :class:`PerfUnavailable`.

``mjchar bench``'s performance section (:mod:`mjchar.bench.performance`) calls the functions
re-exported here. Optional pieces (Gymnasium's MuJoCo envs, the project's envs, ``bvhio``) raise
:class:`PerfUnavailable` with the reason when they cannot be used.

A new figure is a function in the module of its concern (or a new module) that times through
:func:`timed` or :func:`rounds` and returns a dict of ratios and rates; an entry point is a
``main(argv)`` in that module; the bench picks it up as one more part in
:func:`mjchar.bench.performance.run_performance`.
"""

import importlib

#: what the package re-exports, and the module each comes from (imported on first use, so that
#: ``import mjchar.perf`` stays light and ``python -m mjchar.perf.<module>`` runs its module once)
_EXPORTS = {
    "PerfError": "errors", "PerfUnavailable": "errors",
    "Timing": "timing", "Runs": "timing", "Laps": "timing", "timed": "timing", "rounds": "timing",
    "load_average": "timing",
    "StepCost": "physics", "raw_step_rate": "physics", "step_cost": "physics",
    "RunCost": "physics", "run_cost": "physics",
    "stability_envelope": "pd", "ENVELOPE_KPS": "pd", "ENVELOPE_VARIANTS": "pd",
    "ENVELOPE_GRID": "pd", "ENVELOPE_FINER": "pd",
    "rollout_throughput": "rollouts",
    "env_throughput": "envs", "ENV_IDS": "envs", "threaded_throughput": "envs",
    "bvh_parse_speed": "bvh",
}
__all__ = list(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
