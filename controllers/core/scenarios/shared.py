"""The building blocks every scenario shares: the simulation loop and its start states.

- :func:`simulate`: reset, schedule events, run a controller, watch for falls, aggregate the
  metrics into a :class:`~mjchar.controllers.core.metrics.Result`. A divergence is caught and
  reported as a fall (``diverged``), never raised.
- Start states: :func:`standing_pose` (the rest pose on the floor), :func:`perturbed_start`
  (seeded joint and root-velocity noise).
- Pushes: :class:`PushEvent` (one horizontal push while standing, tracking or walking),
  :func:`with_push`, :func:`heading_frame_direction`, :data:`DIRECTIONS`, :func:`survived`.

Randomness comes only from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..character import Character
from ..errors import SimulationDiverged
from ..geometry import heading_yaw
from ..limits import duration_problem
from ..metrics import STEP_DISTANCE, FallDetector, Recorder, Result
from .registry import ScenarioError

#: the four horizontal push directions (degrees in the heading frame)
DIRECTIONS = {"forward": 0.0, "left": 90.0, "backward": 180.0, "right": 270.0}


# -- building blocks -----------------------------------------------------------------------------
def standing_pose(character: Character) -> np.ndarray:
    """``(nq,)`` the model's rest pose (``qpos0``) with the feet on the floor."""
    return character.poses.standing()


def heading_frame_direction(character: Character, degrees: float) -> np.ndarray:
    """``(3,)`` unit horizontal world vector at ``degrees`` from the character's facing
    direction (its root x axis projected on the floor), counter-clockwise seen from above."""
    a = heading_yaw(character.state.root_rotation) + math.radians(degrees)
    return np.array([math.cos(a), math.sin(a), 0.0])


def simulate(character: Character, controller, *, duration: float, scenario: str,
             qpos: np.ndarray, qvel: np.ndarray | None = None, reference=None,
             control_dt: float | None = None, events: Callable[[Character], None] | None = None,
             seed: int | None = None, stop_on_fall: bool = True,
             fall_height: float | None = None, frame_callback=None,
             progress=None) -> Result:
    """Run ``controller`` on ``character`` from ``(qpos, qvel)`` for ``duration`` s.

    Args:
        events: called once at the start (after the reset) to schedule pushes on the character.
        control_dt: seconds between control steps (default: every physics step); rounded to a
            whole number of physics steps.
        frame_callback: called as ``frame_callback(character)`` once after the reset (the
            start state) and after every control step (video capture, BVH export).
        progress: a :class:`~mjchar.progress.Progress` shown the simulated
            time (a bar on a terminal), or ``None``.
    Returns:
        the :class:`Result` (a fall or a divergence ends the run when ``stop_on_fall``).
    """
    problem = duration_problem(duration)
    if problem:
        raise ScenarioError(f"the run's duration {problem}")
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
    if progress is not None:
        progress.start(duration, desc=f"{getattr(controller, 'name', 'run')} {scenario}")
    t0 = character.time
    wall0 = time.perf_counter()
    try:
        for _ in range(n_control):
            action = controller.act(character, character.time)
            character.step(action, n_sub)
            steps += n_sub
            rec.record(character)
            if frame_callback is not None:
                frame_callback(character)
            if progress is not None:
                progress.update(character.time - t0)
            if not fell:
                why = fall.check(character)
                if why is not None:
                    fell, fall_time, reason = True, character.time, why
                    if stop_on_fall:
                        break
    except SimulationDiverged as e:
        fell, diverged, reason = True, True, str(e)
        fall_time = e.time if fall_time is None else fall_time
    finally:
        if progress is not None:
            progress.close()
    return _result(character, controller, scenario, rec, fell=fell, fall_time=fall_time,
                   reason=reason, diverged=diverged, steps=steps,
                   wall=time.perf_counter() - wall0, control_dt=dt * n_sub, seed=seed)


