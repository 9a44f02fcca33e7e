"""Scenarios shared by the tests, the CLI, the benchmarks and the environments.

Each scenario puts a :class:`~mjchar.controllers.core.character.Character` in a start state,
schedules what happens to it (pushes), runs a controller and returns a
:class:`~mjchar.controllers.core.metrics.Result`:

- ``stand``: from the standing pose, no disturbance.
- ``push``: one horizontal push (default 0.2 s on the pelvis, 1 s in) of a given force and
  direction (degrees in the character's heading frame: 0 forward, 90 left, 180 back, 270 right).
- ``push-search``: survival rates over phases, seeds and a force grid, per direction: the push
  protocol of :mod:`mjchar.controllers.core.push_protocol` (built on :func:`push`).
- ``random-push``: a 10 N horizontal push on the root whose direction changes every second
  (PKU MoCCA's standing test), random directions from the seed.
- ``track``: start on the reference's first frame and follow it (tracking errors).
- ``walk``: like ``track`` but reported for locomotion (distance and speed); later controllers
  that walk without a reference start from the standing pose.

``track`` and ``walk`` take an optional :class:`PushEvent` (a push while tracking or walking),
the same push the ``push`` scenario applies to a standing character.

Randomness comes only from ``numpy.random.default_rng(seed)``. A divergence is caught and
reported as a fall (``diverged``), never raised.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mjchar.bvh.errors import MjcharError

from .base import Gains
from .character import Character
from .errors import SimulationDiverged
from .metrics import STEP_DISTANCE, FallDetector, Recorder, Result
from .recording import chain_callbacks
from .registry import SCENARIOS, make_controller

#: the four horizontal push directions (degrees in the heading frame)
DIRECTIONS = {"forward": 0.0, "left": 90.0, "backward": 180.0, "right": 270.0}


class ScenarioError(MjcharError):
    """A scenario was asked for something impossible (unknown name, missing reference)."""


# -- building blocks -----------------------------------------------------------------------------
def standing_pose(character: Character) -> np.ndarray:
    """``(nq,)`` the model's rest pose (``qpos0``) with the feet on the floor."""
    return character.on_floor(character.model.qpos0)


def heading_frame_direction(character: Character, degrees: float) -> np.ndarray:
    """``(3,)`` unit horizontal world vector at ``degrees`` from the character's facing
    direction (its root x axis projected on the floor), counter-clockwise seen from above."""
    R = character.root_rotation
    yaw = math.atan2(R[1, 0], R[0, 0])
    a = yaw + math.radians(degrees)
    return np.array([math.cos(a), math.sin(a), 0.0])


def simulate(character: Character, controller, *, duration: float, scenario: str,
             qpos: np.ndarray, qvel: np.ndarray | None = None, reference=None,
             control_dt: float | None = None, events: Callable[[Character], None] | None = None,
             seed: int | None = None, stop_on_fall: bool = True,
             fall_height: float | None = None, frame_callback=None) -> Result:
    """Run ``controller`` on ``character`` from ``(qpos, qvel)`` for ``duration`` s.

    Args:
        events: called once at the start (after the reset) to schedule pushes on the character.
        control_dt: seconds between control steps (default: every physics step); rounded to a
            whole number of physics steps.
        frame_callback: called as ``frame_callback(character)`` once after the reset (the
            start state) and after every control step (video capture, BVH export).
    Returns:
        the :class:`Result` (a fall or a divergence ends the run when ``stop_on_fall``).
    """
    if not (math.isfinite(duration) and duration > 0):
        raise ScenarioError(f"duration must be a positive number of seconds, got {duration}")
    character.reset(qpos, qvel)
    fall = FallDetector(character, fall_height)
    controller.reset(character)
    if events is not None:
        events(character)
    dt = character.timestep
    n_sub = 1 if control_dt is None else max(1, int(round(control_dt / dt)))
    n_control = int(math.ceil(duration / (dt * n_sub) - 1e-9))
    rec = Recorder(character, reference)
    if frame_callback is not None:
        frame_callback(character)
    fell, fall_time, reason, diverged = False, None, None, False
    steps = 0
    wall0 = time.perf_counter()
    try:
        for _ in range(n_control):
            action = controller.act(character, character.time)
            character.step(action, n_sub)
            steps += n_sub
            rec.record(character)
            if frame_callback is not None:
                frame_callback(character)
            if not fell:
                why = fall.check(character)
                if why is not None:
                    fell, fall_time, reason = True, character.time, why
                    if stop_on_fall:
                        break
    except SimulationDiverged as e:
        fell, diverged, reason = True, True, str(e)
        fall_time = e.time if fall_time is None else fall_time
    wall = time.perf_counter() - wall0
    agg = rec.aggregates()
    track, root_err = rec.tracking_errors()
    sim_time = character.time
    return Result(
        controller=getattr(controller, "name", type(controller).__name__), scenario=scenario,
        fell=fell, fall_time_s=fall_time, sim_time_s=sim_time, distance_m=agg["distance_m"],
        mean_speed_mps=agg["distance_m"] / sim_time if sim_time > 0 else 0.0,
        tracking_error_m=track, root_error_m=root_err,
        root_force_mean_N=agg["root_force_mean_N"], root_force_max_N=agg["root_force_max_N"],
        root_torque_mean_Nm=agg["root_torque_mean_Nm"], max_push_N=None,
        wall_s=wall, steps_per_s=steps / wall if wall > 0 else 0.0, timestep_s=dt,
        control_dt_s=dt * n_sub, n_steps=steps, seed=seed, diverged=diverged, fall_reason=reason,
        foot_travel_m=agg["foot_travel_m"], stepped=agg["foot_travel_m"] > STEP_DISTANCE,
        com_drop_m=agg["com_drop_m"])


