"""Walkers fitted to the body they drive: calibration of SIMBICON and IPM by CMA-ES.

Wang, Fleet and Hertzmann 2009 ("Optimizing Walking Controllers") optimise SIMBICON's
parameters with CMA-ES on an objective of effort, speed and survival; Coros, Beaudoin and van
de Panne 2010 carry one controller to other bodies by expressing its parameters in body units
(leg length, mass, Froude speed), which both walkers here already do. What body units do not
cover (a body's mass distribution, its feet, the hinge axes a converter fitted), a short
optimisation on the body does.

A calibration is a small vector of a walker's body-dependent parameters (:data:`KNOBS`: foot
placement scales and gains, swing height, stance and tracking gains for IPM; balance feedback,
target angles and torso gains for SIMBICON), stored as the factory overrides it amounts to.
:func:`calibrate` is adaptive and cheap:

1. **Check** the defaults on short walks at :data:`SPEEDS` (``None``: SIMBICON's own gait
   speed): no fall, and a commanded speed within :data:`CHECK_TOLERANCE`. A body that passes
   is stored with no overrides (the defaults are its calibration) and no optimisation.
2. Otherwise **CMA-ES** (``cma``) from the defaults (``x = 0``) over the knobs in normalised
   units, each candidate walked at every speed of the check (evaluated in parallel on a process
   pool), on the cost :func:`walk_cost` (a fall costs more than any speed error, and costs less
   the later it comes), while the next generation fits in the time budget (default
   :data:`BUDGET_S`, counted as the walks' CPU time over the worker processes: the wall time
   on a machine of that many free cores). A candidate that passes the check walks
   :data:`CONFIRM_DURATION` s at every speed of the check's range, 0.1 m/s apart
   (:data:`CONFIRM_SPEEDS`), from the check's seeded start and again from the standing pose at
   rest (what ``mjchar run`` starts from), before it is kept: one that falls there or misses a
   speed is ruled out (a walker fitted on short walks can drift into a fall later, one fitted at
   a few speeds can fall between them, and one fitted from a walking start can fall from rest)
   and the search goes on. The
   best candidate is stored if it beats the defaults (a confirmed one first, else the first
   ruled out, which passed the check at least, but only where the defaults fell: defaults that
   walk too slowly or too fast fall less than a candidate that falls in its long walks); else
   the defaults are stored, marked ``"unimproved"``.

Calibrations are JSON files keyed by the model's physics fingerprint
(:func:`~mjchar.controllers.sampling.trajectory.model_fingerprint`), in the cache folder
(:func:`cache_dir`: ``$MJCHAR_CACHE/calibration``, else ``$XDG_CACHE_HOME/mjchar/calibration``,
else ``~/.cache/mjchar/calibration``), written atomically. The walkers' factories ask
:func:`overrides_for` for a body's calibration: the bundled humanoid's is its defaults (no file,
no run: its figures are the defaults' to the bit); another body's is read from the cache, or made
there first (one line on standard error says so; a stored one made by an earlier
:data:`PROTOCOL` is made again). ``calibration="none"`` (or the environment
variable ``MJCHAR_CALIBRATION=none``) runs the defaults; a file name uses that file, which must
have been made for the same body and walker.
"""

from __future__ import annotations

import contextlib
import json
import math
import multiprocessing
import os
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from mjchar import __version__
from mjchar.bvh.io.files import write_text

from ..core.base import ControllerError
from ..core.fingerprint import model_fingerprint
from ..core.workers import process_pool

#: the walkers that take a calibration
WALKERS = ("ipm", "simbicon")
#: the speeds (m/s) the check and the optimisation walk at; ``None``: SIMBICON's own gait speed
SPEEDS = {"ipm": (0.8, 1.0, 1.2), "simbicon": (None, 0.8, 1.0, 1.2)}
#: the speeds a candidate that passes the check then walks :data:`CONFIRM_DURATION` s at: the
#: check's range at 0.1 m/s spacing (a candidate fitted at the check's speeds can fall between
#: them: SIMBICON fitted at 0.8 and 1.2 m/s on a CMU body fell at 0.9-1.1 m/s)
CONFIRM_SPEEDS = {"ipm": (0.8, 0.9, 1.0, 1.1, 1.2),
                  "simbicon": (None, 0.8, 0.9, 1.0, 1.1, 1.2)}
