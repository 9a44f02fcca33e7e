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
  ``plan_timestep``, by default twice the character's (half the rollout physics).
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

from mjchar.bvh.errors import MjcharError
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
    mapping,
    number,
    time,
    tunables,
)
from ..core.registry import ControllerSpec, register
from .executors import LocalExecutor
from .rollout import RolloutRequest
from .tracking import (
    ROLE_WIDTHS,
    CostWeights,
    PoseReference,
    ReferenceFeatures,
    TrackingCost,
    fall_penalty,
    inverse_dynamics_targets,
    reference_features,
    sampling_widths,
    tracking_rollout_model,
)
from .trajectory import model_fingerprint
from .trajopt import KnotSpline

__all__ = ["MPC_STANCE_HEIGHT", "MPC_WIDTHS", "UPDATES", "MpcController", "MpcError",
           "MpcOptions", "ReferenceGrid", "make_mpc", "shift_matrix", "stance_height"]

#: plan updates: predictive sampling, MPPI, cross-entropy
UPDATES = ("sampling", "mppi", "cem")
#: the stance labels' height (fraction of the root height) on a contact-floor reference, whose
#: supporting feet are on the floor: 3 % labels walk60's landing foot only once it is down
#: (the raw-mocap 12 % labels it 5 cm up and gives it half the weight); measured closed loop
#: on walk60, walk_forward and walk_and_turn_right at 2, 3, 6 and 12 % (docs/mpc.md)
MPC_STANCE_HEIGHT = 0.03
#: the MPC's default noise widths: the arms and head are not sampled (their PD tracks them;
#: halving the dimension of the search tracked walk60 better, docs/mpc.md); the legs and
#: spine use the shared ``ROLE_WIDTHS``
MPC_WIDTHS = {"clavicle": 0.0, "shoulder": 0.0, "elbow": 0.0, "wrist": 0.0, "head": 0.0}
#: the planning model's default time step in character time steps: 2 halves the rollout physics
#: (1.7x the real-time factor) and met every bar of docs/mpc.md on the bundled humanoid (0.004 s;
#: 16/16 pushes, the 60 s loop, the clips, the perturbed starts); used when ``control_dt`` is a
#: whole number of it, else the character's own step
PLAN_STEP_RATIO = 2


def _whole_multiple(span: float, step: float) -> bool:
    """Whether ``span`` is a whole number (>= 1) of ``step`` (to 1e-6 of a step)."""
    n = span / step
    return abs(n - round(n)) <= 1e-6 and round(n) >= 1


class MpcError(MjcharError):
    """The MPC was given settings it cannot use (sizes, times, an unknown update)."""


#: the cost weights' accepted values (the :class:`CostWeights` fields, each >= 0)
_WEIGHTS = Spec("none", kind="mapping", low=0.0, high=1e6,
                choices=tuple(f.name for f in fields(CostWeights)))


