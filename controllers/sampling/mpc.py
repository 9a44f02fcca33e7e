"""Receding-horizon sampling MPC: closed-loop clip tracking with batched rollouts.

Follows Howell, Gileadi, Tunyasuvunakool, Zakka, Erez and Tassa, "Predictive Sampling: Real-time
Behaviour Synthesis with MuJoCo" (2022; MuJoCo MPC), with the MPPI update of Williams, Aldrich
and Theodorou, "Model Predictive Path Integral Control" (2017) and the cross-entropy method
(Rubinstein 1999; Botev et al. 2013) as alternatives. Where SAMCON and CMA-ES reconstruct a clip
open loop, offline, this controller replans from the *current simulated state* every
``replan`` seconds, so pushes and perturbed starts are corrected. Native ``<position>``
actuators, no force on the root.

The plan, with MJPC's symbols:

- **Decision variables.** ``K`` spline knots ``X (K, nu)`` spread evenly over a horizon ``H``
  (a few tenths of a second): PD-target offsets in units of the per-joint role widths ``w``
  (:func:`~mjchar.controllers.sampling.tracking.sampling_widths`), linearly interpolated to the
  controls (``control_dt``; :class:`~mjchar.controllers.sampling.trajopt.KnotSpline`) and added to
  the base targets ``q_hat`` (inverse dynamics on the reference,
  :func:`~mjchar.controllers.sampling.tracking.inverse_dynamics_targets`)::

      u(t) = q_hat(t) + w * (B X)(t)

- **Sampling.** Every replanning step the nominal ``X`` is shifted to the current time (the old
  spline evaluated at the new knot times, the last knot held beyond its end: the warm start)
  and ``N - 1`` candidates ``X + b sigma eps`` (``eps ~ N(0, 1)``, ``sigma = noise``) are drawn;
  the nominal is candidate 0. ``b``, in ``[1, max_boost]``, is the last plan's cost over its
  running mean: the search widens after a disturbance (a push) raises the cost. All ``N`` are
  simulated from the current state in one batch (:mod:`mjchar.controllers.sampling.rollout`, every
  core, deterministic) on the *planning model*: the character's physics (checked by
  :func:`~mjchar.controllers.sampling.trajectory.model_fingerprint`) at the time step
  ``plan_timestep``, by default the coarsest divisor of the control interval at which the
  model's contacts and joint limits keep their own time constants (0.005 s, 4 steps per
  control, on a model with 0.01 s contacts), with a sparse constraint Jacobian and no solver
  warm start (``plan_solver="fast"``). When even
  the cheapest candidate's rollout stays further from the clip than ``second_batch`` (its mean
  joint position error over the horizon, the tracking metric's quantity; 5 cm by default),
  ``N`` more candidates are drawn around the same nominal and the update takes both batches:
  the search widens where the clip is hard to follow and costs nothing more where it is not.
- **Cost** of a candidate: the SAMCON tracking cost
  (:class:`~mjchar.controllers.sampling.tracking.TrackingCost`: pose, root, end effectors, balance,
  COM, joint positions) averaged over the control ends of the horizon, plus
  ``smoothness * sum_t mean_u ((Delta u_t) / w)^2`` over the offset changes (the first against
  the offset being applied now), plus a fall penalty graded by how early the candidate fell
  (:func:`~mjchar.controllers.sampling.tracking.fall_penalty`).
- **Update** (``update``): ``"sampling"`` (predictive sampling) keeps the cheapest candidate;
  ``"mppi"`` averages the candidates with weights ``exp(-(c - c_min) / lambda)``, ``lambda =
  temperature * (median(c) - c_min)`` (scale-free); ``"cem"`` moves the mean to the elite
  average and refits a per-knot, per-actuator ``sigma`` to the elites (smoothed, kept within
  ``[0.2, 2] x noise``).
- **Execution.** The new plan's first ``replan`` seconds are applied, at the character's own
  time step, then it replans. The constraint solver's warm start is cleared at each
  replanning, as every rollout starts. With ``plan_timestep`` equal to the character's own
  step, without a disturbance the character follows the chosen candidate's rollout bit for bit;
  with a coarser planning step (the default) the rollouts only approximate what the character
  then does, and the replanning corrects the difference like any disturbance.

Deterministic: the same options (seed) and the same model give the same trajectory, whatever the
thread count (each rollout is independent). The reference and base targets are computed on
demand in blocks, so cyclic clips (``ReferenceMotion(cyclic=True)``) can be tracked for as long
as the scenario runs.
"""

from __future__ import annotations

