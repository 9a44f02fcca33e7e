"""Terrain and gait scenarios for walking controllers (SIMBICON and any controller with an FSM).

- **Slopes**: :func:`tilt_floor` turns the ``floor`` plane of a Character's model at run time
  (``character.contacts.set_floor``; no XML edit), ``character.contacts.floor_height`` gives its
  height anywhere, :func:`place_on_floor` puts a pose on it.
- **Walk starts**: :func:`walk_start` is a walker's own start state (with a small seeded
  perturbation) on a level or tilted floor; :class:`GaitDriver` records the walk (steady speed,
  terrain-relative falls). The ``walk`` and ``slopes`` scenarios
  (:mod:`~mjchar.controllers.core.scenarios.locomotion`) are built on them.
- **Pushes at a phase of the stride**: :func:`push_walk` pushes the torso horizontally for
  0.2 s at a chosen fraction of the stride (a stride = two steps, from one entry into FSM state
  0 to the next; its length is the previous stride's) and direction (degrees in the heading
  frame: 0 forward, 90 left, 180 back, 270 right), after a warm-up, and checks that the
  walker is still walking ``after`` s later; :func:`stride_phases` spreads ``n`` phases over a
  stride. Rates over phases, seeds and forces:
  :mod:`~mjchar.controllers.core.scenarios.push_search`.

Every run goes through :func:`~mjchar.controllers.core.scenarios.shared.simulate` (falls,
divergence, root force bookkeeping). On a slope the shared fall test (root height in world z, bodies
touching the floor) is complemented by a terrain-relative one (root height above the floor under
it), done by :class:`GaitDriver`, the thin wrapper that schedules phase pushes and records the walk.

A controller used here needs ``reset``/``act`` (the Controller protocol) and, for phase pushes,
``transitions``: a list of ``(time, state)`` whose entries with state 0 mark stride starts.
``start_state(character, rng)`` is used when present (else the standing pose).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjchar.bvh.errors import MjcharError

from ..character import Character
from ..metrics import FALL_HEIGHT_FRACTION, Result
from .shared import heading_frame_direction, perturbed_start, simulate, standing_pose


class TerrainError(MjcharError):
    """A terrain or gait scenario was given something impossible (bad slope, phase, force)."""


# -- slopes ----------------------------------------------------------------------------------------
def tilt_floor(
    character: Character, degrees: float, *, heading: float = 0.0, height: float = 0.0
) -> None:
    """Tilt the character's floor plane so it rises by ``degrees`` towards ``heading``.

    Args:
        degrees: slope angle (deg, ``-45 < degrees < 45``); positive rises along ``heading``
            (uphill), negative falls (downhill); 0 restores a level floor.
        heading: world yaw (deg) of the uphill direction (0 = +x, the humanoid's facing).
        height: floor height (m) at the world origin.
    """
    if not (math.isfinite(degrees) and abs(degrees) < 45.0):
        raise TerrainError(f"slope must be between -45 and 45 degrees, got {degrees}")
    if not (math.isfinite(heading) and math.isfinite(height)):
        raise TerrainError("slope heading and height must be finite numbers")
    a = math.radians(degrees)
    h = math.radians(heading)
    # rotation about the horizontal axis perpendicular to the heading: a rotation by -a about
    # the left axis (-sin h, cos h, 0) raises the plane along (cos h, sin h, 0)
    axis = np.array([-math.sin(h), math.cos(h), 0.0])
    quat = np.concatenate([[math.cos(-a / 2)], math.sin(-a / 2) * axis])
    character.contacts.set_floor(quat, height)
    character.reset(character.state.qpos.copy(), character.state.qvel.copy())


def place_on_floor(character: Character, qpos: np.ndarray, clearance: float = 0.0) -> np.ndarray:
    """``(nq,)`` copy of ``qpos`` with the root moved vertically so the character's lowest geom
    point (measured along the floor's normal, capsules and boxes exactly) is ``clearance`` m
    above a level or tilted floor."""
    contacts = character.contacts
    n = contacts.floor_normal()
    q = np.array(qpos, dtype=float)
    lowest = character.poses.clearance(q, n, contacts.floor_origin())
    q[character.root_qpos[2]] += (clearance - lowest) / n[2]
    return q


# -- the scenario wrapper --------------------------------------------------------------------------
@dataclass
class PhasePush:
    """A push at a phase of the stride.

    Attributes:
        force: N (horizontal magnitude).
        direction: degrees in the heading frame (0 forward, 90 left, 180 back, 270 right).
        phase: fraction of the stride in ``[0, 1)`` (0 = entry into FSM state 0).
        duration: s.
        body: body pushed (default: the last spine joint, the chest).
        after: earliest time (s) of the stride the push falls in (warm-up).
    """

    force: float
    direction: float
    phase: float
    duration: float = 0.2
    body: str | None = None
    after: float = 4.0

    def check(self) -> None:
        if not (math.isfinite(self.force) and self.force >= 0):
            raise TerrainError(f"push force must be a non-negative number of N, got {self.force}")
        if not (0.0 <= self.phase < 1.0):
            raise TerrainError(f"push phase must be in [0, 1), got {self.phase}")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise TerrainError(f"push duration must be positive seconds, got {self.duration}")
        if not math.isfinite(self.direction):
            raise TerrainError(f"push direction must be a number of degrees, got {self.direction}")


class GaitDriver:
    """Wraps a walking controller for a scenario: schedules a :class:`PhasePush`, records the
    root's path and checks the height above a (possibly tilted) floor.

    It applies nothing itself: the push is an external force scheduled on the Character
    (``Character.push``), the controller's actions pass through unchanged.

    Attributes:
        push_time: when the push was scheduled to start (s), ``None`` before.
        push_world: ``(3,)`` the push force (N, world).
        fell, fall_time: terrain-relative fall (root lower than ``fall_fraction`` of its
            standing height above the floor under it).
        path: list of ``(t, x, y, z)`` root positions every ``sample_dt`` s.
    """

    def __init__(
        self,
        controller,
        push: PhasePush | None = None,
        *,
        fall_fraction: float = FALL_HEIGHT_FRACTION,
        sample_dt: float = 0.05,
    ):
        self.controller = controller
        self.name = getattr(controller, "name", type(controller).__name__)
        self.push = push
        self.fall_fraction = fall_fraction
        self.fall_height = 0.0
        self.sample_dt = sample_dt
        self.push_time: float | None = None
        self.push_world = np.zeros(3)
        self.fell = False
        self.fall_time: float | None = None
        self.path: list[tuple[float, float, float, float]] = []
        self._next_sample = 0.0

    @property
    def actuation(self) -> str:
        return self.controller.actuation

    def reset(self, character: Character) -> None:
        self.controller.reset(character)
        standing = character.poses.standing()[character.root_qpos[2]]
        self.fall_height = self.fall_fraction * float(standing)
        self.push_time = None
        self.fell, self.fall_time = False, None
        self.path = []
        self._next_sample = character.time

    def act(self, character: Character, t: float):
        action = self.controller.act(character, t)
        if self.push is not None and self.push_time is None:
            self._maybe_schedule(character, t)
        if t >= self._next_sample - 1e-9:
            p = character.state.root_position
            self.path.append((t, float(p[0]), float(p[1]), float(p[2])))
            self._next_sample += self.sample_dt
            if not self.fell and p[2] - character.contacts.floor_height(p[:2]) < self.fall_height:
                self.fell, self.fall_time = True, t
        return action

    def _maybe_schedule(self, character: Character, t: float) -> None:
        tr = getattr(self.controller, "transitions", None)
        if tr is None:
            raise TerrainError(f"{self.name} has no FSM transitions: cannot push at a phase")
        if not tr or tr[-1][1] != 0 or tr[-1][0] != t or t < self.push.after:
            return  # a stride starts now (the controller just entered state 0), after warm-up
        starts = [s for s, state in tr if state == 0]
        if len(starts) < 2:
            return
        stride = starts[-1] - starts[-2]
        t0 = t
        body = self.push.body or character.roles("spine")[-1]
        f = self.push.force * heading_frame_direction(character, self.push.direction)
        self.push_time = t0 + self.push.phase * stride
        self.push_world = f
        if self.push.force > 0:
            character.pushes.add(body, f, self.push.duration, start=self.push_time)

    def speed(self, t0: float, t1: float) -> float:
        """Mean horizontal root speed (m/s) between ``t0`` and ``t1`` (s) from the path."""
        a = np.array(self.path)
        if len(a) < 2:
            return 0.0
        sel = a[(a[:, 0] >= t0 - 1e-9) & (a[:, 0] <= t1 + 1e-9)]
        if len(sel) < 2 or sel[-1, 0] - sel[0, 0] <= 0:
            return 0.0
        return float(
            np.hypot(sel[-1, 1] - sel[0, 1], sel[-1, 2] - sel[0, 2]) / (sel[-1, 0] - sel[0, 0])
        )


#: the seeded start perturbation of a walker without its own ``start_state`` (the same sizes as
#: SIMBICON's): rad per actuated dof, m/s per horizontal axis of the root
START_JOINT_NOISE = 0.02
START_VELOCITY_NOISE = 0.05


def walk_start(
    character: Character, controller, seed: int | None, perturb: bool, clearance: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Start state from the controller (``start_state``, given the seeded generator) or the
    standing pose, on the floor. A controller without ``start_state`` gets the same small seeded
    perturbation (joint angles ~N(0, :data:`START_JOINT_NOISE`) rad, root horizontal velocity
    ~N(0, :data:`START_VELOCITY_NOISE`) m/s), so its seeds are different runs."""
    rng = np.random.default_rng(seed) if (perturb and seed is not None) else None
    inner = getattr(controller, "controller", controller)
    if hasattr(inner, "start_state"):
        q, v = inner.start_state(character, rng)
    elif rng is not None:
        q, v = perturbed_start(character, standing_pose(character), None, seed,
                               joint_noise=START_JOINT_NOISE,
                               root_velocity_noise=START_VELOCITY_NOISE)
    else:
        q, v = standing_pose(character), np.zeros(character.nv)
    return place_on_floor(character, q, clearance), v


def finish_walk(r: Result, driver: GaitDriver, steady_window: float) -> Result:
    """``r`` with the driver's terrain-relative fall and ``extra["steady_speed_mps"]`` (the
    root's mean horizontal speed over the last ``steady_window`` s)."""
    if driver.fell and not r.fell:
        r.fell, r.fall_time_s = True, driver.fall_time
        r.fall_reason = "root too low above the floor under it"
    end = r.sim_time_s
    r.extra["steady_speed_mps"] = driver.speed(max(0.0, end - steady_window), end)
    return r


# -- pushes at a phase of the stride ---------------------------------------------------------------
def push_walk(
    character: Character,
    controller,
    *,
    force: float,
    direction: float = 0.0,
    phase: float = 0.0,
    push_duration: float = 0.2,
    body: str | None = None,
    warmup: float = 4.0,
    after: float = 10.0,
    seed: int | None = 0,
    min_speed: float = 0.3,
    **kw,
) -> Result:
    """Walk, push the torso (``body``, default the chest) with ``force`` N for ``push_duration``
    s towards ``direction`` (deg, heading frame) at ``phase`` of the first stride that starts
    after ``warmup`` s, and keep going ``after`` s past the push's end.

    Survived (``max_push_N == force``) when it did not fall and still walks: mean speed over the
    last 5 s at least ``min_speed`` m/s. ``Result.extra``: ``push_time_s``, ``phase``,
    ``walking_after`` (bool), ``steady_speed_mps``.
    """
    push = PhasePush(force, direction, phase, push_duration, body, warmup)
    push.check()
    driver = GaitDriver(controller, push)
    q, v = walk_start(character, controller, seed, True)
    # the push starts within two strides after the warm-up
    duration = warmup + 3.0 + push_duration + after
    r = simulate(
        character, driver, duration=duration, scenario="push", qpos=q, qvel=v, seed=seed, **kw
    )
    r = finish_walk(r, driver, 5.0)
    r.push_N, r.push_direction_deg = float(force), float(direction)
    pt = driver.push_time
    r.extra.update(push_time_s=pt, phase=phase)
    walking = (
        pt is not None
        and not r.fell
        and r.sim_time_s >= pt + push_duration + after - 1e-6
        and r.extra["steady_speed_mps"] >= min_speed
    )
    r.extra["walking_after"] = bool(walking)
    r.max_push_N = float(force) if walking else 0.0
    return r


def stride_phases(n: int = 8) -> list[float]:
    """``n`` phases spread evenly over a stride: ``[0, 1/n, ..., (n-1)/n]``."""
    if n < 1:
        raise TerrainError(f"need at least one phase, got {n}")
    return [k / n for k in range(n)]