@dataclass(frozen=True)
class PushEvent:
    """One horizontal push of ``force`` N towards ``direction`` degrees (heading frame at the
    push's start: 0 forward, 90 left, 180 back, 270 right) on ``body`` (default: the pelvis)
    for ``duration`` s from ``time`` s. Call it on a character (a scenario's ``events``) to
    schedule it."""

    force: float
    direction: float = 0.0
    time: float = 1.0
    duration: float = 0.2
    body: str | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.force) and self.force >= 0):
            raise ScenarioError(f"push force must be a non-negative number of newtons, got "
                                f"{self.force}")
        if not (math.isfinite(self.time) and self.time >= 0 and math.isfinite(self.duration)
                and self.duration > 0 and math.isfinite(self.direction)):
            raise ScenarioError("push time must be >= 0 s, its duration > 0 s and its "
                                "direction finite degrees")

    @property
    def end(self) -> float:
        """Simulated time (s) the push ends."""
        return self.time + self.duration


def with_push(push: PushEvent | None, kw: dict) -> dict:
    """``simulate`` keywords that also apply ``push``: scheduled by the frame callback at the
    first control step at or after its start, in the heading frame of that moment (a walk may
    have turned since the start)."""
    if push is None:
        return kw
    inner = kw.get("frame_callback")
    done = [False]  # scheduled once: at the events call if it starts at 0, else on a step

    def schedule(ch: Character) -> None:
        if not done[0] and ch.time >= push.time - 1e-9:
            f = push.force * heading_frame_direction(ch, push.direction)
            ch.push(push.body or ch.role("pelvis"), f, push.end - ch.time, start=ch.time)
            done[0] = True

    return {**kw, "events": chain_callbacks(kw.get("events"), schedule),
            "frame_callback": chain_callbacks(schedule, inner)}


# -- the scenarios -------------------------------------------------------------------------------
#: run lengths in s when no duration is given (track and walk with a clip: the clip's length)
DEFAULT_DURATIONS = {"stand": 10.0, "push": 4.0, "random-push": 30.0, "walk": 10.0}


def stand(character: Character, controller, *, duration: float = DEFAULT_DURATIONS["stand"],
          **kw) -> Result:
    """Stand from the standing pose for ``duration`` s."""
    return simulate(character, controller, duration=duration, scenario="stand",
                    qpos=standing_pose(character), **kw)