import math
import os
import time as _time
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from mjchar.bvh.reference.foot_points import CONTACT_HEIGHT

from ..core.base import Action, ControllerError
from ..core.character import Character
from ..core.param_fields import (
    REFUSED,
    Spec,
    Tunable,
    check_fields,
    choice,
    field_docs,
    flag,
    integer,
    length,
    mapping,
    number,
    time,
    tunables,
)
from ..core.registry import ControllerSpec, register
from .executors import LocalExecutor
from .planning import (
    MPC_STANCE_HEIGHT,
    PLAN_SOLVERS,
    MpcError,
    ReferenceGrid,
    coarsest_plan_step,
    model_file,
    planning_model,
    whole_multiple,
)
from .rollout import RolloutRequest
from .tracking import (
    FALL_COST,
    ROLE_WIDTHS,
    CostWeights,
    PoseReference,
    TrackingCost,
    fall_penalty,
    sampling_widths,
)
from .trajopt import KnotSpline

__all__ = ["MPC_STANCE_HEIGHT", "MPC_WIDTHS", "PLAN_SOLVERS", "UPDATES",
           "MpcController", "MpcError", "MpcOptions", "Plan", "ReferenceGrid", "make_mpc",
           "plan_timestep", "planning_model", "shift_matrix", "stance_height"]

#: plan updates: predictive sampling, MPPI, cross-entropy
UPDATES = ("sampling", "mppi", "cem")
#: the MPC's default noise widths: the arms and head are not sampled (their PD tracks them;
#: halving the dimension of the search tracked walk60 better, docs/mpc.md); the legs and
#: spine use the shared ``ROLE_WIDTHS``
MPC_WIDTHS = {"clavicle": 0.0, "shoulder": 0.0, "elbow": 0.0, "wrist": 0.0, "head": 0.0}


#: the cost weights' accepted values (the :class:`CostWeights` fields, each >= 0)
_WEIGHTS = Spec("none", kind="mapping", low=0.0, high=1e6,
                choices=tuple(f.name for f in fields(CostWeights)))


