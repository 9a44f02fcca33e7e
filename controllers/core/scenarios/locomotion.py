"""Moving scenarios: ``track`` (follow a clip), ``walk`` and ``slopes``.

- ``track``: start on the reference's first frame and follow it (tracking errors). A controller
  that plays a saved trajectory (it has ``replay_setup``) brings its own start state, control
  step and reference, and is played instead (:mod:`.replay`). A clip that does not loop, like
  a saved trajectory, ends: a run past its end is refused (:func:`clip_duration`); ``--loop``
  repeats a clip.
- ``walk``: locomotion, reported as distance and speed. Trackers walk by tracking the clip (as
  ``track``); walkers walk from the standing pose at rest, or, with a ``seed``, from their own
  start state (``start_state``) with a small seeded perturbation. ``steady_window`` adds the
  steady speed over the last seconds.
- ``slopes``: walk up (``degrees`` > 0) or down a tilted floor; reached = no fall and
  ``distance`` covered along the slope.

``track`` with a ``seed`` starts from the clip's first frame perturbed from that seed
(:func:`~mjchar.controllers.core.scenarios.shared.perturbed_start`: joints N(0, 0.1 rad), root
velocity N(0, 0.2 m/s)). ``track`` and ``walk`` take one push while moving (``force``,
``direction``, ``push_time``, ``push_duration``), the same push the ``push`` scenario applies
to a standing character.
"""

from __future__ import annotations

import math

import numpy as np

from ..character import Character
from ..limits import MAX_DURATION_S
from ..metrics import Result
from .options import DISTANCE, DURATION, PUSH_WHILE_MOVING, SEED, SLOPE, STEADY_WINDOW
from .registry import BenchRun, ScenarioError, ScenarioSpec, register
from .replay import play, plays_itself
from .shared import (
    PushEvent,
    check_push,
    perturbed_start,
    pushed,
    simulate,
    standing_pose,
    with_push,
)
from .terrain import GaitDriver, TerrainError, finish_walk, place_on_floor, tilt_floor, walk_start

#: run length in s of a walk with no clip when no duration is given
WALK_DURATION = 10.0
#: slopes: the slope (deg) and the distance to cover along it (m) when not given
SLOPE_DEGREES, SLOPE_DISTANCE = 5.0, 20.0


def clip_duration(reference, duration: float | None, what: str = "clip") -> float:
    """How long a run following ``reference`` lasts: ``duration`` s, or the clip's length when
    ``None``. A clip that does not loop (``reference.cyclic`` false) ends with its last frame,
    so a longer run is refused in one line rather than tracking a frozen pose until it falls;
    and a run is at most :data:`~mjchar.controllers.core.limits.MAX_DURATION_S` long, however
    long the clip."""
    length = float(reference.duration)
    if duration is None:
        if length > MAX_DURATION_S:
            raise ScenarioError(f"the {what} lasts {length:g} s, longer than a run may "
                                f"({MAX_DURATION_S:g} s): give --duration")
        if not length > 0:
            raise ScenarioError(f"the {what} is a single frame (0 s long): a run follows at "
                                f"least 2 frames")
        return length
    if not getattr(reference, "cyclic", False) and duration > length + 1e-6:
        loop = " or --loop to repeat the clip" if what == "clip" else ""
        raise ScenarioError(f"--duration {duration:g} is past the end of the {length:.2f} s "
                            f"{what}; give --duration up to {length:.2f}{loop}")
    return duration


def track(character: Character, controller, reference, *, duration: float | None = None,
          scenario: str = "track", push: PushEvent | None = None,
          start: tuple[np.ndarray, np.ndarray] | None = None, **kw) -> Result:
    """Start on the reference's first frame (pose and velocity; or ``start``, e.g. a
    :func:`~mjchar.controllers.core.scenarios.shared.perturbed_start`) and run for
    ``duration`` s (default: the clip's duration); reports tracking and root errors against the
    reference. ``push``: one push while tracking (:class:`PushEvent`)."""
    if reference is None:
        raise ScenarioError(f"the {scenario} scenario needs a reference motion")
    duration = clip_duration(reference, duration)
    check_push(push, duration)
    q, v = (reference.qpos(0.0), reference.qvel(0.0)) if start is None else start
    r = simulate(character, controller, duration=duration, scenario=scenario, qpos=q, qvel=v,
                 reference=reference, **with_push(push, kw))
    return pushed(r, push)