#: seconds walked per speed by the check and by every candidate
CHECK_DURATION = 20.0
#: the last seconds of a walk whose mean speed is compared with the command (m/s)
STEADY_WINDOW = 8.0
#: the check passes within this speed error (m/s) at every speed (the must-show's 0.15 less a
#: margin for the longer walk)
CHECK_TOLERANCE = 0.1
#: seconds an optimised candidate that passes the check then walks at every speed before it is
#: stored (a walker fitted on 20 s walks can drift into a fall later); one that falls is
#: ruled out and the search goes on
CONFIRM_DURATION = 60.0
#: default optimisation time (s) per body (including the check)
BUDGET_S = 300.0
#: what the factories' ``calibration`` option and ``MJCHAR_CALIBRATION`` take besides a file
NO_CALIBRATION = "none"
FORMAT = "mjchar-calibration"
VERSION = 1
#: the calibration procedure's version (its speeds, durations, starts and tolerances): a
#: calibration in the cache made by another is made again (3: the long walks start from rest
#: too), but for one that kept the defaults by a check that has not changed since
PROTOCOL = 3
#: the last :data:`PROTOCOL` that changed the check (its speeds, duration and tolerance): the
#: whole result of a calibration that kept the defaults
CHECK_PROTOCOL = 2


class CalibrationError(ControllerError):
    """A calibration cannot be read, does not fit the body, or was asked for a walker that takes
    none."""


class Knob(NamedTuple):
    """One calibrated parameter: ``name`` (a factory override; ``*`` scales a gain pair),
    ``default``, and how a normalised ``x`` moves it: ``"scale"`` (``default * exp(step x)``) or
    ``"shift"`` (``default + step x``), clipped to ``bounds``."""

    name: str
    default: float
    how: str
    step: float
    bounds: tuple[float, float]

    def value(self, x: float) -> float:
        v = self.default * math.exp(self.step * x) if self.how == "scale" else (
            self.default + self.step * x)
        return float(min(max(v, self.bounds[0]), self.bounds[1]))


#: the body-dependent parameters each walker's calibration moves (values for the tuned body:
#: the walkers carry them to the driven body by similarity)
KNOBS: dict[str, tuple[Knob, ...]] = {
    "ipm": (
        Knob("placement.sagittal_scale", 1.0, "scale", 0.15, (0.5, 2.0)),
        Knob("placement.coronal_scale", 1.0, "scale", 0.15, (0.5, 2.0)),
        Knob("placement.speed_offset", 0.1, "shift", 0.05, (-0.2, 0.4)),
        Knob("placement.step_width", 0.03, "shift", 0.02, (-0.05, 0.12)),
        Knob("stance.knee", 0.15, "shift", 0.08, (0.0, 0.5)),
        Knob("force.sagittal", 30.0, "scale", 0.3, (5.0, 150.0)),
        Knob("tracking.hip*", 1.0, "scale", 0.25, (0.4, 2.5)),
        Knob("tracking.pelvis*", 1.0, "scale", 0.25, (0.4, 2.5)),
        Knob("timing.step_time", 0.5, "scale", 0.1, (0.35, 0.7)),
    ),
    "simbicon": (
        Knob("cd", 0.534, "shift", 0.15, (-0.5, 2.0)),
        Knob("cv", 0.208, "shift", 0.1, (-0.5, 1.5)),
        Knob("cd_coronal", 0.657, "shift", 0.15, (-0.5, 2.0)),
        Knob("cv_coronal", 0.188, "shift", 0.1, (-0.5, 1.5)),
        Knob("torso_pitch", 0.298, "shift", 0.08, (-0.2, 0.6)),
        Knob("state0_swing_hip", 0.576, "shift", 0.1, (0.0, 1.2)),
        Knob("state1_swing_hip", 0.131, "shift", 0.08, (-0.4, 0.8)),
        Knob("state1_stance_knee", 0.146, "shift", 0.08, (0.0, 0.6)),
        Knob("gain_swing_hip*", 1.0, "scale", 0.25, (0.4, 2.5)),
        Knob("gain_torso*", 1.0, "scale", 0.25, (0.4, 2.5)),
    ),
}