def _result(character: Character, controller, scenario: str, rec: Recorder, *, fell: bool,
            fall_time: float | None, reason: str | None, diverged: bool, steps: int,
            wall: float, control_dt: float, seed: int | None) -> Result:
    """The :class:`Result` of a run :func:`simulate` ended: what ``rec`` recorded (errors also
    against a conditioned clip's raw one) and how the run went."""
    dt = character.timestep
    agg = rec.aggregates()
    track, root_err = rec.tracking_errors()
    extra = {}
    raw = getattr(rec.reference, "raw_reference", None)
    if raw is not None:  # a conditioned clip: the error against the raw one too
        raw_track, raw_root = rec.tracking_errors(reference=raw)
        extra = {"tracking_error_raw_m": raw_track, "root_error_raw_m": raw_root,
                 "conditioning": rec.reference.conditioning.summary()}
    sim_time = character.time
    return Result(
        controller=getattr(controller, "name", type(controller).__name__), scenario=scenario,
        fell=fell, fall_time_s=fall_time, sim_time_s=sim_time, distance_m=agg["distance_m"],
        mean_speed_mps=agg["distance_m"] / sim_time if sim_time > 0 else 0.0,
        tracking_error_m=track, root_error_m=root_err,
        root_force_mean_N=agg["root_force_mean_N"], root_force_max_N=agg["root_force_max_N"],
        root_torque_mean_Nm=agg["root_torque_mean_Nm"],
        root_torque_max_Nm=agg["root_torque_max_Nm"], max_push_N=None,
        wall_s=wall, steps_per_s=steps / wall if wall > 0 else 0.0, timestep_s=dt,
        control_dt_s=control_dt, n_steps=steps, seed=seed, diverged=diverged,
        fall_reason=reason, foot_travel_m=agg["foot_travel_m"],
        stepped=agg["foot_travel_m"] > STEP_DISTANCE, com_drop_m=agg["com_drop_m"],
        extra=extra)


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
            ch.pushes.add(push.body or ch.role("pelvis"), f, push.end - ch.time, start=ch.time)
            done[0] = True

    return {**kw, "events": chain_callbacks(kw.get("events"), schedule),
            "frame_callback": chain_callbacks(schedule, inner)}


def survived(result: Result, allow_steps: bool = False) -> bool:
    """No fall, and (unless ``allow_steps``) no foot moved by a step."""
    return not result.fell and (allow_steps or not result.stepped)


def perturbed_start(character: Character, qpos: np.ndarray, qvel: np.ndarray | None,
                    seed: int, *, joint_noise: float = 0.1, root_velocity_noise: float = 0.2,
                    distribution: str = "normal", on_floor: bool = True
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``(qpos (nq,), qvel (nv,))`` perturbed from ``numpy.random.default_rng(seed)``.

    Every actuated dof moves by a random angle: Gaussian of ``joint_noise`` rad standard
    deviation (``distribution="normal"``) or uniform in ``[-joint_noise, joint_noise]``
    (``"uniform"``); then, when ``root_velocity_noise`` > 0, the root's horizontal velocity
    changes by a Gaussian of that many m/s per axis (the defaults: the MPC's perturbed starts). The
    pose is lifted or lowered so its lowest point touches the floor (``on_floor``). ``qvel``
    ``None``: at rest.
    """
    rng = np.random.default_rng(seed)
    act = character.actuated
    dv = np.zeros(character.nv)
    if distribution == "normal":
        dv[act] = rng.normal(0.0, joint_noise, int(act.sum()))
    elif distribution == "uniform":
        dv[act] = rng.uniform(-joint_noise, joint_noise, int(act.sum()))
    else:
        raise ScenarioError(f"distribution must be 'normal' or 'uniform', got {distribution!r}")
    q = character.dynamics.integrate(np.asarray(qpos, float), dv, 1.0)
    if on_floor:
        q = character.poses.on_floor(q)
    v = np.zeros(character.nv) if qvel is None else np.array(qvel, dtype=float)
    if root_velocity_noise > 0:
        v[character.root_dofs[:2]] += rng.normal(0.0, root_velocity_noise, 2)
    return q, v


def check_push(push: PushEvent | None, duration: float) -> None:
    """A :class:`ScenarioError` when ``push`` ends after a run of ``duration`` s."""
    if push is not None and push.end > duration + 1e-9:
        raise ScenarioError(f"the push ({push.time} s + {push.duration} s) ends after the run "
                            f"({duration} s)")


def pushed(r: Result, push: PushEvent | None) -> Result:
    """``r`` with the push's force and direction recorded (when there was one)."""
    if push is not None:
        r.push_N, r.push_direction_deg = float(push.force), float(push.direction)
    return r


def chain_callbacks(*callbacks):
    """One frame callback calling each of ``callbacks`` that is not ``None`` (``None`` if
    there are none)."""
    live = [c for c in callbacks if c is not None]
    if not live:
        return None
    if len(live) == 1:
        return live[0]

    def call(character) -> None:
        for c in live:
            c(character)

    return call