@dataclass
class MpcOptions:
    """Sampling MPC settings (see the module docstring).

    Attributes:
        samples: candidates per replanning step ``N`` (the nominal included), >= 2.
        second_batch: the predicted error (m) above which a plan draws a second batch.
            When the cheapest candidate's rollout stays further from the clip than this (mean
            joint position error over the horizon, the tracking metric's quantity),
            ``samples`` more candidates are drawn and the plan is updated over both batches:
            the search widens where the clip is hard to follow (``None``: never).
        horizon: seconds planned ahead ``H`` (a whole number of controls).
        knots: spline knots over the horizon ``K`` (>= 2; knot spacing ``H / (K - 1)``).
        replan: seconds between replanning steps (a whole number of controls, <= horizon).
        control_dt: seconds per PD-target control (a whole number of physics steps).
        plan_timestep: the time step of the planning model the rollouts run on (``None``:
            the coarsest divisor of ``control_dt`` at which the model's contacts and limits
            keep their own time constants, see :func:`plan_timestep`); ``control_dt`` must be
            a whole number of it. A coarser step makes each rollout cheaper; the character
            itself still steps at its own time step, and giving that step here (with
            ``plan_solver="exact"``) makes the rollouts exact.
        plan_solver: the planning model's solver settings, one of :data:`PLAN_SOLVERS`
            (:func:`planning_model`): ``"fast"`` (the default: a sparse constraint Jacobian
            and no solver warm start, the same physics to the solver's tolerance at about
            0.85 of the step cost) or ``"exact"`` (the character's own).
        near: seconds of the horizon every candidate is rolled out over before the cheapest
            go on (a whole number of controls; 0 or the horizon: no split, the default).
            Only the ``keep`` fraction cheapest so far (fallen candidates last) is rolled on
            over the tail; the others (terminated early) take no part in the update. With
            ``plan_solver="fast"`` the tail continues each rollout bit for bit; with
            ``"exact"`` it starts without the solver's warm start.
        keep: the fraction of candidates rolled on over the tail after ``near``.
        tail_timestep: the time step of the planning model the tail after ``near`` runs on
            (``None``: the planning model's own; ``control_dt`` must be a whole number of it).
        update: the plan update: ``"sampling"`` (predictive sampling), ``"mppi"`` or ``"cem"``.
        noise: standard deviation of the knot perturbations, in units of the role widths.
        widths: role -> width (rad) overriding ``ROLE_WIDTHS`` (default :data:`MPC_WIDTHS`).
        width_scale: factor on every role width.
        temperature: MPPI's ``lambda`` as a fraction of ``median(c) - min(c)``.
        elites: CEM's elite fraction.
        cem_rate: how fast CEM's sigma follows the elites.
        smoothness: weight of the control-smoothness term.
        antithetic: draw the perturbations in pairs ``+eps, -eps`` (variance reduction).
        max_boost: largest factor on the noise when the cost rises above its running mean
            (time constant ``boost_time`` s), e.g. after a push; 1 turns it off.
        boost_time: the time constant (s) of the cost's running mean the noise boost compares
            with.
        weights: the tracking cost weights (:class:`CostWeights`).
        smoothing: seconds of Gaussian smoothing of the inverse-dynamics targets.
        stance_height: a foot carries the body in the base targets' inverse dynamics when its
            lowest point is within this fraction of the root height of the floor (and it is
            slow); ``None``: :data:`MPC_STANCE_HEIGHT` on a contact-floor reference, else the
            raw-mocap :data:`~mjchar.bvh.reference.foot_points.CONTACT_HEIGHT`.
        seed: random seed.
        threads: rollout threads (``None``: every core).
    """

    samples: int = integer(48, ge=2, le=4096)
    second_batch: float | None = length(0.05, gt=0, le=1, optional=True)
    horizon: float = time(0.7, gt=0, le=5)
    knots: int = integer(3, ge=2, le=100)
    replan: float = time(0.04, gt=0, le=5)
    control_dt: float = time(0.02, gt=0, le=0.1)
    plan_timestep: float | None = time(None, ge=1e-5, le=0.01, optional=True)
    plan_solver: str = choice("fast", PLAN_SOLVERS)
    near: float = time(0.0, ge=0, le=5)
    keep: float = number(1.0, gt=0, le=1)
    tail_timestep: float | None = time(None, ge=1e-5, le=0.01, optional=True)
    update: str = choice("mppi", UPDATES)
    noise: float = number(0.5, gt=0, le=10)
    widths: dict = mapping(lambda: dict(MPC_WIDTHS), ge=0, le=math.pi, keys=tuple(ROLE_WIDTHS),
                           unit="rad")
    width_scale: float = number(1.0, gt=0, le=100)
    temperature: float = number(0.1, gt=0, le=100)
    elites: float = number(0.25, gt=0, le=1)
    cem_rate: float = number(0.5, gt=0, le=1)
    smoothness: float = number(1.0, ge=0)
    antithetic: bool = flag(False)
    max_boost: float = number(2.0, ge=1, le=100)
    boost_time: float = time(1.0, gt=0)
    weights: CostWeights = field(default_factory=CostWeights)
    smoothing: float = time(0.03, ge=0, le=1)
    stance_height: float | None = number(None, gt=0, le=1, optional=True)
    seed: int = integer(0, ge=0, le=2**32 - 1)
    threads: int | None = integer(None, ge=1, le=1024, optional=True)

    def check(self, timestep: float | None = None) -> None:
        """Raise :class:`MpcError` for impossible settings (``timestep``: the physics step the
        controls must be a whole number of). Each option is checked against its declaration
        (type and range, one line naming it), then the options against each other."""
        for k, v in check_fields(self, MpcError, "MPC option", skip=("weights",)).items():
            setattr(self, k, v)
        if not isinstance(self.weights, CostWeights):
            raise MpcError("weights must be a CostWeights (or an object of weights)")
        if _WEIGHTS.coerce(asdict(self.weights)) is REFUSED:
            raise MpcError(f"MPC option weights must be {_WEIGHTS.accepted()}, got "
                           f"{asdict(self.weights)}")
        for k in ("horizon", "replan"):
            if not whole_multiple(getattr(self, k), self.control_dt):
                raise MpcError(f"{k} ({getattr(self, k)} s) must be a whole number of controls "
                               f"of {self.control_dt} s")
        if self.near > 0 and not whole_multiple(self.near, self.control_dt):
            raise MpcError(f"near ({self.near} s) must be a whole number of controls of "
                           f"{self.control_dt} s")
        for k in ("plan_timestep", "tail_timestep"):
            v = getattr(self, k)
            if v is not None and not whole_multiple(self.control_dt, v):
                raise MpcError(f"control_dt {self.control_dt} s is not a whole number of "
                               f"{k} {v} s planning steps")
        if self.replan > self.horizon + 1e-9:
            raise MpcError(f"replan ({self.replan} s) cannot exceed horizon ({self.horizon} s)")
        if timestep is not None:
            if not whole_multiple(self.control_dt, timestep):
                raise MpcError(f"control_dt {self.control_dt} s is not a whole number of "
                               f"{timestep} s physics steps")

    @staticmethod
    def tunables() -> list[Tunable]:
        """Every option ``--param`` takes, with its default (``mjchar params mpc``)."""
        rows = tunables(MpcOptions())
        default = asdict(CostWeights())
        meaning = field_docs(MpcOptions)["weights"]
        return rows[:rows.index(next(t for t in rows if t.name == "smoothing"))] + [
            Tunable("weights", _WEIGHTS, default, meaning)] + rows[
            rows.index(next(t for t in rows if t.name == "smoothing")):]

    @classmethod
    def from_kwargs(cls, **kw) -> MpcOptions:
        """Options from keyword arguments; an unknown name lists the valid ones; a ``weights``
        dict becomes :class:`CostWeights`."""
        names = [f.name for f in fields(cls)]
        unknown = [k for k in kw if k not in names]
        if unknown:
            raise MpcError(f"unknown MPC option(s) {', '.join(unknown)}; valid: "
                           f"{', '.join(names)}")
        if isinstance(kw.get("weights"), dict):
            try:
                kw["weights"] = CostWeights(**kw["weights"])
            except TypeError as e:
                raise MpcError(f"bad cost weights: {e}") from None
        o = cls(**kw)
        o.check()
        return o