@dataclass
class Calibration:
    """A walker's calibration for one body.

    Attributes:
        walker: ``"ipm"`` or ``"simbicon"``.
        fingerprint: the body's :func:`model_fingerprint`.
        overrides: the factory options it amounts to (``{}``: the defaults).
        status: ``"defaults"`` (the check passed), ``"optimised"`` or ``"unimproved"`` (the
            optimisation found nothing better than the defaults within its budget).
        check: per speed, the defaults' walk (``speed``, ``fell``, ``fall_time_s``,
            ``steady_speed_mps``) and, when optimised, ``calibrated``: the best candidate's.
        confirmed: the stored candidate's :data:`CONFIRM_DURATION` walks (empty: the defaults,
            or no candidate passed the check, or the budget ended first); ``rejected``: the
            candidates that passed the check and fell in their long walks, with those walks.
        cost_defaults, cost: :func:`walk_cost` of the defaults and of the stored overrides.
        evaluations: candidates walked (the check and each long walk included); seconds: wall
            time; cpu_seconds: the walks' CPU time (what the budget counts, spread over ``jobs``
            worker processes: the wall time on that many cores of its own).
        protocol: the :data:`PROTOCOL` that made it (a file written before the field existed
            reads as 1).
    """

    walker: str
    fingerprint: str
    overrides: dict[str, Any] = field(default_factory=dict)
    status: str = "defaults"
    check: list[dict] = field(default_factory=list)
    calibrated: list[dict] = field(default_factory=list)
    confirmed: list[dict] = field(default_factory=list)
    rejected: list[list[dict]] = field(default_factory=list)
    cost_defaults: float = 0.0
    cost: float = 0.0
    evaluations: int = 0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    jobs: int = 1
    version: str = __version__
    protocol: int = PROTOCOL

    def to_json(self) -> str:
        return json.dumps({"format": FORMAT, "format_version": VERSION, **asdict(self)},
                          indent=1) + "\n"

    @classmethod
    def from_json(cls, text: str, where: str = "calibration") -> Calibration:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise CalibrationError(f"{where}: not a calibration file ({e.msg}, line {e.lineno})"
                                   ) from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise CalibrationError(f"{where}: not a calibration file (made by mjchar calibrate)")
        if data.get("format_version") != VERSION:
            raise CalibrationError(f"{where}: calibration format {data.get('format_version')!r}"
                                   f", this mjchar reads {VERSION}: run mjchar calibrate again")
        data = {"protocol": 1, **{k: v for k, v in data.items()
                                  if k not in ("format", "format_version")}}
        try:
            cal = cls(**data)
        except TypeError as e:
            raise CalibrationError(f"{where}: a calibration file with unknown fields ({e})"
                                   ) from None
        if cal.walker not in WALKERS or not isinstance(cal.overrides, dict):
            raise CalibrationError(f"{where}: a calibration of {cal.walker!r}, not of "
                                   f"{' or '.join(WALKERS)}")
        return cal


# -- where calibrations live -----------------------------------------------------------------
def cache_dir() -> Path:
    """The folder of stored calibrations (see the module docstring); not created here."""
    root = os.environ.get("MJCHAR_CACHE")
    if not root:
        xdg = os.environ.get("XDG_CACHE_HOME")
        root = str(Path(xdg) / "mjchar") if xdg else str(Path.home() / ".cache" / "mjchar")
    return Path(root) / "calibration"


def cache_path(model: mujoco.MjModel, walker: str) -> Path:
    """The cache file of ``walker``'s calibration of ``model``."""
    _check_walker(walker)
    return cache_dir() / f"{walker}-{model_fingerprint(model)}.json"


