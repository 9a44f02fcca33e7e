"""Standing scenarios: ``stand``, ``push`` and ``random-push``.

- ``stand``: from the standing pose, no disturbance.
- ``push``: one horizontal push (default 0.2 s on the pelvis, 1 s in) of a given force and
  direction (degrees in the character's heading frame: 0 forward, 90 left, 180 back, 270 right).
- ``random-push``: a 10 N horizontal push on the root whose direction changes every second
  (PKU MoCCA's standing test), random directions from the seed.
"""

from __future__ import annotations

import math

import numpy as np

from ..character import Character
from ..metrics import Result
from .options import ALLOW_STEPS, DIRECTION, DURATION, FORCE, PUSH_DURATION, PUSH_TIME, SEED
from .registry import BenchRun, ScenarioError, ScenarioSpec, register
from .shared import heading_frame_direction, simulate, standing_pose, survived

#: run lengths in s when no duration is given
STAND_DURATION, PUSH_RUN_DURATION, RANDOM_PUSH_DURATION = 10.0, 4.0, 30.0


def stand(character: Character, controller, *, duration: float = STAND_DURATION,
          **kw) -> Result:
    """Stand from the standing pose for ``duration`` s."""
    return simulate(character, controller, duration=duration, scenario="stand",
                    qpos=standing_pose(character), **kw)


def push(character: Character, controller, *, force: float, direction: float = 0.0,
         push_duration: float = 0.2, push_time: float = 1.0, body: str | None = None,
         duration: float = PUSH_RUN_DURATION, allow_steps: bool = False,
         start: tuple[np.ndarray, np.ndarray | None] | None = None, **kw) -> Result:
    """One push of ``force`` N towards ``direction`` degrees (heading frame) on ``body``
    (default: the pelvis) for ``push_duration`` s at ``push_time`` s; run ``duration`` s from
    ``start`` (``(qpos (nq,), qvel (nv,))``, default: the standing pose at rest).

    ``max_push_N`` is ``force`` when it was survived (no fall and, unless ``allow_steps``, no
    foot moved more than 5 cm), else 0.
    """
    if not (math.isfinite(force) and force >= 0):
        raise ScenarioError(f"push force must be a non-negative number of newtons, got {force}")
    if push_time + push_duration > duration:
        raise ScenarioError(f"the push ({push_time} s + {push_duration} s) ends after the run "
                            f"({duration} s)")
    body = body or character.role("pelvis")

    def events(ch: Character) -> None:
        f = force * heading_frame_direction(ch, direction)
        ch.pushes.add(body, f, push_duration, start=push_time)

    qpos, qvel = (standing_pose(character), None) if start is None else start
    r = simulate(character, controller, duration=duration, scenario="push", qpos=qpos,
                 qvel=qvel, events=events, **kw)
    r.push_N, r.push_direction_deg = float(force), float(direction)
    r.max_push_N = float(force) if survived(r, allow_steps) else 0.0
    return r


def random_push(character: Character, controller, *, seed: int = 0, force: float = 10.0,
                period: float = 1.0, duration: float = RANDOM_PUSH_DURATION,
                body: str | None = None, **kw) -> Result:
    """A ``force`` N horizontal push on ``body`` (default: the root/pelvis) whose direction
    (uniform on the circle, from ``numpy.random.default_rng(seed)``) changes every ``period``
    s, for ``duration`` s."""
    rng = np.random.default_rng(seed)
    n = int(math.ceil(duration / period))
    angles = rng.uniform(0.0, 2 * math.pi, size=n)
    body = body or character.role("pelvis")

    def events(ch: Character) -> None:
        for k, a in enumerate(angles):
            ch.pushes.add(body, force * np.array([math.cos(a), math.sin(a), 0.0]), period,
                    start=k * period)

    r = simulate(character, controller, duration=duration, scenario="random-push",
                 qpos=standing_pose(character), events=events, seed=seed, **kw)
    r.push_N = float(force)
    return r


# -- registrations -------------------------------------------------------------------------------
def _stand(run, **options) -> Result:
    return stand(run.character, run.controller, **options, **run.simulate_options())


def _push(run, *, force: float | None = None, **options) -> Result:
    if force is None:
        raise ScenarioError("the push scenario needs a force (mjchar run: --push NEWTONS)")
    return push(run.character, run.controller, force=force, **options,
                **run.simulate_options())


def _random_push(run, **options) -> Result:
    return random_push(run.character, run.controller, **options, **run.simulate_options())


register(ScenarioSpec(
    name="stand", measures="stand from the standing pose, no disturbance", procedure=_stand,
    needs=("stand",), options=(DURATION,), default_duration=STAND_DURATION,
    bench=lambda s, c: [BenchRun("stand", None, {"duration": s["stand_duration"]})]))
register(ScenarioSpec(
    name="push", measures="one horizontal push while standing: survived or not",
    procedure=_push, needs=("stand",),
    options=(DURATION, FORCE, DIRECTION, PUSH_TIME, PUSH_DURATION, ALLOW_STEPS),
    default_duration=PUSH_RUN_DURATION,
    bench=lambda s, c: [BenchRun(f"{s.get('push_force', 100.0):g} N", None,
                                 {"force": s.get("push_force", 100.0)})]))
register(ScenarioSpec(
    name="random-push",
    measures="10 N on the pelvis in a new random direction every second (PKU MoCCA)",
    procedure=_random_push, needs=("stand",), options=(DURATION, FORCE, SEED),
    default_duration=RANDOM_PUSH_DURATION,
    bench=lambda s, c: [BenchRun(f"seed {k}", int(k), {
        "seed": int(k), "force": s["random_push_force"], "duration": s["random_push_duration"]})
        for k in s["seeds"]]))