@dataclass
class MpcOptions:
    """Sampling MPC settings (see the module docstring).

    Attributes:
        samples: candidates per replanning step ``N`` (the nominal included), >= 2.
        horizon: seconds planned ahead ``H`` (a whole number of controls).
        knots: spline knots over the horizon ``K`` (>= 2; knot spacing ``H / (K - 1)``).
        replan: seconds between replanning steps (a whole number of controls, <= horizon).
        control_dt: seconds per PD-target control (a whole number of physics steps).
        plan_timestep: the time step of the planning model the rollouts run on (``None``:
            :data:`PLAN_STEP_RATIO` times the character's own, see :func:`plan_timestep`);
            ``control_dt`` must be a whole number of it. A coarser step makes each rollout
            cheaper; the character itself still steps at its own time step, and giving that
            step here makes the rollouts exact.
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
    horizon: float = time(0.7, gt=0, le=5)
    knots: int = integer(3, ge=2, le=100)
    replan: float = time(0.04, gt=0, le=5)
    control_dt: float = time(0.02, gt=0, le=0.1)
    plan_timestep: float | None = time(None, ge=1e-5, le=0.01, optional=True)
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
            if not _whole_multiple(getattr(self, k), self.control_dt):
                raise MpcError(f"{k} ({getattr(self, k)} s) must be a whole number of controls "
                               f"of {self.control_dt} s")
        if self.plan_timestep is not None:
            v = self.plan_timestep
            if isinstance(v, bool) or not (isinstance(v, int | float) and math.isfinite(v)
                                           and v > 0):
                raise MpcError(f"plan_timestep must be a positive number or None, got {v!r}")
            if not _whole_multiple(self.control_dt, v):
                raise MpcError(f"control_dt {self.control_dt} s is not a whole number of "
                               f"plan_timestep {v} s planning steps")
        if self.replan > self.horizon + 1e-9:
            raise MpcError(f"replan ({self.replan} s) cannot exceed horizon ({self.horizon} s)")
        if timestep is not None:
            if not _whole_multiple(self.control_dt, timestep):
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


def plan_timestep(options: MpcOptions, timestep: float) -> float:
    """The planning model's time step for a character stepping at ``timestep``: the option, or
    :data:`PLAN_STEP_RATIO` ``x timestep`` where ``control_dt`` is a whole number of that, else
    ``timestep``."""
    if options.plan_timestep is not None:
        return float(options.plan_timestep)
    coarse = PLAN_STEP_RATIO * float(timestep)
    return coarse if _whole_multiple(options.control_dt, coarse) else float(timestep)


def stance_height(options: MpcOptions, reference) -> float:
    """The stance labels' height fraction the base targets of ``reference`` take."""
    if options.stance_height is not None:
        return float(options.stance_height)
    return MPC_STANCE_HEIGHT if getattr(reference, "floor", None) == "contact" else CONTACT_HEIGHT


class ReferenceGrid:
    """Base targets at control midpoints and reference features at control ends on the grid
    ``n control_dt`` (``n = 0, 1, ...``), computed in blocks of ``block`` controls on demand
    (so an endless cyclic reference costs memory in proportion to the time tracked).

    Base targets (:func:`inverse_dynamics_targets`) of a block are computed with a margin of
    four smoothing widths on each side, so blocks join without a visible seam.
    """

    def __init__(self, character: Character, reference, rmodel, control_dt: float,
                 smoothing: float, block: int = 50, *, stance_height: float):
        self.character, self.reference, self.rmodel = character, reference, rmodel
        self.stance_height = float(stance_height)
        self.dt, self.smoothing, self.block = float(control_dt), float(smoothing), int(block)
        self.pad = int(math.ceil(4 * smoothing / control_dt)) + 1 if smoothing > 0 else 0
        self._base = np.zeros((0, character.nu))
        self.features: ReferenceFeatures | None = None

    @property
    def size(self) -> int:
        return len(self._base)

    def ensure(self, n_end: int) -> None:
        """Compute rows up to control ``n_end`` (exclusive)."""
        while self.size < n_end:
            a = self.size
            b = a + self.block
            n = np.arange(a - self.pad, b + self.pad)
            # both feet where no foot is labelled: measured better closed loop than SAMCON's
            # lowest foot (docs/mpc.md, "The clip's start and grounded stance labels")
            base = inverse_dynamics_targets(self.character, self.reference, (n + 0.5) * self.dt,
                                            smoothing=self.smoothing, unlabelled="both",
                                            stance_height=self.stance_height,
                                            )[self.pad:len(n) - self.pad]
            f = reference_features(self.rmodel, self.reference, (np.arange(a, b) + 1) * self.dt)
            self._base = np.concatenate([self._base, base])
            if self.features is None:
                self.features = f
            else:
                self.features = ReferenceFeatures(*(
                    np.concatenate([getattr(self.features, k.name), getattr(f, k.name)])
                    for k in fields(ReferenceFeatures)))

    def base(self, a: int, b: int) -> np.ndarray:
        """``(b - a, nu)`` base targets of controls ``a .. b-1``."""
        self.ensure(b)
        return self._base[a:b]