def save(cal: Calibration, path: str | os.PathLike | None = None) -> Path:
    """Write ``cal`` atomically to ``path`` (default: its cache file); returns the path."""
    if path is None:
        path = cache_dir() / f"{cal.walker}-{cal.fingerprint}.json"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text(path, cal.to_json())


def load(path: str | os.PathLike) -> Calibration:
    """The calibration in ``path`` (a one-line :class:`CalibrationError` if it is none)."""
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise CalibrationError(f"cannot read calibration {path}: {e.strerror or e}") from None
    return Calibration.from_json(text, str(path))


@lru_cache(maxsize=1)
def _bundled_fingerprint() -> str:
    from mjchar.bvh.bundled.assets import HUMANOID_XML

    return model_fingerprint(mujoco.MjModel.from_xml_path(str(HUMANOID_XML)))


def is_bundled(model: mujoco.MjModel) -> bool:
    """Whether ``model`` is the bundled humanoid (its physics, whatever the file's name)."""
    return model_fingerprint(model) == _bundled_fingerprint()


def _check_walker(walker: str) -> None:
    if walker not in WALKERS:
        raise CalibrationError(f"no calibration for {walker!r}; walkers that take one: "
                               f"{', '.join(WALKERS)}")


# -- what the factories call -----------------------------------------------------------------
def overrides_for(character, walker: str, calibration: str | os.PathLike | None = None,
                  *, announce: Callable[[str], None] | None = None) -> dict[str, Any]:
    """The factory overrides of ``walker``'s calibration for ``character``'s body.

    ``calibration``: ``None`` (the ``MJCHAR_CALIBRATION`` environment variable if set, else
    the cache: the bundled humanoid's defaults, a stored calibration, or one made now and
    stored), ``"none"`` (the defaults) or a calibration file. ``announce`` gets the one line
    said before calibrating (default: standard error)."""
    _check_walker(walker)
    if calibration is None:
        calibration = os.environ.get("MJCHAR_CALIBRATION") or None
    if character is None or (isinstance(calibration, str)
                             and calibration.lower() == NO_CALIBRATION):
        return {}
    model = character.model
    if calibration is not None:
        cal = load(calibration)
        if cal.walker != walker:
            raise CalibrationError(f"{calibration}: a calibration of {cal.walker}, not {walker}")
        if cal.fingerprint != model_fingerprint(model):
            raise CalibrationError(f"{calibration}: made for another body (run mjchar calibrate "
                                   "on this model)")
        return dict(cal.overrides)
    if is_bundled(model):
        return {}
    path = cache_path(model, walker)
    why = "first (once,"
    if path.exists():
        stored = load(path)
        if is_current(stored):
            return dict(stored.overrides)
        why = "again (its stored calibration was made by an earlier procedure;"
    say = announce or _stderr
    say(f"calibrating {walker} for this body {why} at most {BUDGET_S / 60:.0f} min; stored in "
        f"{path.parent}; calibration='none' or --calibration none skips it)")
    cal = calibrate(model, walker, info=character.info)
    save(cal, path)
    return dict(cal.overrides)


def is_current(cal: Calibration) -> bool:
    """Whether the procedure of today would make ``cal`` again: it was made by this
    :data:`PROTOCOL`, or it kept the defaults by the check of today (:data:`CHECK_PROTOCOL`:
    the later protocols changed only what an optimised candidate must then show)."""
    return cal.protocol == PROTOCOL or (cal.status == "defaults"
                                        and CHECK_PROTOCOL <= cal.protocol <= PROTOCOL)


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


# -- the objective ---------------------------------------------------------------------------
def candidate_overrides(walker: str, x: np.ndarray | None) -> dict[str, Any]:
    """The factory overrides of normalised knob values ``x`` ``(n,)`` (``None``: the
    defaults, ``{}``)."""
    if x is None:
        return {}
    out: dict[str, Any] = {}
    defaults = _gain_pairs(walker)
    for knob, xi in zip(KNOBS[walker], np.asarray(x, dtype=float), strict=True):
        v = knob.value(float(xi))
        if knob.name.endswith("*"):
            base = knob.name[:-1]
            for name, default in defaults[base]:
                out[name] = ([d * v for d in default] if isinstance(default, (list, tuple))
                             else default * v)
        else:
            out[knob.name] = v
    return out