def shift_matrix(n_knots: int, knot_dt: float, shift: float) -> np.ndarray:
    """``(K, K)`` ``S`` such that ``S @ X`` are the knots of the piecewise-linear spline ``X``
    (knots at ``0, knot_dt, ...``) evaluated at ``shift + j knot_dt``, the last knot held beyond
    the end (the warm start of the next plan)."""
    s = np.clip((np.arange(n_knots) * knot_dt + shift) / knot_dt, 0.0, n_knots - 1.0)
    i = np.minimum(np.floor(s).astype(int), n_knots - 2)
    a = s - i
    S = np.zeros((n_knots, n_knots))
    S[np.arange(n_knots), i] = 1.0 - a
    S[np.arange(n_knots), i + 1] += a
    return S


def plan_timestep(options: MpcOptions, model) -> float:
    """The planning model's time step for a character of ``model`` (an ``MjModel``): the
    option, or :func:`~mjchar.controllers.sampling.planning.coarsest_plan_step` (the coarsest
    divisor of ``control_dt`` at which the model's contacts and limits keep their own time
    constants, not finer than the model's step)."""
    if options.plan_timestep is not None:
        return float(options.plan_timestep)
    return coarsest_plan_step(model, options.control_dt)


def stance_height(options: MpcOptions, reference) -> float:
    """The stance labels' height fraction the base targets of ``reference`` take."""
    if options.stance_height is not None:
        return float(options.stance_height)
    return MPC_STANCE_HEIGHT if getattr(reference, "floor", None) == "contact" else CONTACT_HEIGHT


@dataclass(frozen=True, eq=False)
class Plan:
    """What one planning step (:meth:`MpcController.plan`) chose: PD targets over the horizon
    from clip time ``time``, control ``i`` held over ``[time + i dt, time + (i + 1) dt)``.

    Attributes:
        time: clip time of control 0 (s); control_dt: seconds per control ``dt``.
        targets: ``(T, nu)`` PD targets (rad; the actuators' ``ctrl``).
        base: ``(T, nu)`` the base targets under them (inverse dynamics on the reference).
        knots: ``(K, nu)`` the plan's spline knots (offsets in units of the role widths): what
            a next plan shifts to warm start from.
        sigma: ``(K, nu)`` the search widths the plan leaves (CEM's; the noise otherwise).
        cost: the cost of the cheapest candidate rolled out.
        rollouts: candidates rolled out; physics_steps: planning-model steps simulated (every
            candidate's, early-terminated ones only as far as they ran); seconds: wall time.
    """

    time: float
    control_dt: float
    targets: np.ndarray
    base: np.ndarray
    knots: np.ndarray
    sigma: np.ndarray
    cost: float
    rollouts: int
    physics_steps: int
    seconds: float

    @property
    def offsets(self) -> np.ndarray:
        """``(T, nu)`` the plan's offsets over the base targets (rad)."""
        return self.targets - self.base

    @property
    def horizon(self) -> float:
        """Seconds the plan covers."""
        return len(self.targets) * self.control_dt

    def index(self, t: float) -> int:
        """The control containing clip time ``t`` (the first before ``time``, the last after
        the horizon)."""
        i = int(math.floor((t - self.time) / self.control_dt + 1e-6))
        return min(max(i, 0), len(self.targets) - 1)

    def target(self, t: float) -> np.ndarray:
        """``(nu,)`` PD targets (rad) at clip time ``t`` (held, past the horizon, at the last
        control's)."""
        return self.targets[self.index(t)]