class MpcController:
    """Closed-loop sampling MPC tracking ``target`` (a ReferenceMotion, or a pose ``(nq,)`` to
    hold) on native PD actuators; see the module docstring.

    Args:
        target: what to track (``None``: the character's standing pose at :meth:`reset`).
        options: :class:`MpcOptions`.

    Attributes:
        stats: replanning steps, rollouts and planning-model physics steps simulated, seconds
            spent planning, and the chosen cost of every replanning step.
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

    # -- setup -------------------------------------------------------------------------------
    def reset(self, character: Character) -> None:
        """Bind to ``character``: native PD with the model's own gains, the rollout model (same
        physics; the time step :func:`plan_timestep`), the reference
        grid, a fresh plan and random stream."""
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
        source = _model_file(ch)
        plan_dt = plan_timestep(o, ch.timestep)
        key = (source, plan_dt)
        if self._rm_key != key:
            rm = tracking_rollout_model(source, ch)
            rm.model.opt.timestep = plan_dt  # the fingerprint leaves the time step out
            if model_fingerprint(rm.model) != model_fingerprint(ch.model):
                raise MpcError(f"the character's physics differs from its model file "
                               f"{source} (edited gains or options?)")
            self._rmodel, self._rm_key = rm, key
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
        self.T = int(round(o.horizon / o.control_dt))
        self.R = int(round(o.replan / o.control_dt))
        self.widths = sampling_widths(ch, o.widths, o.width_scale)
        self.knot_dt = o.horizon / (o.knots - 1)
        self.spline = KnotSpline(self.T, o.control_dt, self.knot_dt, np.diag(self.widths))
        if self.spline.n_knots != o.knots:
            raise MpcError(f"internal: {self.spline.n_knots} knots instead of {o.knots}")
        self.cost = TrackingCost(ch, o.weights, site_names=self._rmodel.site_names)
        self.grid = ReferenceGrid(ch, ref, self._rmodel, o.control_dt, o.smoothing,
                                  stance_height=stance_height(o, ref))
        threads = o.threads or os.cpu_count() or 1
        if self._executor is None or self._executor.threads != threads:
            if self._executor is not None:
                self._executor.close()
            self._executor = LocalExecutor(threads=threads)
        self.rng = np.random.default_rng(o.seed)
        nu = ch.nu
        self.X = np.zeros((o.knots, nu))
        self.sigma = np.full((o.knots, nu), o.noise)
        self._mean_cost = None
        self._n0 = 0
        self._plan: np.ndarray | None = None
        self._offsets = np.zeros((self.T, nu))
        self._next = 0
        self.stats = {"replans": 0, "rollouts": 0, "physics_steps": 0, "planning_s": 0.0,
                      "costs": []}
        self._bound = True

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
        n = int(math.floor(t / self.options.control_dt + 1e-6))
        if self._plan is None or n >= self._next:
            self._replan(character, n)
        i = min(max(n - self._n0, 0), self.T - 1)
        return Action(target=self._plan[i])

    def _replan(self, ch: Character, n0: int) -> None:
        o = self.options
        t0 = _time.perf_counter()
        cdt = o.control_dt
        if self._plan is not None:
            S = shift_matrix(o.knots, self.knot_dt, (n0 - self._n0) * cdt)
            X = S @ self.X
            sigma = S @ self.sigma
            applied = self._offsets[min(max(n0 - self._n0 - 1, 0), self.T - 1)]
        else:
            X, sigma, applied = self.X, self.sigma, np.zeros(ch.nu)
        N = o.samples
        if o.antithetic:  # pairs +eps, -eps (and one more when N - 1 is odd)
            half = self.rng.standard_normal(((N - 1) // 2,) + X.shape)
            extra = self.rng.standard_normal(((N - 1) % 2,) + X.shape)
            eps = np.concatenate([half, -half, extra])
        else:
            eps = self.rng.standard_normal((N - 1,) + X.shape)
        Xs = np.concatenate([X[None], X[None] + self._boost() * sigma * eps])  # (N, K, nu)
        off = self.spline.offsets(Xs)  # (N, T, nu), radians
        base = self.grid.base(n0, n0 + self.T)
        state = ch.state.get_physics()
        req = RolloutRequest(self._rmodel, state, base[None] + off, self.k_plan)
        res = self._executor.evaluate(req)
        c = self._costs(res, off, applied, n0)
        X, sigma, best = self._update(Xs, c, X, sigma)
        self.X, self.sigma = X, sigma
        self._offsets = self.spline.offsets(X)
        self._plan = base + self._offsets
        self._n0, self._next = n0, n0 + self.R
        ch.state.clear_warm_start()  # as every rollout started
        st = self.stats
        st["replans"] += 1
        st["rollouts"] += N
        st["physics_steps"] += N * self.T * self.k_plan  # of the planning model
        st["costs"].append(float(best))
        st["planning_s"] += _time.perf_counter() - t0

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

    def _costs(self, res, off: np.ndarray, applied: np.ndarray, n0: int) -> np.ndarray:
        """``(N,)`` mean tracking cost + smoothness + graded fall penalty of the rollouts."""
        feats = self.grid.features
        c = np.empty((off.shape[0], self.T))
        for i in range(self.T):
            c[:, i] = self.cost(res.qpos[:, i], res.qvel[:, i], res.com[:, i],
                                res.com_vel[:, i], res.sites[:, i], feats, n0 + i)
        c = np.where(np.isfinite(c), c, 1e3).mean(axis=1)
        if self.options.smoothness > 0:
            prev = np.concatenate([np.broadcast_to(applied, (off.shape[0], 1, off.shape[2])),
                                   off], axis=1)
            d = np.diff(prev, axis=1) / np.where(self.widths > 0, self.widths, 1.0)
            c = c + self.options.smoothness * (d * d).mean(axis=2).sum(axis=1)
        return c + fall_penalty(self.cost, res)

    def _update(self, Xs: np.ndarray, c: np.ndarray, X: np.ndarray, sigma: np.ndarray):
        """The new nominal knots and CEM's sigma from candidates ``Xs (N, K, nu)`` and their
        costs ``c (N,)``; returns ``(X, sigma, cost of the best candidate)``."""
        o = self.options
        order = np.argsort(c, kind="stable")
        best = float(c[order[0]])
        if o.update == "sampling":
            return Xs[order[0]].copy(), sigma, best
        if o.update == "mppi":
            spread = max(float(np.median(c)) - best, 1e-9)
            w = np.exp(-(c - best) / (o.temperature * spread))
            w /= w.sum()
            return np.tensordot(w, Xs, axes=1), sigma, best
        n_el = max(2, int(math.ceil(o.elites * len(c))))
        el = Xs[order[:n_el]]
        mean = el.mean(axis=0)
        std = el.std(axis=0)
        sigma = np.clip((1 - o.cem_rate) * sigma + o.cem_rate * std,
                        0.2 * o.noise, 2.0 * o.noise)
        return mean, sigma, best



def _model_file(character: Character) -> str:
    """The MJCF file the rollout model is compiled from: the Character's own, or for a
    Character built from an ``MjModel`` the bundled humanoid's when the physics is the same
    (what ``mjchar bench`` does); else :class:`MpcError`."""
    if character.source is not None:
        return character.source
    import mujoco

    from mjchar.bvh.bundled.assets import humanoid_path

    path = os.fspath(humanoid_path())
    if model_fingerprint(mujoco.MjModel.from_xml_path(path)) == model_fingerprint(
            character.model):
        return path
    raise MpcError("mpc builds its rollout model from the model file: give the Character an "
                   "MJCF path (a Character built from an MjModel works only for the bundled "
                   "humanoid)")


def make_mpc(character: Character | None = None, target=None, **options) -> MpcController:
    """An :class:`MpcController` tracking ``target`` (a ReferenceMotion or a pose); ``options``
    are :class:`MpcOptions` fields."""
    return MpcController(target, MpcOptions.from_kwargs(**options))


register(ControllerSpec(
    name="mpc", label="sampling MPC tracker (closed loop)", kind="balance", factory=make_mpc,
    abilities=("track", "stand"), default_scenario="track",
    options=("params",), bench=("track",), expected=("track",),
    tunables=MpcOptions.tunables))