def _gain_pairs(walker: str) -> dict[str, list[tuple[str, Any]]]:
    """For each scaled gain knob, the overrides it scales and their defaults."""
    if walker == "ipm":
        from .ipm_params import IPMParams

        flat = IPMParams().flat()
        return {base: [(f"{base}_kp", flat[f"{base}_kp"]), (f"{base}_kd", flat[f"{base}_kd"])]
                for base in ("tracking.hip", "tracking.pelvis")}
    from .gaits import GAITS

    gains = GAITS["walk"].gains
    return {f"gain_{g}": [(f"gain_{g}", list(gains[g]))] for g in ("swing_hip", "torso")}


def walk_cost(rows: list[dict], duration: float = CHECK_DURATION) -> float:
    """The cost of walks ``rows`` (each ``speed`` commanded or ``None``, ``fell``,
    ``fall_time_s``, ``steady_speed_mps``, ``own_speed_mps``): per walk, a fall costs
    ``5 + 10 (1 - t_fall / duration)`` and a walk that stands its time the speed error (m/s) times
    10, at most 5 (an uncommanded walk, SIMBICON's own gait speed, costs nothing: its speed is
    the gait's, not a command's); the mean over walks."""
    total = 0.0
    for r in rows:
        if r["fell"]:
            total += 5.0 + 10.0 * (1.0 - min(r["fall_time_s"], duration) / duration)
        elif r["speed"] is not None:
            total += min(10.0 * abs(r["steady_speed_mps"] - r["speed"]), 5.0)
    return total / max(len(rows), 1)


def passes(rows: list[dict]) -> bool:
    """Whether walks ``rows`` pass the check (no fall; a commanded speed within
    :data:`CHECK_TOLERANCE`)."""
    return all(not r["fell"] and (r["speed"] is None or abs(
        r["steady_speed_mps"] - r["speed"]) <= CHECK_TOLERANCE) for r in rows)


def walk_once(model: mujoco.MjModel, info, walker: str, overrides: dict, speed: float | None,
              duration: float = CHECK_DURATION, seed: int = 0) -> dict:
    """One walk of ``walker`` with ``overrides`` (uncalibrated otherwise) on the body, from its
    seeded start state, or with ``seed=None`` from the standing pose at rest as ``mjchar run``
    walks it (at the walker's own speed: the very run of ``mjchar run simbicon``):
    ``{speed, seed, fell, fall_time_s, steady_speed_mps, own_speed_mps}``."""
    from ..core.builder import RunSpec, execute

    cpu = time.process_time()
    opts = dict(overrides, calibration=NO_CALIBRATION)
    if speed is not None:
        opts["speed"] = speed
    scenario = {"duration": duration}
    if seed is not None or speed is not None:
        scenario["steady_window"] = min(STEADY_WINDOW, duration / 2)
    run = RunSpec(walker, "walk", model=model, seed=seed, options=opts,
                  scenario_options=scenario).build(info=info)
    r = execute(run)
    own = _own_speed(run.controller) if speed is None else None  # SIMBICON's own gait speed
    return {"speed": speed, "seed": seed, "fell": bool(r.fell),
            "fall_time_s": float(r.fall_time_s) if r.fell else None,
            "steady_speed_mps": _float_or_none(r.extra.get("steady_speed_mps")),
            "own_speed_mps": own, "cpu_s": time.process_time() - cpu}


def _float_or_none(v) -> float | None:
    return None if v is None else float(v)


def _own_speed(controller) -> float:
    """SIMBICON's gait speed on its body (its Froude number times ``sqrt(g L)``)."""
    g = controller.base_gait
    return float(g.froude * math.sqrt(9.81 * controller.leg_length)) if g.froude else 1.0