class MpcController:
    """Closed-loop sampling MPC tracking ``target`` (a ReferenceMotion, or a pose ``(nq,)`` to
    hold) on native PD actuators; see the module docstring.

    The closed loop (:meth:`act`) calls :meth:`plan` every ``replan`` seconds from the
    character's state, warm started from its previous plan. :meth:`plan` is also the expert of
    imitation learning (DAgger): after :meth:`reset`, it plans from any full-physics state at any
    clip time, warm started from any nominal (docs/mpc.md, "Planning from any state").

    Args:
        target: what to track (``None``: the character's standing pose at :meth:`reset`).
        options: :class:`MpcOptions`.

    Attributes:
        stats: replanning steps, rollouts and planning-model physics steps simulated, seconds
            spent planning, and the chosen cost of every replanning step.
        last_plan: the latest :class:`Plan` (``None`` before the first).
    """

    name = "mpc"
    actuation = "native"

    def __init__(self, target=None, options: MpcOptions | None = None):
        self.options = options or MpcOptions()
        self.options.check()
        self.target = target
        self._executor: LocalExecutor | None = None
        self._rmodel = None
        self._rm_key = None
        self._bound = False
        self.last_plan: Plan | None = None

    # -- setup -------------------------------------------------------------------------------
    def reset(self, character: Character) -> None:
        """Bind to ``character``: native PD with the model's own gains, the planning model
        (:func:`planning_model`), the reference grid, a fresh plan and random stream."""
        o, ch = self.options, character
        o.check(ch.timestep)
        if not np.all(ch.actuation.position_actuators):
            body = ch.dof_body[ch.actuator_dof[np.flatnonzero(~ch.actuation.position_actuators)[0]]]
            joint = next(n for n, b in zip(ch.joint_names, ch.joint_bodies, strict=True)
                         if b == body)
            raise ControllerError(f"mpc needs <position> actuators on every actuated dof; joint "
                                  f"{joint} is a ball joint driven by motors: convert with "
                                  "--joint-model hinge (or full)")
        ch.actuation.set_mode("native")
        kp, kd = ch.actuation.default_gains()
        ch.actuation.set_native_gains(kp, kd)
        source = model_file(ch)
        plan_dt = plan_timestep(o, ch.model)
        tail_dt = plan_dt if o.tail_timestep is None else float(o.tail_timestep)
        key = (source, plan_dt, tail_dt, o.plan_solver)
        if self._rm_key != key:
            self._rmodel = planning_model(source, ch, plan_dt, o.plan_solver)
            self._tail_model = self._rmodel if tail_dt == plan_dt else planning_model(
                source, ch, tail_dt, o.plan_solver)
            self._rm_key = key
        ref = self.target
        if ref is None:
            from ..core.scenarios import standing_pose

            ref = standing_pose(ch)
        if isinstance(ref, np.ndarray):
            if ref.shape != (ch.nq,):
                raise MpcError(f"a pose target must have shape ({ch.nq},), got {ref.shape}")
            ref = PoseReference(ref, ch.nv)
        elif getattr(getattr(ref, "model", None), "nq", ch.nq) != ch.nq:
            raise MpcError("the reference motion was built for another model")
        self.reference = ref
        self.k = int(round(o.control_dt / ch.timestep))  # physics steps per control
        self.k_plan = int(round(o.control_dt / plan_dt))  # planning-model steps per control
        self.k_tail = int(round(o.control_dt / tail_dt))  # the tail's
        self.T = int(round(o.horizon / o.control_dt))
        self.R = int(round(o.replan / o.control_dt))
        self.T_near = min(int(round(o.near / o.control_dt)), self.T)
        self.widths = sampling_widths(ch, o.widths, o.width_scale)
        self.knot_dt = o.horizon / (o.knots - 1)
        self.spline = KnotSpline(self.T, o.control_dt, self.knot_dt, np.diag(self.widths))
        if self.spline.n_knots != o.knots:
            raise MpcError(f"internal: {self.spline.n_knots} knots instead of {o.knots}")
        self.cost = TrackingCost(ch, o.weights, site_names=self._rmodel.site_names)
        self._character = ch
        self._stance = stance_height(o, ref)
        self._grids: dict[float, ReferenceGrid] = {}
        self.grid = self._grid(0.0)
        threads = o.threads or os.cpu_count() or 1
        if self._executor is None or self._executor.threads != threads:
            if self._executor is not None:
                self._executor.close()
            self._executor = LocalExecutor(threads=threads)
        self._nstate = self._rmodel.nstate
        self.restart()
        self._bound = True

    def restart(self, seed: int | None = None) -> None:
        """Forget what one plan carries to the next (the noise boost's running cost, the last
        plan, the statistics) and restart the random stream from ``seed`` (``None``:
        ``options.seed``): what is planned next depends on nothing planned before (a labeller
        starting an episode)."""
        self.rng = np.random.default_rng(self.options.seed if seed is None else seed)
        self._mean_cost = None
        self.last_plan = None
        self._next = 0
        self.stats = {"replans": 0, "rollouts": 0, "physics_steps": 0, "planning_s": 0.0,
                      "costs": []}

    def close(self) -> None:
        """Release the rollout threads."""
        if self._executor is not None:
            self._executor.close()
            self._executor = None

    # -- control -----------------------------------------------------------------------------
    def act(self, character: Character, t: float) -> Action:
        """The plan's PD targets for the control interval containing ``t`` (replanning from
        the current state when a replanning time is reached)."""
        if not self._bound:
            raise ControllerError("mpc: act() called before reset()")
        cdt = self.options.control_dt
        n = int(math.floor(t / cdt + 1e-6))
        if self.last_plan is None or n >= self._next:
            self.plan(character.state.get_physics(), n * cdt, self.last_plan)
            self._next = n + self.R
            character.state.clear_warm_start()  # as every rollout starts
        return Action(target=self.last_plan.target(t))

    def plan(self, state: np.ndarray, t: float, nominal=None, *,
             rng: np.random.Generator | None = None, boost: float | None = None) -> Plan:
        """One planning step: ``N`` candidates rolled out from ``state`` at clip time ``t``,
        scored against the reference, the plan updated (module docstring, steps 1-6).

        Args:
            state: ``(nstate,)`` full-physics state of the character's model
                (``character.state.get_physics()``, or
                :func:`~mjchar.controllers.sampling.rollout.get_state` of any ``MjData`` of the
                same model); its own time field is not read.
            t: the clip time ``state`` is at (s, >= 0); need not be on the control grid.
            nominal: what the candidates are drawn around: ``None`` (the base targets), a
                :class:`Plan` (shifted to ``t``: the warm start of consecutive states), or PD
                targets (rad), ``(nu,)`` held over the horizon or ``(T', nu)`` per control from
                ``t`` (the last held), e.g. a learned policy's action; fitted to the knots in
                least squares on the sampled joints (the others keep their base targets).
            rng: the random stream (default: the controller's, seeded by ``options.seed``).
            boost: factor on the noise (default: the closed loop's, from the cost history of
                this controller's plans, see :attr:`MpcOptions.max_boost`).

        Returns:
            the :class:`Plan`; also kept as :attr:`last_plan`. Costs ``samples x horizon /
            plan_timestep`` planning-model steps at most (fewer with ``near``, ``keep`` and
            ``tail_timestep``).
        """
        if not self._bound:
            raise ControllerError("mpc: plan() called before reset()")
        o, w0 = self.options, _time.perf_counter()
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (self._nstate,):
            raise MpcError(f"state must be a ({self._nstate},) full-physics state "
                           f"(character.state.get_physics()), got shape {state.shape}")
        if not (math.isfinite(t) and t >= -1e-9):
            raise MpcError(f"the clip time must be a non-negative number, got {t!r}")
        rng = self.rng if rng is None else rng
        grid, n0 = self._grid_at(t)
        base = grid.base(n0, n0 + self.T)
        X, sigma, applied = self._warm(nominal, t, base)
        b = self._boost() if boost is None else float(boost)
        Xs = np.concatenate([X[None], X[None] + b * sigma * self._noise(rng, o.samples - 1,
                                                                      X.shape)])  # (N, K, nu)
        c, err, steps = self._batch(state, Xs, base, applied, grid, n0)
        if o.second_batch is not None and err[np.argmin(c)] > o.second_batch:
            more = X[None] + b * sigma * self._noise(rng, o.samples, X.shape)
            c2, _, steps2 = self._batch(state, more, base, applied, grid, n0)
            Xs, c, steps = np.concatenate([Xs, more]), np.concatenate([c, c2]), steps + steps2
        N = len(Xs)
        X, sigma, best = self._update(Xs, c, X, sigma)
        offsets = self.spline.offsets(X)
        t0 = grid.origin + n0 * o.control_dt
        seconds = _time.perf_counter() - w0
        p = Plan(time=t0, control_dt=o.control_dt, targets=base + offsets, base=base.copy(),
                 knots=X, sigma=sigma, cost=best, rollouts=N, physics_steps=steps,
                 seconds=seconds)
        self.last_plan = p
        st = self.stats
        st["replans"] += 1
        st["rollouts"] += N
        st["physics_steps"] += steps  # of the planning model
        st["costs"].append(best)
        st["planning_s"] += seconds
        return p

    # -- the planning step's parts -------------------------------------------------------------
    def _noise(self, rng: np.random.Generator, n: int, shape: tuple) -> np.ndarray:
        """``(n,) + shape`` standard normal perturbations (in pairs ``+eps, -eps`` and one more
        when ``n`` is odd, with ``antithetic``)."""
        if not self.options.antithetic:
            return rng.standard_normal((n,) + shape)
        half = rng.standard_normal((n // 2,) + shape)
        return np.concatenate([half, -half, rng.standard_normal((n % 2,) + shape)])

    def _batch(self, state, Xs: np.ndarray, base: np.ndarray, applied: np.ndarray, grid, n0):
        """``((N,) costs, (N,) mean joint errors (m), planning-model steps)`` of the candidate
        knots ``Xs (N, K, nu)`` rolled out from ``state``."""
        off = self.spline.offsets(Xs)  # (N, T, nu), radians
        return self._rollout_costs(state, base[None] + off, off, applied, grid, n0)

    def _grid(self, origin: float) -> ReferenceGrid:
        key = round(origin, 9)
        g = self._grids.get(key)
        if g is None:
            o = self.options
            g = ReferenceGrid(self._character, self.reference, self._rmodel, o.control_dt,
                              o.smoothing, stance_height=self._stance, origin=key)
            self._grids[key] = g
        return g

    def _grid_at(self, t: float) -> tuple[ReferenceGrid, int]:
        """The grid whose controls start at ``t``, and ``t``'s control index on it."""
        cdt = self.options.control_dt
        n0 = int(math.floor(t / cdt + 1e-6))
        frac = t - n0 * cdt
        if abs(frac) < 1e-9:
            return self.grid, n0
        return self._grid(frac), n0

    def _warm(self, nominal, t: float, base: np.ndarray):
        """``(X, sigma, applied)``: the knots and search widths the candidates are drawn
        around, and the offset (rad) applied just before ``t`` (the smoothness term's start)."""
        o, nu = self.options, base.shape[1]
        if nominal is None:
            return np.zeros((o.knots, nu)), np.full((o.knots, nu), o.noise), np.zeros(nu)
        if isinstance(nominal, Plan):
            if nominal.knots.shape != (o.knots, nu):
                raise MpcError(f"the nominal plan has knots {nominal.knots.shape}, this "
                               f"controller plans ({o.knots}, {nu})")
            S = shift_matrix(o.knots, self.knot_dt, t - nominal.time)
            applied = nominal.offsets[nominal.index(t - o.control_dt)]
            return S @ nominal.knots, S @ nominal.sigma, applied
        u = np.asarray(nominal, dtype=np.float64)
        if u.ndim == 1:
            u = u[None]
        if u.ndim != 2 or u.shape[1] != nu or len(u) < 1 or not np.isfinite(u).all():
            raise MpcError(f"a nominal must be a Plan or finite PD targets of shape ({nu},) "
                           f"or (T, {nu}), got shape {np.shape(nominal)}")
        u = np.concatenate([u[:self.T], np.repeat(u[-1:], max(0, self.T - len(u)), axis=0)])
        off = u - base  # (T, nu) rad
        X = np.zeros((o.knots, nu))
        s = self.widths > 0
        X[:, s] = np.linalg.lstsq(self.spline.B, off[:, s] / self.widths[s], rcond=None)[0]
        return X, np.full((o.knots, nu), o.noise), off[0]

    def _rollout_costs(self, state, controls, off, applied, grid, n0):
        """``((N,) costs, (N,) mean joint errors (m), planning-model steps)`` of the candidates
        ``controls (N, T, nu)``.

        Without a split (``near``), one batch over the horizon. With it, every candidate runs
        the near part; the ``keep`` fraction cheapest so far (fallen ones last) runs on over
        the tail, from where it stopped, on the tail model; the rest cost ``inf`` (no weight
        in the update)."""
        o, T, N = self.options, self.T, len(controls)
        rows = n0 + np.arange(T)
        grid.ensure(n0 + T)
        T1 = self.T_near
        if T1 <= 0 or T1 >= T:
            res = self._executor.evaluate(RolloutRequest(self._rmodel, state, controls,
                                                         self.k_plan))
            c, err = self._costs(res, off, applied, grid.features, rows)
            return c, err, N * T * self.k_plan
        n_keep = min(N, max(2, int(math.ceil(o.keep * N))))
        first = self._executor.evaluate(RolloutRequest(self._rmodel, state, controls[:, :T1],
                                                       self.k_plan))
        steps = N * T1 * self.k_plan
        c1 = self._costs(first, off[:, :T1], applied, grid.features, rows[:T1])[0]
        c1 = np.where(first.ok, c1, np.inf)  # a diverged candidate cannot be continued
        keep = np.sort(np.argsort(c1, kind="stable")[:n_keep])
        keep = keep[np.isfinite(c1[keep])]
        if not len(keep):  # every candidate diverged: the least bad by what they did
            return np.where(np.isfinite(c1), c1, 10 * FALL_COST), np.full(N, np.inf), steps
        c, err = np.full(N, np.inf), np.full(N, np.inf)
        near = first.take(keep)
        whole = near.then(self._executor.evaluate(RolloutRequest(
            self._tail_model, near.final_states, controls[keep, T1:], self.k_tail)))
        c[keep], err[keep] = self._costs(whole, off[keep], applied, grid.features, rows)
        return c, err, steps + len(keep) * (T - T1) * self.k_tail

    def _boost(self) -> float:
        """Noise factor: the last plan's cost over its running mean (time constant
        ``boost_time``), clipped to ``[1, max_boost]``; wider search after a disturbance."""
        o, c = self.options, self.stats["costs"]
        if o.max_boost <= 1.0 or not c:
            return 1.0
        a = min(1.0, o.replan / o.boost_time)
        self._mean_cost = c[-1] if self._mean_cost is None else (
            (1 - a) * self._mean_cost + a * c[-1])
        return float(np.clip(c[-1] / max(self._mean_cost, 1e-9), 1.0, o.max_boost))

    def _costs(self, res, off: np.ndarray, applied: np.ndarray, feats,
               rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``((N,) costs, (N,) mean joint errors (m))`` of the rollouts ``res`` of the offsets
        ``off (N, T, nu)`` against feature rows ``rows (T,)``: the mean tracking cost +
        smoothness + graded fall penalty, and the tracking metric's quantity."""
        c, err = self.cost.over_time(res.qpos, res.qvel, res.com, res.com_vel, res.sites, feats,
                                     rows, joint_error=True)
        c = np.where(np.isfinite(c), c, 1e3).mean(axis=1)
        if self.options.smoothness > 0:
            prev = np.concatenate([np.broadcast_to(applied, (off.shape[0], 1, off.shape[2])),
                                   off], axis=1)
            d = np.diff(prev, axis=1) / np.where(self.widths > 0, self.widths, 1.0)
            c = c + self.options.smoothness * (d * d).mean(axis=2).sum(axis=1)
        return c + fall_penalty(self.cost, res), err

    def _update(self, Xs: np.ndarray, c: np.ndarray, X: np.ndarray, sigma: np.ndarray):
        """The new nominal knots and CEM's sigma from candidates ``Xs (N, K, nu)`` and their
        costs ``c (N,)`` (``inf``: terminated early, no weight); returns ``(X, sigma, cost of
        the best candidate)``."""
        o = self.options
        order = np.argsort(c, kind="stable")
        best = float(c[order[0]])
        if o.update == "sampling":
            return Xs[order[0]].copy(), sigma, best
        if o.update == "mppi":
            spread = max(float(np.median(c[np.isfinite(c)])) - best, 1e-9)
            w = np.exp(-(c - best) / (o.temperature * spread))
            w /= w.sum()
            return np.tensordot(w, Xs, axes=1), sigma, best
        n_el = max(2, int(math.ceil(o.elites * np.isfinite(c).sum())))
        el = Xs[order[:n_el]]
        mean = el.mean(axis=0)
        std = el.std(axis=0)
        sigma = np.clip((1 - o.cem_rate) * sigma + o.cem_rate * std,
                        0.2 * o.noise, 2.0 * o.noise)
        return mean, sigma, best


def make_mpc(character: Character | None = None, target=None, **options) -> MpcController:
    """An :class:`MpcController` tracking ``target`` (a ReferenceMotion or a pose); ``options``
    are :class:`MpcOptions` fields."""
    return MpcController(target, MpcOptions.from_kwargs(**options))


register(ControllerSpec(
    name="mpc", label="sampling MPC tracker (closed loop)", kind="balance", factory=make_mpc,
    abilities=("track", "stand"), default_scenario="track",
    options=("params",), bench=("track",), expected=("track",),
    tunables=MpcOptions.tunables))