def walk(character: Character, controller, reference=None, *, duration: float | None = None,
         push: PushEvent | None = None, seed: int | None = None,
         steady_window: float | None = None, slope: float = 0.0,
         target_distance: float | None = None, **kw) -> Result:
    """Locomotion for ``duration`` s (default: the clip's, else :data:`WALK_DURATION`).

    With a ``reference`` it is :func:`track` (reported as a walk). Without one the controller
    walks from the standing pose at rest, or, with a ``seed``, from its own start state
    (``start_state(character, rng)``, else the standing pose) perturbed from
    ``numpy.random.default_rng(seed)``, on level ground or a ``slope`` (deg, uphill positive)
    rising along the initial heading.

    ``Result.extra["steady_speed_mps"]`` (with a ``steady_window`` in s, a seed or a slope;
    default window 10 s): the root's mean horizontal speed over the last ``steady_window`` s;
    ``Result.mean_speed_mps`` is over the whole run (start-up included). On a slope,
    ``extra["slope_distance_m"]`` (along the slope) and, with ``target_distance`` (m),
    ``extra["time_to_distance_s"]``: when the root had first covered that much along the slope
    (``None`` if never). ``push``: one push while walking (:class:`PushEvent`). Other keyword
    arguments go to :func:`~mjchar.controllers.core.scenarios.shared.simulate`.
    """
    if reference is not None:
        return track(character, controller, reference, duration=duration, scenario="walk",
                     push=push, **kw)
    duration = WALK_DURATION if duration is None else duration
    check_push(push, duration)
    if seed is None and not slope and steady_window is None:  # the standing pose at rest
        r = simulate(character, controller, duration=duration, scenario="walk",
                     qpos=standing_pose(character), **with_push(push, kw))
        return pushed(r, push)
    driver = GaitDriver(controller)
    clearance = 0.002 if slope else 0.0
    with _slope(character, slope, duration):
        if seed is None:
            q, v = place_on_floor(character, standing_pose(character), clearance), None
        else:
            q, v = walk_start(character, controller, seed, True, clearance=clearance)
        r = simulate(character, driver, duration=duration, scenario="walk", qpos=q, qvel=v,
                     seed=seed, **with_push(push, kw))
    r = pushed(finish_walk(r, driver, 10.0 if steady_window is None else steady_window), push)
    if slope:
        r.scenario = f"slope {slope:+g} deg"
        r.extra["slope_distance_m"] = _slope_distance(driver, slope)
        if target_distance is not None:
            r.extra["time_to_distance_s"] = _time_to_distance(driver, slope, target_distance)
    return r


class _slope:
    """Context manager: tilt the floor for a run (placed so a downhill run never goes below
    z = 0, which keeps the shared absolute-height fall test meaningful), then level it."""

    def __init__(self, character: Character, degrees: float, duration: float):
        self.character, self.degrees = character, float(degrees)
        self.height = max(0.0, -math.sin(math.radians(self.degrees))) * 2.0 * duration

    def __enter__(self):
        if self.degrees:
            tilt_floor(self.character, self.degrees, height=self.height)

    def __exit__(self, *exc):
        if self.degrees:
            tilt_floor(self.character, 0.0)


def _slope_distance(driver: GaitDriver, degrees: float) -> float:
    """Distance (m) covered along the slope direction (+x) by the root, measured on the slope."""
    if len(driver.path) < 2:
        return 0.0
    a = np.array(driver.path)
    dx = a[-1, 1] - a[0, 1]
    return float(dx / math.cos(math.radians(degrees)))


def _time_to_distance(driver: GaitDriver, degrees: float, distance: float) -> float | None:
    """First time (s) the root had covered ``distance`` m along the slope, ``None`` if never."""
    if len(driver.path) < 2:
        return None
    a = np.array(driver.path)
    along = (a[:, 1] - a[0, 1]) / math.cos(math.radians(degrees))
    hit = np.flatnonzero(along >= distance)
    return float(a[hit[0], 0]) if len(hit) else None


def slope_walk(character: Character, controller, *, degrees: float = SLOPE_DEGREES,
               distance: float = SLOPE_DISTANCE, duration: float | None = None,
               seed: int | None = 0, **kw) -> Result:
    """Walk up (``degrees`` > 0) or down (< 0) a slope; success = no fall and at least
    ``distance`` m covered along the slope. ``duration`` defaults to ``distance / 0.6`` s.

    ``Result.extra``: ``slope_distance_m``, ``reached`` (bool), ``time_to_distance_s`` (when
    ``distance`` was first covered, ``None`` if never), ``steady_speed_mps``.
    """
    if not degrees:
        raise TerrainError("slope_walk needs a non-zero slope (use walk() for level ground)")
    duration = distance / 0.6 if duration is None else duration
    r = walk(character, controller, duration=duration, seed=seed, slope=degrees,
             target_distance=distance, **kw)
    r.extra["reached"] = bool(not r.fell and r.extra["slope_distance_m"] >= distance)
    return r