def _walk_job(args) -> dict:
    return walk_once(*args)


# -- the optimisation ------------------------------------------------------------------------
def calibrate(model: mujoco.MjModel | str | os.PathLike, walker: str, *, info=None,
              budget_s: float | None = None, jobs: int | None = None,
              duration: float | None = None, popsize: int = 6, seed: int = 0,
              progress: Callable[[str], None] | None = None) -> Calibration:
    """Calibrate ``walker`` for the body ``model`` (an MJCF path or an ``MjModel``; ``info``:
    its role map when the model is not a converted file): the check, then CMA-ES while a
    generation fits in ``budget_s`` s (default :data:`BUDGET_S`; see the module docstring) of
    ``jobs`` cores (the walks' CPU time over ``jobs``: the same budget on a busy machine),
    walking ``duration`` s per speed (default :data:`CHECK_DURATION`); ``jobs`` worker
    processes (default: every core); ``progress`` gets one line per generation. The result is
    not stored (:func:`save`)."""
    _check_walker(walker)
    budget_s = BUDGET_S if budget_s is None else budget_s
    duration = CHECK_DURATION if duration is None else duration
    if not isinstance(model, mujoco.MjModel):
        from ..core.character import Character

        ch = Character(str(model))
        model, info = ch.model, ch.info
    start = time.monotonic()
    jobs = max(1, jobs or os.cpu_count() or 1)
    speeds = SPEEDS[walker]
    say = progress or (lambda line: None)
    cal = Calibration(walker, model_fingerprint(model), jobs=jobs)
    if multiprocessing.current_process().daemon:  # a pool's worker (the bench's) has no children
        jobs = 1
    with _pool(jobs) as pool:
        walks = _Walks(pool, jobs, model, info, walker, speeds, seed, cal)
        cal.check = walks([None], duration)[0]
        cal.cost_defaults = cal.cost = walk_cost(cal.check, duration)
        say(f"defaults: cost {cal.cost_defaults:.2f} ({_summary(cal.check)})")
        if passes(cal.check):
            cal.seconds = time.monotonic() - start
            return cal
        best_x, best_rows, best = _search(walks, cal, duration, budget_s, popsize, seed, say)
    if best_x is not None:
        cal.overrides = candidate_overrides(walker, best_x)
        cal.status, cal.cost, cal.calibrated = "optimised", best, best_rows
    else:
        cal.status = "unimproved"
    cal.seconds = time.monotonic() - start
    return cal


class _Walks:
    """The walks of one calibration: candidates (normalised knob vectors, ``None`` for the
    defaults) walked at every speed on ``pool`` of ``jobs`` processes (``None``: here, one),
    counted in ``cal`` (evaluations, CPU seconds)."""

    def __init__(self, pool, jobs: int, model, info, walker: str, speeds, seed: int,
                 cal: Calibration):
        self.pool, self.jobs, self.model, self.info, self.walker = pool, jobs, model, info, walker
        self.speeds, self.seed, self.cal = speeds, seed, cal

    def __call__(self, xs: list, seconds: float, speeds=None, rest: bool = False
                 ) -> list[list[dict]]:
        """Per candidate, its walks of ``seconds`` s, one per speed (default: the check's) from
        the seeded start, and with ``rest`` one more per speed from the standing pose at
        rest."""
        speeds = self.speeds if speeds is None else speeds
        starts = (self.seed, None) if rest else (self.seed,)
        work = [(self.model, self.info, self.walker, candidate_overrides(self.walker, x), v,
                 seconds, s) for x in xs for s in starts for v in speeds]
        pool = self.pool
        out = list(pool.map(_walk_job, work) if pool is not None else map(_walk_job, work))
        self.cal.evaluations += len(xs)
        self.cal.cpu_seconds += sum(r.pop("cpu_s") for r in out)
        n = len(speeds) * len(starts)
        return [out[i * n:(i + 1) * n] for i in range(len(xs))]

    def machine_s(self) -> float:
        """The walks' CPU time so far, spread over the walking processes' cores."""
        return self.cal.cpu_seconds / self.jobs


