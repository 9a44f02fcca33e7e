"""CMA-ES trajectory optimisation of open-loop PD targets: clip tracking and a vertical jump.

The decision variables are PD-target offsets at spline knots every ``knot_dt`` (~0.1 s),
linearly interpolated to the controls (``control_dt``) and added to base targets (inverse
dynamics on the clip, :func:`mjchar.controllers.sampling.tracking.inverse_dynamics_targets`, or a
standing pose). Like SAMCON, the result is a
:class:`~mjchar.controllers.sampling.trajectory.Trajectory` for the native ``<position>`` actuators,
replayed open-loop with no force on the root.

CMA-ES (Hansen's ``cma`` package, ``ask``/``tell``) optimises overlapping windows (``window``
~0.5 s): the knots that act inside the window are free, those already committed are frozen; the
whole population of a generation is simulated as one batch of rollouts
(:mod:`mjchar.controllers.sampling.rollout`) from the state at the window start, and after
``generations`` the first ``commit`` seconds of the window are fixed, simulated once more to get the
next window's start state, and the window slides on (the un-committed knots warm-start the next
window). A window as long as the horizon gives a single whole-trajectory optimisation (what the jump
uses).

Objectives (lower is better; a fall adds :data:`~mjchar.controllers.sampling.tracking.FALL_COST`
scaled by how early it happened, so CMA-ES still sees a gradient among falling candidates):

- :class:`TrackingObjective`: the SAMCON cost
  (:class:`~mjchar.controllers.sampling.tracking.TrackingCost`)
  averaged over every control end in the window.
- :class:`JumpObjective`: a standing vertical jump, no clip: reward the peak clearance of the
  feet (lowest foot/toe sole site) up to ``target_clearance`` plus a margin, then land and stand:
  at the end the root back at standing height, the COM over the feet and still, the pose near
  standing; a small effort penalty on the offsets. Parameters are symmetric sagittal groups
  (hips, knees, ankles, toes, spine: the same offset on both sides), from a designed
  crouch-push-tuck-land initial guess.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from mjchar.bvh.errors import MjcharError

from ..core.character import Character
from ..core.limits import MAX_CONTROL_DT_S, MAX_DURATION_S
from .executors import Executor, LocalExecutor
from .rollout import RolloutModel, RolloutRequest, RolloutResult
from .tracking import (
    FALL_COST,
    CostWeights,
    PoseReference,
    TrackingCost,
    actuator_roles,
    clip_window,
    fall_penalty,
    inverse_dynamics_targets,
    reference_features,
    sampling_widths,
    tracking_rollout_model,
)
from .trajectory import Trajectory, register_replay

__all__ = [
    "TrajoptError", "TrajoptOptions", "TrajoptResult", "KnotSpline", "TrackingObjective",
    "JumpObjective", "TrajectoryOptimizer", "track_clip", "optimise_jump", "trajectory_cost",
    "plain_pd_trajectory", "JUMP_GROUPS", "JUMP_KEYS", "JUMP_OPTIONS", "standing_targets",
    "jump_initial_knots",
]


class TrajoptError(MjcharError):
    """Trajectory optimisation was given options it cannot use."""


# ------------------------------------------------------------------------------------------------
# parametrisation


class KnotSpline:
    """Piecewise-linear knots of ``P`` parameters every ``knot_dt`` mapped to ``(T, nu)`` offsets.

    ``offsets = B @ X @ G`` with ``X`` ``(K, P)`` knot values, ``B`` ``(T, K)`` the linear
    interpolation weights at the control midpoints and ``G`` ``(P, nu)`` the map from parameters
    to actuators (identity times the per-actuator scale for tracking; symmetric groups for the
    jump).

    Args:
        n_controls: T; control_dt, knot_dt: seconds.
        G: ``(P, nu)`` parameter-to-actuator matrix (rad per parameter unit).
    """

    def __init__(self, n_controls: int, control_dt: float, knot_dt: float, G: np.ndarray):
        if not (knot_dt > 0 and control_dt > 0):
            raise TrajoptError("knot_dt and control_dt must be positive seconds")
        self.n_controls, self.control_dt, self.knot_dt = int(n_controls), control_dt, knot_dt
        self.G = np.asarray(G, dtype=float)
        t = (np.arange(self.n_controls) + 0.5) * control_dt
        self.n_knots = int(math.ceil(self.n_controls * control_dt / knot_dt - 1e-9)) + 1
        s = np.clip(t / knot_dt, 0, self.n_knots - 1)
        i = np.minimum(np.floor(s).astype(int), self.n_knots - 2)
        a = s - i
        B = np.zeros((self.n_controls, self.n_knots))
        B[np.arange(self.n_controls), i] = 1 - a
        B[np.arange(self.n_controls), i + 1] += a
        self.B = B

    @property
    def n_params(self) -> int:
        return self.G.shape[0]

    def knots_acting(self, a: int, b: int) -> np.ndarray:
        """Knot indices with non-zero weight on controls ``a .. b-1``."""
        return np.flatnonzero(np.abs(self.B[a:b]).sum(axis=0) > 0)

    def offsets(self, X: np.ndarray, a: int = 0, b: int | None = None) -> np.ndarray:
        """``(..., b - a, nu)`` offsets of controls ``a .. b-1`` for knots ``X`` ``(..., K, P)``."""
        b = self.n_controls if b is None else b
        return np.einsum("tk,...kp,pu->...tu", self.B[a:b], X, self.G, optimize=True)


# ------------------------------------------------------------------------------------------------
# objectives


class TrackingObjective:
    """Mean SAMCON tracking cost over the control ends of a window (+ a graded fall penalty).

    Args:
        character: model structure; reference: a ``ReferenceMotion``; rmodel: the rollout model;
        control_dt: seconds per control; start: clip time of control 0; n_controls: T;
        weights: :class:`~mjchar.controllers.sampling.tracking.CostWeights`.
    """

    def __init__(self, character: Character, reference, rmodel: RolloutModel,
                 control_dt: float, n_controls: int, start: float = 0.0,
                 weights: CostWeights | None = None):
        self.cost = TrackingCost(character, weights, site_names=rmodel.site_names)
        ends = start + (np.arange(n_controls) + 1) * control_dt
        self.features = reference_features(rmodel, reference, ends)

    def __call__(self, res: RolloutResult, a: int, b: int) -> np.ndarray:
        """``(B,)`` costs of rollouts ``res`` covering controls ``a .. b-1``."""
        n = b - a
        c = np.zeros((res.qpos.shape[0], n))
        for i in range(n):
            c[:, i] = self.cost(res.qpos[:, i], res.qvel[:, i], res.com[:, i], res.com_vel[:, i],
                                res.sites[:, i], self.features, a + i)
        c = np.where(np.isfinite(c), c, 1e3)
        return c.mean(axis=1) + fall_penalty(self.cost, res)


#: the jump's parameter groups: role kind and hinge axis (the same offset on both sides)
#: the longest CMA-ES window, s: one search over more than this many seconds of controls is
#: beyond what the optimiser can do (and a jump is one window)
MAX_WINDOW_S = 10.0
JUMP_GROUPS = (("hip", "y"), ("knee", "y"), ("ankle", "y"), ("toe", "y"), ("spine", "y"))


def standing_targets(character: Character) -> tuple[np.ndarray, np.ndarray]:
    """``(qpos (nq,), targets (nu,))``: the standing pose (rest pose, feet on the floor) and
    native-PD targets that hold it against gravity (static inverse dynamics, weight shared by
    both feet)."""
    from ..core.scenarios import standing_pose

    q = standing_pose(character)

    u = inverse_dynamics_targets(character, PoseReference(q, character.nv), np.zeros(1),
                                 smoothing=0.0)[0]
    return q, u


class JumpObjective:
    """A standing vertical jump: leave the ground by ``target_clearance`` m and land standing.

    Cost of a rollout (lower is better)::

        - w_clear min(flight clearance, target_clearance + margin) - w_rise min(COM rise, 0.3)
        + w_land E_stand(end) + w_still mean E_stand(last ``settle`` s)
        + w_upright mean_t |c_xy - feet_xy| + w_drift max_t |c_xy - c0_xy| + fall penalty

    with ``E_stand = |z_root - z_stand| + |c_xy - feet_xy| + 0.3 |c_dot| + 0.1 pose error``.
    The flight clearance at a control end is the height of the lowest of the four sole sites
    (``left/right_foot``, ``left/right_toe``) when no body touched the floor during that control
    interval and the character has not fallen yet (0 otherwise); its peak over the rollout is
    rewarded. The COM rise (peak COM height above standing) shapes the search before the first
    flights appear; the drift term (COM away from where it started) keeps the jump vertical.
    """

    def __init__(self, character: Character, rmodel: RolloutModel, q_stand: np.ndarray,
                 control_dt: float, *, target_clearance: float = 0.10, margin: float = 0.06,
                 settle: float = 0.4, w_clear: float = 200.0, w_rise: float = 20.0,
                 w_land: float = 30.0, w_still: float = 20.0, w_upright: float = 20.0,
                 w_drift: float = 30.0):
        self.cost = TrackingCost(character, site_names=rmodel.site_names)
        names = list(rmodel.site_names)
        need = ("left_foot", "right_foot", "left_toe", "right_toe")
        missing = [n for n in need if n not in names]
        if missing:
            raise TrajoptError(f"the jump needs sole sites {missing} the model lacks")
        self.feet = [names.index(n) for n in need]
        self.q_stand = np.asarray(q_stand, dtype=float)
        self.z_stand = float(q_stand[2])
        self.com_stand = _com(character, q_stand)
        self.act_q = character.actuator_qpos
        self.target = target_clearance + margin
        self.settle = max(1, int(round(settle / control_dt)))
        self.w = {"clear": w_clear, "rise": w_rise, "land": w_land, "still": w_still,
                  "upright": w_upright, "drift": w_drift}

    def clearance(self, res: RolloutResult) -> np.ndarray:
        """``(B, T)`` flight clearance (m) at each control end (see the class docstring)."""
        z = np.nan_to_num(res.sites[:, :, self.feet, 2].min(axis=2), nan=0.0)
        airborne = ~res.contacts.any(axis=2)
        zr = res.qpos[:, :, self.cost.root_height_index]
        bad = res.non_foot_contact | ~(zr >= self.cost.fall_height)
        upright = np.cumsum(bad, axis=1) == 0
        return np.where(airborne & upright, np.maximum(z, 0.0), 0.0)

    def _feet_xy(self, res: RolloutResult, i):
        return res.sites[:, i][..., self.feet, :2].mean(axis=-2)

    def _standing_error(self, res: RolloutResult, i) -> np.ndarray:
        q = res.qpos[:, i]
        z = np.abs(q[..., self.cost.root_height_index] - self.z_stand)
        bal = np.linalg.norm(res.com[:, i][..., :2] - self._feet_xy(res, i), axis=-1)
        vel = np.linalg.norm(res.com_vel[:, i], axis=-1)
        pose = np.abs(q[..., self.act_q] - self.q_stand[self.act_q]).mean(axis=-1)
        return z + bal + 0.3 * vel + 0.1 * pose

    def __call__(self, res: RolloutResult, a: int, b: int) -> np.ndarray:
        w = self.w
        clear = self.clearance(res).max(axis=1)
        rise = np.nan_to_num(res.com[:, :, 2] - self.com_stand[2], nan=0.0).max(axis=1)
        drift = np.nan_to_num(np.linalg.norm(res.com[..., :2] - self.com_stand[:2], axis=-1),
                              nan=1.0).max(axis=1)
        c = -w["clear"] * np.minimum(clear, self.target) - w["rise"] * np.clip(rise, 0.0, 0.3)
        end = np.nan_to_num(self._standing_error(res, -1), nan=10.0)
        still = np.nan_to_num(self._standing_error(res, slice(-self.settle, None)), nan=10.0)
        upright = np.nan_to_num(np.linalg.norm(res.com[..., :2] - self._feet_xy(res, slice(None)),
                                               axis=-1), nan=1.0)
        c += w["land"] * end + w["still"] * still.mean(axis=1) + w["upright"] * upright.mean(1)
        c += w["drift"] * drift
        return c + fall_penalty(self.cost, res)


def _com(character: Character, qpos: np.ndarray) -> np.ndarray:
    """``(3,)`` centre of mass (m) of the character at pose ``qpos`` (the state is restored)."""
    saved = character.state.get()
    character.reset(qpos)
    c = character.state.com()
    character.state.set(saved)
    return c


# ------------------------------------------------------------------------------------------------
# the optimiser


@dataclass
class TrajoptOptions:
    """CMA-ES trajectory optimisation settings.

    Attributes:
        knot_dt: seconds between spline knots; control_dt: seconds per PD-target control.
        window: seconds optimised together; commit: seconds fixed per window (the rest overlaps
            the next window). A window >= the horizon optimises everything at once.
        generations: CMA-ES iterations per window; popsize: candidates per generation (one
            batch; default ``max(4 + 3 ln n, 2 x executor parallelism)`` rounded up to even).
        sigma0: initial CMA-ES step size, in parameter units (tracking: fractions of the
            SAMCON sampling widths).
        width_scale: factor on the SAMCON role widths that scale the tracking parameters.
        weights: tracking cost weights.
        id_targets: base targets from inverse dynamics (tracking) instead of the raw pose.
        start, duration: clip seconds to track (duration default: the whole clip).
        seed: random seed (CMA-ES's own).
    """

    knot_dt: float = 0.1
    control_dt: float = 0.02
    window: float = 0.5
    commit: float = 0.2
    generations: int = 40
    popsize: int | None = None
    sigma0: float = 1.0
    width_scale: float = 1.0
    weights: CostWeights = field(default_factory=CostWeights)
    id_targets: bool = True
    start: float = 0.0
    duration: float | None = None
    seed: int = 0

    def check(self, timestep: float) -> None:
        for k in ("knot_dt", "control_dt", "window", "commit", "sigma0"):
            v = getattr(self, k)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise TrajoptError(f"{k} must be a positive number, got {v!r}")
        for k in ("generations",):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise TrajoptError(f"{k} must be a positive integer, got {v!r}")
        if self.popsize is not None and (not isinstance(self.popsize, int) or self.popsize < 2):
            raise TrajoptError(f"popsize must be an integer >= 2, got {self.popsize!r}")
        k = self.control_dt / timestep
        if abs(k - round(k)) > 1e-6:
            raise TrajoptError(f"control_dt {self.control_dt} s is not a whole number of "
                               f"{timestep} s physics steps")
        if self.window > MAX_WINDOW_S:
            raise TrajoptError(f"window must be at most {MAX_WINDOW_S:g} s (one CMA-ES search), "
                               f"got {self.window:g}")
        if self.control_dt > MAX_CONTROL_DT_S:
            raise TrajoptError(f"control_dt must be at most {MAX_CONTROL_DT_S:g} s, got "
                               f"{self.control_dt:g}")
        for k in ("knot_dt", "commit"):
            c = getattr(self, k) / self.control_dt
            if abs(c - round(c)) > 1e-6 or round(c) < 1:
                raise TrajoptError(f"{k} must be a whole number of controls of "
                                   f"{self.control_dt} s")
        if self.commit > self.window:
            raise TrajoptError(f"commit ({self.commit} s) cannot exceed window ({self.window} s)")
        if self.duration is not None and not (0 < self.duration <= MAX_DURATION_S):
            raise TrajoptError(f"duration must be positive seconds, at most "
                               f"{MAX_DURATION_S:g}, got {self.duration!r}")


@dataclass
class TrajoptResult:
    """What :meth:`TrajectoryOptimizer.run` returns.

    Attributes:
        trajectory: the optimised trajectory; knots: ``(K, P)`` knot values.
        window_costs: best objective value per window; evaluations: rollouts simulated;
        physics_steps: physics steps simulated; wall_s: seconds.
    """

    trajectory: Trajectory
    knots: np.ndarray
    window_costs: list
    evaluations: int
    physics_steps: int
    wall_s: float


class TrajectoryOptimizer:
    """Windowed CMA-ES over spline-knot offsets of PD targets.

    Args:
        character: the character (model structure).
        rmodel: the rollout model compiled from the same source.
        base: ``(T, nu)`` base targets; spline: the :class:`KnotSpline`; objective: callable
            ``(RolloutResult, a, b) -> (B,) costs`` for rollouts of controls ``a .. b-1``.
        q0, v0: start state; options: :class:`TrajoptOptions`; executor: where rollouts run.
        x0: ``(K, P)`` initial knot values (default zeros).
    """

    def __init__(self, character: Character, rmodel: RolloutModel, base: np.ndarray,
                 spline: KnotSpline, objective: Callable, q0: np.ndarray, v0: np.ndarray,
                 options: TrajoptOptions, executor: Executor, x0: np.ndarray | None = None):
        self.character, self.rmodel = character, rmodel
        self.base, self.spline, self.objective = np.asarray(base, float), spline, objective
        self.q0, self.v0 = np.asarray(q0, float), np.asarray(v0, float)
        self.options, self.executor = options, executor
        self.k = int(round(options.control_dt / character.timestep))
        self.X = (np.zeros((spline.n_knots, spline.n_params)) if x0 is None
                  else np.array(x0, dtype=float))

    def _windows(self) -> list[tuple[int, int, int]]:
        """``(a, b, commit_end)`` control ranges of the windows."""
        o, T = self.options, self.spline.n_controls
        w = int(round(o.window / o.control_dt))
        c = int(round(o.commit / o.control_dt))
        out, a = [], 0
        while a < T:
            b = min(T, a + w)
            e = b if b == T else a + c
            out.append((a, b, e))
            a = e
        return out

    def run(self, progress: bool | Callable = True) -> tuple[np.ndarray, list, dict]:
        """Optimise; returns ``(X (K, P), window costs, stats)``."""
        import cma

        o = self.options
        state = self.rmodel.initial_state(self.q0, self.v0)
        frozen = np.zeros(self.spline.n_knots, dtype=bool)
        stats = {"evaluations": 0, "steps": 0, "resets": []}
        costs = []
        windows = self._windows()
        bar = None
        if progress is True:
            from tqdm import tqdm

            bar = tqdm(total=len(windows) * o.generations, desc="CMA-ES", unit="gen",
                       leave=False)
        for wi, (a, b, e) in enumerate(windows):
            stats["resets"].append(a)
            free = np.array([k for k in self.spline.knots_acting(a, b) if not frozen[k]])
            n = len(free) * self.spline.n_params
            pop = o.popsize or max(4 + int(3 * math.log(n)), 2 * self.executor.parallelism)
            pop += pop % 2
            es = cma.CMAEvolutionStrategy(self.X[free].ravel(), o.sigma0,
                                          {"popsize": pop, "seed": o.seed + 1 + wi,
                                           "verbose": -9, "verb_log": 0, "maxiter": o.generations})
            best_x = self.X[free].ravel().copy()  # the warm start competes too
            best_f = float(self._evaluate(state, best_x[None], free, a, b, stats)[0])
            for g in range(o.generations):
                xs = np.array(es.ask())
                f = self._evaluate(state, xs, free, a, b, stats)
                es.tell(list(xs), f.tolist())
                i = int(np.argmin(f))
                if f[i] < best_f:
                    best_f, best_x = float(f[i]), xs[i].copy()
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(window=f"{wi + 1}/{len(windows)}", best=f"{best_f:.3f}")
                elif callable(progress):
                    progress(wi, g, len(windows), best_f)
            self.X[free] = best_x.reshape(len(free), -1)
            costs.append(best_f)
            # commit [a, e): every knot acting on a committed control is frozen from now on
            frozen[self.spline.knots_acting(a, e)] = True
            if e < self.spline.n_controls:
                ctrl = self.base[a:e] + self.spline.offsets(self.X, a, e)
                res = self.executor.evaluate(RolloutRequest(self.rmodel, state, ctrl[None],
                                                            self.k))
                state = res.final_states[0]
                stats["evaluations"] += 1
                stats["steps"] += (e - a) * self.k
        if bar is not None:
            bar.close()
        return self.X.copy(), costs, stats

    def _evaluate(self, state, xs, free, a, b, stats) -> np.ndarray:
        P = len(xs)
        X = np.broadcast_to(self.X, (P,) + self.X.shape).copy()
        X[:, free] = xs.reshape(P, len(free), -1)
        ctrl = self.base[None, a:b] + self.spline.offsets(X, a, b)
        res = self.executor.evaluate(RolloutRequest(self.rmodel, state, ctrl, self.k))
        stats["evaluations"] += P
        stats["steps"] += P * (b - a) * self.k
        f = np.asarray(self.objective(res, a, b), dtype=float)
        return np.where(np.isfinite(f), f, 10 * FALL_COST)

    def targets(self, X: np.ndarray | None = None) -> np.ndarray:
        """``(T, nu)`` targets for knots ``X`` (default: the current ones)."""
        return self.base + self.spline.offsets(self.X if X is None else X)


# ------------------------------------------------------------------------------------------------
# front ends


def _setup(model):
    from mjchar.bvh.bundled.assets import humanoid_path

    src = humanoid_path() if model is None else model
    ch = Character(src)
    return ch, tracking_rollout_model(src, ch)


def track_clip(reference, *, model=None, options: TrajoptOptions | None = None,
               executor: Executor | None = None, source_motion: str = "",
               progress: bool | Callable = True) -> TrajoptResult:
    """Optimise PD-target offsets that make the character track ``reference`` (a
    ``ReferenceMotion`` on ``model``) from its first frame, with windowed CMA-ES.

    Returns:
        a :class:`TrajoptResult`; its trajectory stores the reference rows for the metrics.
    """
    o = options or TrajoptOptions()
    ch, rm = _setup(model)
    o.check(ch.timestep)
    if reference.model.nq != ch.nq:
        raise TrajoptError("the reference motion was built for another model")
    duration = clip_window(reference, o.start, o.duration, TrajoptError)
    T = int(round(duration / o.control_dt))
    if T < 1:
        raise TrajoptError(f"duration {duration} s is shorter than one control")
    t_mid = o.start + (np.arange(T) + 0.5) * o.control_dt
    if o.id_targets:
        base = inverse_dynamics_targets(ch, reference, t_mid)
    else:
        base = reference.qpos(t_mid)[:, ch.actuator_qpos]
    G = np.diag(sampling_widths(ch, scale=o.width_scale))
    spline = KnotSpline(T, o.control_dt, o.knot_dt, G)
    objective = TrackingObjective(ch, reference, rm, o.control_dt, T, o.start, o.weights)
    q0, v0 = reference.qpos(o.start), reference.qvel(o.start)
    own = executor is None
    ex = executor or LocalExecutor()
    try:
        wall0 = time.perf_counter()
        opt = TrajectoryOptimizer(ch, rm, base, spline, objective, q0, v0, o, ex)
        X, costs, stats = opt.run(progress)
        wall = time.perf_counter() - wall0
    finally:
        if own:
            ex.close()
    t = o.start + np.arange(T + 1) * o.control_dt
    traj = Trajectory.for_model(
        ch.model, opt.targets(X), o.control_dt, q0, v0, warmstart_resets=stats["resets"],
        source_motion=source_motion, reference_qpos=reference.qpos(t),
        metadata={"method": "cmaes-track", "options": asdict(o), "window_costs": costs,
                  "evaluations": stats["evaluations"], "physics_steps": stats["steps"],
                  "wall_s": wall})
    return TrajoptResult(traj, X, costs, stats["evaluations"], stats["steps"], wall)


def _jump_matrix(character: Character, groups=JUMP_GROUPS) -> np.ndarray:
    roles = actuator_roles(character)
    names = [character.dof_names[d] for d in character.actuator_dof]
    G = np.zeros((len(groups), character.nu))
    for p, (role, axis) in enumerate(groups):
        for a, (r, n) in enumerate(zip(roles, names, strict=True)):
            if r == role and n.endswith(f"_{axis}"):
                G[p, a] = 1.0
    if not G.any(axis=1).all():
        missing = [groups[p] for p in np.flatnonzero(~G.any(axis=1))]
        raise TrajoptError(f"the model has no actuators for jump groups {missing}")
    return G


#: designed jump (offsets in rad for hip, knee, ankle, toe, spine; hip/ankle/spine positive =
#: extension/plantarflexion/forward lean about the lateral axis): time (s) -> offsets
JUMP_KEYS = (
    (0.0, (0.0, 0.0, 0.0, 0.0, 0.0)),
    (0.2, (0.0, 0.0, 0.0, 0.0, 0.0)),
    (0.5, (-0.9, 1.3, -0.45, 0.0, 0.35)),     # crouch
    (0.6, (-0.9, 1.3, -0.45, 0.0, 0.35)),
    (0.75, (0.4, -0.4, 0.7, 0.0, -0.1)),      # push off
    (0.9, (-0.3, 0.5, 0.1, 0.0, 0.1)),        # tuck in flight
    (1.1, (-0.6, 0.9, -0.3, 0.0, 0.25)),      # absorb the landing
    (1.5, (-0.2, 0.3, -0.1, 0.0, 0.05)),
    (1.8, (0.0, 0.0, 0.0, 0.0, 0.0)),         # stand
    (2.2, (0.0, 0.0, 0.0, 0.0, 0.0)),
)


#: options of the benchmark / slow-test jump (``TrajoptOptions(**JUMP_OPTIONS)``)
JUMP_OPTIONS = {"generations": 60, "popsize": 24, "sigma0": 0.15}


def jump_initial_knots(spline: KnotSpline, keys=JUMP_KEYS) -> np.ndarray:
    """``(K, P)`` knot values interpolated from the designed key poses :data:`JUMP_KEYS`."""
    t = np.arange(spline.n_knots) * spline.knot_dt
    kt = np.array([k[0] for k in keys])
    kv = np.array([k[1] for k in keys])
    return np.stack([np.interp(t, kt, kv[:, p]) for p in range(kv.shape[1])], axis=1)


def optimise_jump(*, model=None, duration: float = 2.2, options: TrajoptOptions | None = None,
                  executor: Executor | None = None, target_clearance: float = 0.10,
                  progress: bool | Callable = True) -> TrajoptResult:
    """Optimise a standing vertical jump from the standing pose (a task objective, no clip):
    leave the ground by ``target_clearance`` m and land standing, within ``duration`` s.

    One CMA-ES window over the whole horizon (``options.window`` is raised to ``duration``),
    symmetric sagittal parameters (:data:`JUMP_GROUPS`), base targets holding the standing pose,
    initial knots from :data:`JUMP_KEYS`.
    """
    o = options or TrajoptOptions(**JUMP_OPTIONS)
    if not (isinstance(duration, int | float) and 0 < duration <= MAX_WINDOW_S):
        raise TrajoptError(f"a jump is optimised in one window: its duration must be positive "
                           f"and at most {MAX_WINDOW_S:g} s, got {duration!r}")
    ch, rm = _setup(model)
    o.window = max(o.window, duration)
    o.commit = o.window
    o.check(ch.timestep)
    T = int(round(duration / o.control_dt))
    q0, u_stand = standing_targets(ch)
    base = np.tile(u_stand, (T, 1))
    spline = KnotSpline(T, o.control_dt, o.knot_dt, _jump_matrix(ch))
    objective = JumpObjective(ch, rm, q0, o.control_dt, target_clearance=target_clearance)
    v0 = np.zeros(ch.nv)
    own = executor is None
    ex = executor or LocalExecutor()
    try:
        wall0 = time.perf_counter()
        opt = TrajectoryOptimizer(ch, rm, base, spline, objective, q0, v0, o, ex,
                                  x0=jump_initial_knots(spline))
        X, costs, stats = opt.run(progress)
        wall = time.perf_counter() - wall0
    finally:
        if own:
            ex.close()
    traj = Trajectory.for_model(
        ch.model, opt.targets(X), o.control_dt, q0, v0, warmstart_resets=stats["resets"],
        metadata={"method": "cmaes-jump", "options": asdict(o), "window_costs": costs,
                  "target_clearance_m": target_clearance, "evaluations": stats["evaluations"],
                  "physics_steps": stats["steps"], "wall_s": wall, "knots": X.tolist()})
    return TrajoptResult(traj, X, costs, stats["evaluations"], stats["steps"], wall)


# ------------------------------------------------------------------------------------------------
# evaluation helpers


def plain_pd_trajectory(reference, *, model=None, duration: float | None = None,
                        start: float = 0.0) -> Trajectory:
    """Plain native PD tracking of the raw reference as a trajectory: every physics step the
    target ``u = q_bar + (kd / kp) qdot_bar`` of
    :class:`~mjchar.controllers.core.pd.NativePDController`."""
    ch, _ = _setup(model)
    dt = ch.timestep
    duration = (reference.duration - start) if duration is None else duration
    T = int(round(duration / dt))
    t = start + np.arange(T) * dt
    kp, kd = ch.actuation.default_gains()
    lead = np.divide(kd, kp, out=np.zeros_like(kd), where=kp > 0)[ch.actuator_dof]
    u = reference.qpos(t)[:, ch.actuator_qpos] + lead * reference.qvel(t)[:, ch.actuator_dof]
    tt = start + np.arange(T + 1) * dt
    return Trajectory.for_model(ch.model, u, dt, reference.qpos(start), reference.qvel(start),
                                warmstart_resets=[0], reference_qpos=reference.qpos(tt),
                                metadata={"method": "plain-pd"})


def trajectory_cost(trajectory: Trajectory, reference, *, model=None,
                    weights: CostWeights | None = None, every: float = 0.02,
                    start: float = 0.0) -> float:
    """The mean tracking cost (:class:`~mjchar.controllers.sampling.tracking.TrackingCost`, no fall
    penalty) of a trajectory's open-loop rollout, sampled every ``every`` s: the number compared
    between plain PD tracking and CMA-ES. The rollout restarts the solver warm start at the
    trajectory's ``warmstart_resets`` (as its replay does)."""
    ch, rm = _setup(model)
    trajectory.validate(ch.model)
    k = trajectory.steps_per_control
    stride = max(1, int(round(every / trajectory.control_dt)))
    cost = TrackingCost(ch, weights, site_names=rm.site_names)
    bounds = list(trajectory.warmstart_resets) + [trajectory.n_controls]
    if bounds[0] != 0:
        bounds.insert(0, 0)
    state = rm.initial_state(trajectory.initial_qpos, trajectory.initial_qvel)
    parts = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        res = _rollout_one(rm, state, trajectory.targets[a:b], k)
        state = res.final_states[0]
        parts.append((a, res))
    idx = np.arange(stride - 1, trajectory.n_controls, stride)
    ends = start + (idx + 1) * trajectory.control_dt
    feats = reference_features(rm, reference, ends)
    total = []
    for n, i in enumerate(idx):
        a, res = next((a, r) for a, r in reversed(parts) if a <= i)
        j = i - a
        c = cost(res.qpos[:, j], res.qvel[:, j], res.com[:, j], res.com_vel[:, j],
                 res.sites[:, j], feats, n)
        total.append(float(c[0]) if np.isfinite(c[0]) else 1e3)
    return float(np.mean(total))


def _rollout_one(rm: RolloutModel, state, targets, k) -> RolloutResult:
    from .rollout import rollout

    return rollout(RolloutRequest(rm, state, np.asarray(targets)[None], k), threads=1)


register_replay("cmaes_replay", "CMA-ES trajectory replay",
                ("cmaes", "cma-es", "cma_es", "trajopt"), bench=("track",))