def push(character: Character, controller, *, force: float, direction: float = 0.0,
         push_duration: float = 0.2, push_time: float = 1.0, body: str | None = None,
         duration: float = DEFAULT_DURATIONS["push"], allow_steps: bool = False,
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
        ch.push(body, f, push_duration, start=push_time)

    qpos, qvel = (standing_pose(character), None) if start is None else start
    r = simulate(character, controller, duration=duration, scenario="push", qpos=qpos,
                 qvel=qvel, events=events, **kw)
    r.push_N, r.push_direction_deg = float(force), float(direction)
    r.max_push_N = float(force) if survived(r, allow_steps) else 0.0
    return r


def survived(result: Result, allow_steps: bool = False) -> bool:
    """No fall, and (unless ``allow_steps``) no foot moved by a step."""
    return not result.fell and (allow_steps or not result.stepped)


def random_push(character: Character, controller, *, seed: int = 0, force: float = 10.0,
                period: float = 1.0, duration: float = DEFAULT_DURATIONS["random-push"],
                body: str | None = None,
                **kw) -> Result:
    """A ``force`` N horizontal push on ``body`` (default: the root/pelvis) whose direction
    (uniform on the circle, from ``numpy.random.default_rng(seed)``) changes every ``period``
    s, for ``duration`` s."""
    rng = np.random.default_rng(seed)
    n = int(math.ceil(duration / period))
    angles = rng.uniform(0.0, 2 * math.pi, size=n)
    body = body or character.role("pelvis")

    def events(ch: Character) -> None:
        for k, a in enumerate(angles):
            ch.push(body, force * np.array([math.cos(a), math.sin(a), 0.0]), period,
                    start=k * period)

    r = simulate(character, controller, duration=duration, scenario="random-push",
                 qpos=standing_pose(character), events=events, seed=seed, **kw)
    r.push_N = float(force)
    return r


def _check_push(push: PushEvent | None, duration: float) -> None:
    if push is not None and push.end > duration + 1e-9:
        raise ScenarioError(f"the push ({push.time} s + {push.duration} s) ends after the run "
                            f"({duration} s)")


def _pushed(r: Result, push: PushEvent | None) -> Result:
    if push is not None:
        r.push_N, r.push_direction_deg = float(push.force), float(push.direction)
    return r


def perturbed_start(character: Character, qpos: np.ndarray, qvel: np.ndarray, seed: int, *,
                    joint_noise: float = 0.1, root_velocity_noise: float = 0.2
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``(qpos (nq,), qvel (nv,))`` perturbed from ``numpy.random.default_rng(seed)``: every
    actuated dof moved by a Gaussian angle of ``joint_noise`` rad standard deviation, the root's
    horizontal velocity by one of ``root_velocity_noise`` m/s per axis, then the pose lifted or
    lowered so its lowest point touches the floor."""
    rng = np.random.default_rng(seed)
    dv = np.zeros(character.nv)
    dv[character.actuated] = rng.normal(0.0, joint_noise, int(character.actuated.sum()))
    q = character.on_floor(character.integrate(np.asarray(qpos, float), dv, 1.0))
    v = np.array(qvel, dtype=float)
    v[character.root_dofs[:2]] += rng.normal(0.0, root_velocity_noise, 2)
    return q, v


def track(character: Character, controller, reference, *, duration: float | None = None,
          scenario: str = "track", push: PushEvent | None = None,
          start: tuple[np.ndarray, np.ndarray] | None = None, **kw) -> Result:
    """Start on the reference's first frame (pose and velocity; or ``start``, e.g. a
    :func:`perturbed_start`) and run for ``duration`` s (default: the clip's duration); reports
    tracking and root errors against the reference. ``push``: one push while tracking
    (:class:`PushEvent`)."""
    if reference is None:
        raise ScenarioError(f"the {scenario} scenario needs a reference motion")
    duration = reference.duration if duration is None else duration
    _check_push(push, duration)
    q, v = (reference.qpos(0.0), reference.qvel(0.0)) if start is None else start
    r = simulate(character, controller, duration=duration, scenario=scenario, qpos=q, qvel=v,
                 reference=reference, **with_push(push, kw))
    return _pushed(r, push)


def walk(character: Character, controller, reference=None, *, duration: float | None = None,
         push: PushEvent | None = None, **kw) -> Result:
    """Locomotion: from the reference's first frame (or the standing pose without one), report
    the distance covered and the mean speed (and tracking errors when there is a reference).
    ``push``: one push while walking (:class:`PushEvent`)."""
    if reference is None:
        duration = DEFAULT_DURATIONS["walk"] if duration is None else duration
        _check_push(push, duration)
        r = simulate(character, controller, duration=duration, scenario="walk",
                     qpos=standing_pose(character), **with_push(push, kw))
        return _pushed(r, push)
    return track(character, controller, reference, duration=duration, scenario="walk",
                 push=push, **kw)


@dataclass
class HoldResult:
    """Outcome of :func:`hold_pose` (a PD stability check with the root welded).

    Attributes:
        held: no divergence, and over the last second the RMS joint error stayed below
            ``HOLD_ERROR`` rad and the RMS joint velocity below ``HOLD_VELOCITY`` rad/s.
        diverged: the simulation blew up (NaN, exploding velocity).
        rms_error: RMS joint error over the last second (rad; ``inf`` if diverged).
        rms_velocity: RMS joint velocity over the last second (rad/s; ``inf`` if diverged).
        time_s: simulated time reached.
    """

    held: bool
    diverged: bool
    rms_error: float
    rms_velocity: float
    time_s: float


#: thresholds of :func:`hold_pose` (rad, rad/s)
HOLD_ERROR = 0.05
HOLD_VELOCITY = 0.5


def hold_pose(character: Character, controller: str, *, kp: float, timestep: float,
              duration: float = 5.0, seed: int = 0, perturbation: float = 0.2,
              kd: float | None = None, torque_limits: bool = False) -> HoldResult:
    """Can PD variant ``controller`` (``pd``, ``spd``, ``native_pd``) hold the standing pose?

    The root is welded 0.1 m above its standing height (no floor contact), every actuated dof
    starts off target by a uniform random error in ``[-perturbation, perturbation]`` rad (seeded),
    and the controller, with uniform gains ``kp`` and ``kd`` (default ``kp / 10``), runs for
    ``duration`` s at ``timestep`` s, acting every physics step. The torque limits are lifted
    unless ``torque_limits``: the check is about integrating the PD law; with limits, a clamped
    native actuator loses its implicit damping in MuJoCo and saturation limit cycles appear.
    """
    if controller not in ("pd", "spd", "native_pd"):
        raise ScenarioError(f"hold_pose is for the PD variants, not {controller!r}")
    rng = np.random.default_rng(seed)
    character.set_timestep(timestep)
    pose = standing_pose(character)
    pose[character.root_qpos[2]] += 0.1
    v = np.zeros(character.nv)
    v[character.actuated] = rng.uniform(-perturbation, perturbation, int(character.actuated.sum()))
    start = character.integrate(pose, v, 1.0)
    character.reset(start)
    character.weld_root(True)  # the root of `start` is the root of `pose`
    ctrl = make_controller(controller, character, pose, gains=Gains.uniform(character, kp, kd))
    ctrl.reset(character)
    character.set_torque_limits(torque_limits)
    n = int(round(duration / timestep))
    tail = max(1, int(round(1.0 / timestep)))
    act = character.actuated
    err2 = vel2 = 0.0
    try:
        for k in range(n):
            character.step(ctrl.act(character, character.time))
            if k >= n - tail:
                e = character.difference(character.qpos, pose)[act]
                err2 += float(e @ e) / len(e)
                q = character.qvel[act]
                vel2 += float(q @ q) / len(q)
    except SimulationDiverged:
        return HoldResult(False, True, math.inf, math.inf, character.time)
    finally:
        character.set_torque_limits(True)
        character.weld_root(False)
    rms_e, rms_v = math.sqrt(err2 / tail), math.sqrt(vel2 / tail)
    return HoldResult(rms_e < HOLD_ERROR and rms_v < HOLD_VELOCITY, False, rms_e, rms_v,
                      character.time)


def run_scenario(name: str, character: Character, controller, *, reference=None, **kw) -> Result:
    """Dispatch by scenario name (:data:`SCENARIOS`)."""
    if name == "stand":
        return stand(character, controller, **kw)
    if name == "push":
        return push(character, controller, **kw)
    if name == "push-search":
        raise ScenarioError("push-search is measured by the push protocol: "
                            "mjchar.controllers.core.push_protocol.survival_rates")
    if name == "random-push":
        return random_push(character, controller, **kw)
    if name == "track":
        return track(character, controller, reference, **kw)
    if name == "walk":
        return walk(character, controller, reference, **kw)
    raise ScenarioError(f"unknown scenario {name!r}; choose from {', '.join(SCENARIOS)}")