def _search(walks: _Walks, cal: Calibration, duration: float, budget_s: float, popsize: int,
            seed: int, say: Callable[[str], None]) -> tuple[np.ndarray | None, list, float]:
    """CMA-ES from the defaults while a generation fits in the budget; a candidate that passes
    the check is confirmed by :data:`CONFIRM_DURATION` s walks at :data:`CONFIRM_SPEEDS`, from
    the seeded start and from rest (a fall or a speed off by more than the tolerance there rules
    it out and the search goes on).
    Returns ``(x, walks, cost)`` of the candidate to store (``x`` ``None``: none beat the
    defaults); ``cal.confirmed`` and ``cal.rejected`` are filled in."""
    import cma

    es = cma.CMAEvolutionStrategy(np.zeros(len(KNOBS[cal.walker])), 1.0, {
        "popsize": popsize, "seed": seed + 1, "verbose": -9, "verb_log": 0,
        "bounds": [-3.0, 3.0]})
    best_x, best_rows, best = None, cal.check, cal.cost_defaults
    fallback = None  # the first candidate ruled out by its long walks
    # a generation walks popsize candidates as the check walked one
    check_s = walks.machine_s()
    generation_s = check_s * popsize
    confirm = CONFIRM_SPEEDS[cal.walker]
    confirm_s = (check_s * max(CONFIRM_DURATION, duration) / duration
                 * 2 * len(confirm) / len(walks.speeds))
    while not es.stop():
        if walks.machine_s() + generation_s > budget_s:
            break
        t0 = walks.machine_s()
        xs = es.ask()
        rows = walks(xs, duration)
        costs = [walk_cost(r, duration) for r in rows]
        es.tell(xs, costs)
        i = int(np.argmin(costs))
        if costs[i] < best:
            best_x, best_rows, best = np.array(xs[i]), rows[i], costs[i]
        generation_s = walks.machine_s() - t0
        say(f"generation {es.countiter}: best {min(costs):.2f}, so far {best:.2f} "
            f"({_summary(best_rows)}) [{walks.machine_s():.0f} s on {walks.jobs} core(s)]")
        if passes(best_rows) and best < 0.5:
            if CONFIRM_DURATION <= duration:
                break
            if walks.machine_s() + confirm_s > budget_s:
                say("the budget ends before the long walks of the best candidate")
                break
            long = walks([best_x], CONFIRM_DURATION, confirm, rest=True)[0]
            say(f"confirming over {CONFIRM_DURATION:.0f} s: {_summary(long)}")
            if passes(long):
                cal.confirmed = long
                break
            # it drifts into a fall after the check's walks: ruled out, the search goes on
            cal.rejected.append(long)
            fallback = fallback or (best_x, best_rows, best)
            best_x, best_rows, best = None, cal.check, cal.cost_defaults
    if fallback is not None and (best_x is None or not passes(best_rows)):
        best_x, best_rows, best = fallback  # it passed the check at least
    if (best_x is not None and not cal.confirmed and not any(r["fell"] for r in cal.check)
            and (cal.rejected or any(r["fell"] for r in best_rows))):
        # the defaults walk, if not at every speed asked: better slow than fallen
        best_x, best_rows, best = None, cal.check, cal.cost_defaults
    return best_x, best_rows, best


@contextlib.contextmanager
def _pool(jobs: int):
    """A process pool of ``jobs`` workers (``None`` for one: the walks run here)."""
    if jobs <= 1:
        yield None
        return
    with process_pool(jobs, start_method="fork" if hasattr(os, "fork") else "spawn") as pool:
        yield pool


def _summary(rows: list[dict]) -> str:
    return ", ".join(
        f"{'own' if r['speed'] is None else r['speed']:}"
        f"{' from rest' if 'seed' in r and r['seed'] is None else ''}: "
        + (f"fell {r['fall_time_s']:.1f} s" if r["fell"] else "walked" if r["steady_speed_mps"]
           is None else f"{r['steady_speed_mps']:.2f} m/s")
        for r in rows)