# -- registrations -------------------------------------------------------------------------------
def _push_event(force, direction, push_time, push_duration) -> PushEvent | None:
    """The push while moving, from the scenario options (``None`` without a force)."""
    if force is None:
        details = {"direction": direction, "push_time": push_time,
                   "push_duration": push_duration}
        given = [k for k, v in details.items() if v is not None]
        if given:
            raise ScenarioError(f"{given[0]} needs a force: one push while moving")
        return None
    return PushEvent(force, 0.0 if direction is None else direction,
                     1.0 if push_time is None else push_time,
                     0.2 if push_duration is None else push_duration)


def _track(run, *, duration=None, force=None, direction=None, push_time=None,
           push_duration=None, seed=None) -> Result:
    push = _push_event(force, direction, push_time, push_duration)
    if plays_itself(run.controller):  # a saved trajectory: its own start, step and reference
        if seed is not None:
            raise ScenarioError("a saved trajectory plays from its own start state: --seed "
                                "(a perturbed start) does not apply")
        return play(run.character, run.controller, duration=duration, push=push,
                    frame_callback=run.frame_callback,
                    progress=run.simulate_options()["progress"])
    start = None
    if seed is not None:  # the clip's first frame, perturbed (the MPC's perturbed starts)
        ref = run.reference
        start = perturbed_start(run.character, ref.qpos(0.0), ref.qvel(0.0), int(seed))
    return track(run.character, run.controller, run.reference, duration=duration, push=push,
                 start=start, seed=seed, **run.simulate_options())


def _walk(run, *, duration=None, force=None, direction=None, push_time=None,
          push_duration=None, seed=None, steady_window=None) -> Result:
    push = _push_event(force, direction, push_time, push_duration)
    return walk(run.character, run.controller, run.reference, duration=duration, push=push,
                seed=seed, steady_window=steady_window, **run.simulate_options())


def _slopes(run, *, duration=None, degrees=SLOPE_DEGREES, distance=SLOPE_DISTANCE,
            seed=None) -> Result:
    return slope_walk(run.character, run.controller, degrees=degrees, distance=distance,
                      duration=duration, seed=seed, **run.simulate_options())


def _walk_seeds(settings, controller) -> list[int | None]:
    """A walker with its own start state walks once per bench seed (perturbed from it); one
    without walks once from the standing pose (every seed would give the same run)."""
    return ([int(s) for s in settings["seeds"]] if hasattr(controller, "start_state")
            else [None])


def _seed_label(seed) -> str:
    return "no seed (deterministic start)" if seed is None else f"seed {seed}"


def _bench_track(settings, controller) -> list[BenchRun]:
    """The clip for ``track_duration`` s (default: all of it); a saved trajectory plays whole."""
    if plays_itself(controller):
        return [BenchRun("trajectory")]
    return [BenchRun("clip", None, {"duration": settings.get("track_duration")})]


def _bench_walk(settings, controller) -> list[BenchRun]:
    return [BenchRun(_seed_label(s), s, {"duration": settings["walk_duration"], "seed": s,
                                         "steady_window": settings["steady_window"]})
            for s in _walk_seeds(settings, controller)]


def _bench_slopes(settings, controller) -> list[BenchRun]:
    deg = abs(settings["slope_degrees"])
    return [BenchRun(f"{d:+g} deg, {_seed_label(s)}", s, {
        "degrees": d, "distance": settings["slope_distance"],
        "duration": settings["slope_duration"], "seed": s})
        for d in (deg, -deg) for s in _walk_seeds(settings, controller)]


register(ScenarioSpec(
    name="track", measures="follow the reference clip from its first frame (tracking errors)",
    procedure=_track, needs=("track", "replay"), options=(DURATION, *PUSH_WHILE_MOVING, SEED),
    reference="required", moving=True, bench=_bench_track))
register(ScenarioSpec(
    name="walk", measures="locomotion: distance and speed (trackers follow the clip; walkers "
                          "walk from the standing pose, or from their own seeded start)",
    procedure=_walk, needs=("walk", "track"),
    options=(DURATION, *PUSH_WHILE_MOVING, SEED, STEADY_WINDOW), reference="trackers",
    moving=True, default_duration=WALK_DURATION,
    bench=_bench_walk))
register(ScenarioSpec(
    name="slopes", measures="walk up or down a slope: the distance covered along it",
    procedure=_slopes, needs=("walk",), options=(DURATION, SLOPE, DISTANCE, SEED), moving=True,
    bench=_bench_slopes))
