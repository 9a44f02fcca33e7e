"""Speed against bare ``mj_step``, everything in one run: what every registered controller's
``mjchar run`` costs per physics step, and how much of the envs' time is physics (the tables of
docs/controllers.md and docs/envs.md).

    python -m mjchar.perf.speed                       # every controller and the envs, printed
    python -m mjchar.perf.speed --only controllers    # or: --only envs
    python -m mjchar.perf.speed simbicon spd          # some controllers
    python -m mjchar.perf.speed --repeats 5 --write   # update the docs pages

- **Controllers** (:func:`mjchar.perf.physics.run_cost`): each controller's default run, built
  and executed as ``mjchar run NAME`` does (its default scenario and duration; ``mpc`` for
  :data:`MPC_DURATION` s), its loop timed on the process CPU clock from inside, over bare
  ``mj_step`` on the same model and time step from the states that run visited; timed runs and
  bare loops take turns, median of the repeats, their spread beside it.
- **Envs** (:func:`mjchar.perf.envs.env_throughput`, :func:`mjchar.perf.envs.vector_throughput`,
  the tables of :mod:`mjchar.perf.envs`): the share of each env's time spent inside MuJoCo's
  stepping functions with random actions in one process (and the bare-equivalent share: bare
  ``mj_step`` CPU time for the same physics steps over the env loop's CPU time), then env steps
  per second in one process and as a ``gymnasium.vector.AsyncVectorEnv`` of two workers with
  shared memory, ``Humanoid-v5`` alongside.

Timings are CPU time of this process where they are ratios (other processes' load affects the
controller and its yardstick alike) and wall time where they are throughputs; a table says the
load average it was measured under.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

from .errors import PerfUnavailable
from .physics import run_cost
from .report import DOCS, entry_parser, machine_line, markdown_table, spread, write_block

__all__ = ["MPC_DURATION", "controller_run_costs", "controllers_table", "main"]

#: seconds the MPC's run lasts here (its default run takes minutes of planning)
MPC_DURATION = 0.5


def controller_run_costs(names: Sequence[str] | None = None, *, repeats: int = 3,
                         log: Callable[[str], None] = lambda msg: None) -> dict:
    """``{name: RunCost.to_dict()}`` for the registered controllers ``names`` (default: all
    that run without a file: the generic ``replay``, which plays a trajectory it is given, is
    the controller ``samcon_replay`` and ``cmaes_replay`` run on their bundled ones), each on
    its default run (:func:`~mjchar.perf.physics.run_cost`)."""
    from mjchar.controllers.core import registry
    from mjchar.controllers.core.builder import RunSpec

    if not names:
        names = [s.name for s in registry.specs()
                 if not (s.kind == "replay" and not s.trajectory_prefixes)]
    out = {}
    for name in names:
        if name == "policy":  # a learned policy runs on its own clip: the bundled one's
            from .policy import policy_spec

            spec = policy_spec(None)
        else:
            spec = RunSpec(name, scenario_options={"duration": MPC_DURATION} if name == "mpc"
                           else {})
        c = run_cost(spec, repeats=repeats)
        out[name] = c.to_dict()
        log(f"  {name}: {c.ratio:.2f} x mj_step ({min(c.ratios):.2f}-{max(c.ratios):.2f}; "
            f"{c.run_us:.1f} vs {c.bare_us:.1f} us per step)")
    return out


def controllers_table(costs: dict, repeats: int) -> str:
    """Markdown table of :func:`controller_run_costs`."""
    intro = (f"Measured by `python -m mjchar.perf.speed --only controllers` on {machine_line()}; "
             f"process CPU time, median of {repeats} timed runs each interleaved with bare "
             f"`mj_step` from the states the run visited (spread: smallest and largest ratio).")
    header = ("controller", "scenario", "physics dt", "control dt", "steps", "cost / mj_step",
              "spread", "us per step", "mj_step us")
    rows = [(name, c["scenario"], f"{c['timestep_s'] * 1000:.3g} ms",
             f"{c['control_dt_s'] * 1000:.3g} ms", c["steps"], f"{c['ratio']:.2f}",
             spread(c["ratios"], ".2f"), f"{c['run_us']:.1f}", f"{c['bare_us']:.1f}")
            for name, c in costs.items()]
    return f"{intro}\n\n{markdown_table(header, rows)}"


def main(argv: list[str] | None = None) -> int:
    p = entry_parser("speed", __doc__)
    p.add_argument("controllers", nargs="*", help="registered controllers (default: all)")
    p.add_argument("--only", choices=("controllers", "envs"))
    p.add_argument("--repeats", type=int, default=3, help="timed runs / rounds (median)")
    p.add_argument("--env-steps", type=int, default=1500, help="env steps per env per round")
    p.add_argument("--write", action="store_true",
                   help="update docs/controllers.md and docs/envs.md")
    a = p.parse_args(argv)
    if a.repeats <= 0 or a.env_steps <= 0:
        p.error("--repeats and --env-steps must be positive")

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    sections = {}
    if a.only in (None, "controllers"):
        log("controllers: mjchar run per physics step over bare mj_step")
        costs = controller_run_costs(a.controllers or None, repeats=a.repeats, log=log)
        sections["speed"] = ("controllers.md", controllers_table(costs, a.repeats))
    if a.only in (None, "envs"):
        from .envs import (
            ENV_IDS,
            env_throughput,
            table,
            threaded_table,
            threaded_throughput,
            vector_table,
            vector_throughput,
        )

        log("envs: time in mj_step, one process, AsyncVectorEnv and the threaded vector env")
        command = "python -m mjchar.perf.speed --only envs"
        try:
            share = env_throughput(ENV_IDS, steps=a.env_steps, repeats=a.repeats, bare=True,
                                   log=log)
            vector = vector_throughput((ENV_IDS[0], ENV_IDS[-1]), steps=a.env_steps,
                                       repeats=a.repeats, log=log)
            threaded = threaded_throughput(ENV_IDS[0], steps=a.env_steps, repeats=a.repeats,
                                           log=log)
        except PerfUnavailable as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        sections["envs"] = ("envs.md", table(share, command))
        sections["envs-vector"] = ("envs.md", vector_table(vector, command))
        sections["envs-threads"] = ("envs.md", threaded_table(threaded, command))
    for key, (_, body) in sections.items():
        print(f"\n## {key}\n\n{body}")
    if a.write:
        for key, (page, body) in sections.items():
            log(f"updated {write_block(DOCS / page, key, body)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
