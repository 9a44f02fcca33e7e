"""SAMCON: sampling-based reconstruction of a motion clip as open-loop PD targets.

Follows Liu, Yin, van de Panne, Shao and Xu, "Sampling-based Contact-rich Motion Control"
(SIGGRAPH 2010), with the options of Liu, Yin, van de Panne and Guo, "Improving Sampling-based
Motion Control" (Eurographics 2015). The character is the converted humanoid with its native
``<position>`` actuators (MuJoCo applies ``kp (u - q) - kd qdot`` inside the step); nothing ever
pushes the root.

The algorithm, with the paper's symbols:

1. **Base targets.** The clip (a ``mjchar.bvh.reference.reference_motion.ReferenceMotion``) is cut
   into slices of
   ``slice_dt`` (~0.1 s), each made of controls of ``control_dt``. The base PD target of each
   control comes from inverse dynamics on the reference (:func:`inverse_dynamics_targets`):
   ``q_hat = q + (tau_ID + kd qdot) / kp``, where ``tau_ID`` is ``mj_inverse``'s joint torque
   after the unactuated root wrench has been handed to the stance feet (minimum-norm contact
   wrenches), smoothed over time.
2. **Sampling.** For slice ``j`` the saved states ``S_j`` (``n_saved`` of them, the start state
   for ``j = 0``) each receive an equal share of ``n_samples`` samples. A sample is a constant
   offset ``Delta`` per actuator added to the slice's base targets, drawn from a uniform
   (``[mu - w, mu + w]``) or Gaussian (``N(mu, (w/2)^2)``) distribution with per-joint widths
   ``w`` by role (:data:`ROLE_WIDTHS`). All samples of a slice are simulated in one batch with
   :mod:`mjchar.controllers.sampling.rollout` through an executor (local threads or Ray).
3. **Cost** at the end of each slice (:class:`TrackingCost`)::

       E = wp Ep + wr Er + we Ee + wb Eb + wc Ec + wj Ej

   ``Ep``: sum over joints of the rotation difference (+ ``v`` x joint velocity difference);
   ``Er``: root orientation angle (+ ``v`` x root angular velocity difference);
   ``Ee``: sum of end-effector (head, hands, feet, toes) height differences;
   ``Eb``: sum over end effectors of ``|(c - p_e)_xy / c_z - (c_bar - p_bar_e)_xy / c_bar_z|``
   (+ ``v`` x COM velocity difference). Not in the paper: ``Ec``, the world COM error predicted
   ``h`` s ahead (``c - c_bar + h (c_dot - c_bar_dot)``, horizontal norm + vertical absolute
   value), and ``Ej``, the mean world joint position error (recorded by sites at the joint
   bodies, :func:`tracking_rollout_model`); they keep the reconstruction on the clip's path.
   Weights default to (5, 3, 30, 10, 100, 100), ``v = 0.1``, ``h = 0.3``. A sample whose body
   (not the feet) touches the floor, whose root drops below the fall height or whose simulation
   diverges gets :data:`FALL_COST` added.
4. **Selection** (:func:`select_diverse`): the best ``elite_fraction`` of the saved set by cost,
   then the rest drawn at random from the next ranks, with at most ``max_children`` children per
   parent state, so the saved set does not collapse onto one parent (the 2010 paper's concern).
5. **Result**: the lowest total-cost path, traced back through the parents from the last slice;
   its targets (base + offsets) are the :class:`~mjchar.controllers.sampling.trajectory.Trajectory`.

The pieces SAMCON shares with CMA-ES (widths by role, inverse-dynamics base targets, the
rollout model with joint sites, the cost) live in :mod:`mjchar.controllers.sampling.tracking`.

2015 options: ``adapt`` updates each slice's sampling mean and per-dof width from its elite
samples with a CMA-style weighted rank-mu update (``iterations`` > 1 reuses the adapted
distributions on the next pass); ``window`` > 1 samples offsets for ``window`` consecutive
slices at once, selects by the summed cost over the window (look-ahead) and commits one slice
per step (the sliding window).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from mjchar.bvh.errors import MjcharError

from ..core.character import Character
from .executors import Executor, LocalExecutor
from .rollout import RolloutRequest
from .tracking import (
    FALL_COST,
    CostWeights,
    TrackingCost,
    clip_window,
    inverse_dynamics_targets,
    reference_features,
    sampling_widths,
    tracking_rollout_model,
)
from .trajectory import Trajectory, model_fingerprint, register_replay

__all__ = ["DISTRIBUTIONS", "RECONSTRUCTION_OPTIONS", "Samcon", "SamconError", "SamconOptions",
           "SamconResult", "select_diverse", "slice_layout"]

DISTRIBUTIONS = ("uniform", "gaussian")

class SamconError(MjcharError):
    """SAMCON was given options it cannot use (sizes, widths, a motion too short)."""



def slice_layout(duration: float, slice_dt: float, control_dt: float) -> list[tuple[int, int]]:
    """Control index ranges ``[(start, stop), ...]`` of the slices covering ``duration`` s
    (the last slice may be shorter; one shorter than half a slice is merged into the previous)."""
    n = int(round(duration / control_dt))
    c = int(round(slice_dt / control_dt))
    if n < 1 or c < 1:
        raise SamconError(f"duration {duration} s / slice {slice_dt} s / control {control_dt} s "
                          f"give no controls")
    bounds = list(range(0, n, c)) + [n]
    if len(bounds) > 2 and bounds[-1] - bounds[-2] < c / 2:
        del bounds[-2]
    return list(zip(bounds[:-1], bounds[1:], strict=True))


#: prefix of the sites :func:`tracking_rollout_model` adds at every joint body's origin


# ------------------------------------------------------------------------------------------------
# selection


def select_diverse(cost: np.ndarray, parent: np.ndarray, n_keep: int, rng: np.random.Generator,
                   *, elite_fraction: float = 0.5, pool_factor: float = 3.0,
                   max_children: int | None = None) -> np.ndarray:
    """Pick ``n_keep`` sample indices, best first, keeping the saved set diverse.

    The first ``ceil(elite_fraction n_keep)`` are the lowest-cost samples; the rest are drawn
    uniformly (from ``rng``) among the next ranks up to ``pool_factor n_keep``. In both stages a
    parent contributes at most ``max_children`` samples (default ``max(2, ceil(n_keep / 10))``)
    while other candidates remain. Samples with infinite cost are taken only when nothing else
    is left.

    Args:
        cost: ``(B,)`` costs; parent: ``(B,)`` parent index of each sample.
    Returns:
        ``(min(n_keep, B),)`` int indices sorted by cost.
    """
    cost = np.asarray(cost, dtype=float)
    parent = np.asarray(parent)
    n = len(cost)
    n_keep = min(int(n_keep), n)
    if max_children is None:
        max_children = max(2, math.ceil(n_keep / 10))
    order = np.argsort(cost, kind="stable")
    finite = order[np.isfinite(cost[order])]
    counts: dict[int, int] = {}
    chosen: list[int] = []
    taken = np.zeros(n, dtype=bool)

    def take(i: int, cap: bool) -> bool:
        p = int(parent[i])
        if taken[i] or (cap and counts.get(p, 0) >= max_children):
            return False
        taken[i] = True
        counts[p] = counts.get(p, 0) + 1
        chosen.append(int(i))
        return True

    n_elite = min(n_keep, math.ceil(elite_fraction * n_keep))
    rest = []
    for i in finite:
        if len(chosen) >= n_elite:
            rest.append(i)
            continue
        if not take(i, True):
            rest.append(i)
    pool = [i for i in rest if not taken[i]][: max(0, int(pool_factor * n_keep) - len(chosen))]
    if pool and len(chosen) < n_keep:
        for i in rng.permutation(pool):
            if len(chosen) >= n_keep:
                break
            take(int(i), True)
    for cap in (True, False):  # fill up from the ranking, relaxing the cap, then the fallen
        for i in (finite if cap else order):
            if len(chosen) >= n_keep:
                break
            take(int(i), cap)
    chosen = np.array(chosen, dtype=int)
    return chosen[np.argsort(cost[chosen], kind="stable")]


# ------------------------------------------------------------------------------------------------
# the algorithm


@dataclass
class SamconOptions:
    """SAMCON settings (see the module docstring).

    Attributes:
        samples: samples per slice (N); saved: saved states kept per slice (N_s).
        slice_dt: seconds per slice; control_dt: seconds per PD-target control (a whole number
            of physics steps, dividing ``slice_dt``).
        distribution: ``"uniform"`` or ``"gaussian"``; widths: role -> half-width (rad)
            overriding :data:`ROLE_WIDTHS`; width_scale: factor on all widths.
        weights: :class:`CostWeights`.
        elite_fraction, pool_factor, max_children: :func:`select_diverse`.
        adapt: CMA-style per-slice update of the sampling mean and widths (2015).
        adapt_rate: learning rate of the width update (the mean moves to the elites' weighted
            mean times ``adapt_mean_rate``); adapt_elites: elites used (fraction of saved).
        window: slices sampled and scored together (sliding window, 2015); 1 = the 2010 scheme.
        iterations: passes over the clip (useful with ``adapt``).
        smoothing: seconds of Gaussian smoothing of the inverse-dynamics targets.
        id_targets: use inverse-dynamics base targets (else the raw reference pose).
        retries: extra attempts (with doubled widths) at a slice where every sample fell.
        cost_at: ``"end"`` scores a slice at its end (the paper); ``"all"`` averages the cost
            over the slice's control ends.
        interpolate: ramp the offset linearly over a slice from the previous slice's offset
            (continuous targets) instead of holding it constant (the paper).
        start: clip time (s) of the first slice; duration: seconds to reconstruct (default: to
            the end of the clip).
        seed: random seed.
    """

    samples: int = 1000
    saved: int = 200
    slice_dt: float = 0.1
    control_dt: float = 0.02
    distribution: str = "uniform"
    widths: dict = field(default_factory=dict)
    width_scale: float = 1.0
    weights: CostWeights = field(default_factory=CostWeights)
    elite_fraction: float = 0.5
    pool_factor: float = 3.0
    max_children: int | None = None
    adapt: bool = False
    adapt_rate: float = 0.3
    adapt_mean_rate: float = 0.5
    adapt_elites: float = 0.5
    window: int = 1
    iterations: int = 1
    smoothing: float = 0.03
    id_targets: bool = True
    retries: int = 2
    cost_at: str = "end"
    interpolate: bool = False
    start: float = 0.0
    duration: float | None = None
    seed: int = 0

    def check(self, timestep: float) -> None:
        """Raise :class:`SamconError` for impossible settings."""
        for k in ("samples", "saved", "window", "iterations"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1:
                raise SamconError(f"{k} must be a positive integer, got {v!r}")
        if self.saved > self.samples:
            raise SamconError(f"saved ({self.saved}) cannot exceed samples ({self.samples})")
        if self.cost_at not in ("end", "all"):
            raise SamconError(f"cost_at must be 'end' or 'all', got {self.cost_at!r}")
        if self.distribution not in DISTRIBUTIONS:
            raise SamconError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}, got "
                              f"{self.distribution!r}")
        for k in ("slice_dt", "control_dt"):
            v = getattr(self, k)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise SamconError(f"{k} must be a positive number of seconds, got {v!r}")
        k = self.control_dt / timestep
        if abs(k - round(k)) > 1e-6:
            raise SamconError(f"control_dt {self.control_dt} s is not a whole number of "
                              f"{timestep} s physics steps")
        c = self.slice_dt / self.control_dt
        if abs(c - round(c)) > 1e-6:
            raise SamconError(f"slice_dt {self.slice_dt} s is not a whole number of controls "
                              f"of {self.control_dt} s")
        for k in ("elite_fraction", "adapt_rate", "adapt_mean_rate", "adapt_elites"):
            v = getattr(self, k)
            if not (0 < v <= 1):
                raise SamconError(f"{k} must be in (0, 1], got {v!r}")
        if self.duration is not None and not (math.isfinite(self.duration)
                                              and self.duration > 0):
            raise SamconError(f"duration must be positive seconds, got {self.duration!r}")
        if not (math.isfinite(self.start) and self.start >= 0):
            raise SamconError(f"start must be non-negative seconds, got {self.start!r}")


#: the options ``mjchar samcon`` and the benchmark reconstruct clips with: the 2010 scheme plus
#: the 2015 per-slice distribution update over two passes and the 2015 sliding window of two
#: slices (a slice's offsets are judged by how the next slice goes too: a foot placed wrong
#: costs the rest of its stance; docs/sampling.md, "Tuning trials" and "Zoo rigs")
RECONSTRUCTION_OPTIONS = {"samples": 1000, "saved": 200, "adapt": True, "iterations": 2,
                          "window": 2}


@dataclass
class SamconResult:
    """What :meth:`Samcon.run` returns.

    Attributes:
        trajectory: the reconstructed :class:`~mjchar.controllers.sampling.trajectory.Trajectory`.
        slice_costs: ``(n_slices,)`` cost of the chosen path at each slice end.
        total_cost: their sum; fell: the chosen path contains a fallen slice.
        samples_simulated: sample-slices simulated (a window sample counts its slices);
        physics_steps: physics steps simulated; wall_s: seconds; rollout_s: seconds inside the
        executor; samples_per_s: ``samples_simulated / wall_s``.
        history: per pass, per slice: best and median cost, fallen fraction.
    """

    trajectory: Trajectory
    slice_costs: np.ndarray
    total_cost: float
    fell: bool
    samples_simulated: int
    physics_steps: int
    wall_s: float
    rollout_s: float
    history: list = field(default_factory=list)

    @property
    def samples_per_s(self) -> float:
        return self.samples_simulated / self.wall_s if self.wall_s > 0 else 0.0


class Samcon:
    """SAMCON reconstruction of ``reference`` on ``character``'s model.

    Args:
        reference: a ``mjchar.bvh.reference.reference_motion.ReferenceMotion`` built on the model.
        model: the model source (MJCF path; ``None``: the bundled humanoid) the character and
            the rollout model are compiled from.
        options: :class:`SamconOptions`.
        executor: where rollouts run (default: a :class:`LocalExecutor` owned by this object).
        source_motion: path recorded in the trajectory file.
    """

    def __init__(self, reference, *, model=None, options: SamconOptions | None = None,
                 executor: Executor | None = None, source_motion: str = ""):
        from mjchar.bvh.bundled.assets import humanoid_path

        self.options = options or SamconOptions()
        src = humanoid_path() if model is None else model
        self.character = Character(src)
        self.rmodel = tracking_rollout_model(src, self.character)
        if model_fingerprint(self.rmodel.model) != model_fingerprint(self.character.model):
            raise SamconError("internal: the rollout model's physics differs from the model's")
        if reference.model.nq != self.character.nq:
            raise SamconError("the reference motion was built for another model")
        self.reference = reference
        self.options.check(self.character.timestep)
        self._own_executor = executor is None
        self.executor = executor if executor is not None else LocalExecutor()
        self.source_motion = str(source_motion)
        o = self.options
        self.duration = clip_window(reference, o.start, o.duration, SamconError)
        self.slices = slice_layout(self.duration, o.slice_dt, o.control_dt)
        self.n_controls = self.slices[-1][1]
        self.k = int(round(o.control_dt / self.character.timestep))
        self.widths = sampling_widths(self.character, o.widths, o.width_scale)
        self.cost = TrackingCost(self.character, o.weights, site_names=self.rmodel.site_names)
        t_mid = o.start + (np.arange(self.n_controls) + 0.5) * o.control_dt
        if o.id_targets:
            self.base = inverse_dynamics_targets(self.character, reference, t_mid,
                                                 smoothing=o.smoothing)
        else:
            self.base = reference.qpos(t_mid)[:, self.character.actuator_qpos]
        # reference rows at every control end (row i: time start + (i + 1) control_dt)
        self.features = reference_features(
            self.rmodel, reference, o.start + (np.arange(self.n_controls) + 1) * o.control_dt)
        self.q0 = reference.qpos(o.start)
        self.v0 = reference.qvel(o.start)
        self.state0 = self.rmodel.initial_state(self.q0, self.v0)

    def close(self) -> None:
        """Release the executor if this object created it."""
        if self._own_executor:
            self.executor.close()

    def __enter__(self) -> Samcon:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- sampling --------------------------------------------------------------------------------
    def _draw(self, rng, mean: np.ndarray, scale: np.ndarray, n: int) -> np.ndarray:
        """``(n, nu)`` offsets from the slice distribution (mean, scale: ``(nu,)``)."""
        if self.options.distribution == "uniform":
            return mean + rng.uniform(-1.0, 1.0, (n, len(mean))) * scale
        return mean + rng.normal(0.0, 0.5, (n, len(mean))) * scale

    def _adapt(self, mean, scale, elites: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """CMA-style rank-mu update of one slice's (mean, scale) from ``(mu, nu)`` elite
        offsets sorted best first (log weights; the variance is in the distribution's own
        units: uniform half-width^2 / 3, Gaussian (w/2)^2)."""
        o = self.options
        mu = len(elites)
        if mu == 0:
            return mean, scale
        w = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
        w /= w.sum()
        new_mean = mean + o.adapt_mean_rate * (w @ elites - mean)
        kappa = 3.0 if o.distribution == "uniform" else 4.0  # scale^2 / variance
        var = (scale ** 2) / kappa
        var = (1 - o.adapt_rate) * var + o.adapt_rate * (w @ (elites - mean) ** 2)
        lo, hi = 0.1 * self.widths, 2.0 * self.widths
        new_scale = np.clip(np.sqrt(kappa * var), lo, hi)
        return new_mean, new_scale

    # -- the main loop -------------------------------------------------------------------------
    def run(self, progress: bool | Callable = True) -> SamconResult:
        """Reconstruct the clip; ``progress``: a tqdm bar (True), nothing (False), or a callable
        ``f(pass_index, slice_index, n_slices, best_cost)``."""
        o = self.options
        rng = np.random.default_rng(o.seed)
        n_sl = len(self.slices)
        means = np.zeros((n_sl, self.character.nu))
        scales = np.tile(self.widths, (n_sl, 1))
        wall0 = time.perf_counter()
        stats = {"samples": 0, "steps": 0, "rollout_s": 0.0}
        history = []
        best = None
        for it in range(o.iterations):
            path, hist = self._pass(rng, means, scales, stats, progress, it)
            history.append(hist)
            if best is None or path["total"] < best["total"] or (best["fell"] and
                                                                 not path["fell"]):
                best = path
        wall = time.perf_counter() - wall0
        traj = self._trajectory(best["offsets"], {
            "method": "samcon", "options": _options_dict(o), "total_cost": best["total"],
            "slice_costs": best["costs"].tolist(), "fell": best["fell"], "wall_s": wall,
            "samples_simulated": stats["samples"], "physics_steps": stats["steps"],
            "rollout_s": stats["rollout_s"], "executor": type(self.executor).__name__,
            "parallelism": self.executor.parallelism})
        return SamconResult(traj, best["costs"], best["total"], best["fell"], stats["samples"],
                            stats["steps"], wall, stats["rollout_s"], history)

    def _pass(self, rng, means, scales, stats, progress, it) -> tuple[dict, list]:
        o = self.options
        n_sl = len(self.slices)
        nu = self.character.nu
        # saved set of the current slice start: states, total cost, slice cost, lineage ids
        states = self.state0[None].copy()
        last_offsets = np.zeros((1, nu))  # each saved state's offset on its last slice
        totals = np.zeros(1)
        lineage: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        # lineage[j] = (parent index into saved set j, offsets (Ns, nu), slice cost, fell)
        bar = None
        if progress is True:
            from tqdm import tqdm

            bar = tqdm(total=n_sl, desc=f"SAMCON pass {it + 1}/{o.iterations}", unit="slice",
                       leave=False)
        hist = []
        prev_fell = np.zeros(1, dtype=bool)
        for j in range(n_sl):
            w = min(o.window, n_sl - j)
            width_boost, attempts = 1.0, 0
            while True:
                attempts += 1
                out = self._step(rng, j, w, states, means, scales * width_boost, stats,
                                 last_offsets)
                if not out["fallen"].all() or attempts > o.retries:
                    break
                width_boost *= 2.0
            sel = select_diverse(out["window_cost"], out["parent"], o.saved, rng,
                                 elite_fraction=o.elite_fraction, pool_factor=o.pool_factor,
                                 max_children=o.max_children)
            par = out["parent"][sel]
            fell = out["fallen_first"][sel] | prev_fell[par]
            lineage.append((par, out["offsets"][sel, 0], out["slice_cost"][sel], fell))
            if o.adapt:
                n_el = max(1, int(round(o.adapt_elites * len(sel))))
                el = sel[:n_el]
                el = el[np.isfinite(out["window_cost"][el])]
                for s in range(w):
                    means[j + s], scales[j + s] = self._adapt(means[j + s], scales[j + s],
                                                              out["offsets"][el, s])
            states = out["first_states"][sel]
            last_offsets = out["offsets"][sel, 0]
            totals = totals[par] + out["slice_cost"][sel]
            prev_fell = fell
            good = np.isfinite(out["window_cost"]) & ~out["fallen"]
            hist.append({"slice": j, "best": float(out["slice_cost"][sel].min()),
                         "median": float(np.median(out["slice_cost"][sel])),
                         "fallen_fraction": float(1 - good.mean()), "attempts": attempts})
            if bar is not None:
                bar.update(1)
                bar.set_postfix(slice=f"{j + 1}/{n_sl}", best=f"{totals.min():.2f}")
            elif callable(progress):
                progress(it, j, n_sl, float(totals.min()))
        if bar is not None:
            bar.close()
        # trace the lowest total-cost path
        finals = np.flatnonzero(~prev_fell)
        pick = int(finals[np.argmin(totals[finals])] if len(finals) else np.argmin(totals))
        offsets = np.zeros((n_sl, nu))
        costs = np.zeros(n_sl)
        fell_any = False
        i = pick
        for j in range(n_sl - 1, -1, -1):
            par, off, sc, fl = lineage[j]
            offsets[j], costs[j] = off[i], sc[i]
            fell_any |= bool(fl[i])
            i = int(par[i])
        return ({"offsets": offsets, "costs": costs, "total": float(costs.sum()),
                 "fell": fell_any}, hist)

    def _ramp(self, j: int) -> np.ndarray:
        """``(c, 1)`` weights of slice ``j``'s own offset over its controls (1 when offsets are
        held constant; a linear ramp from the previous slice's offset with ``interpolate``)."""
        a, b = self.slices[j]
        if not self.options.interpolate:
            return np.ones((b - a, 1))
        return ((np.arange(b - a) + 1.0) / (b - a))[:, None]

    def _step(self, rng, j, w, states, means, scales, stats, last_offsets) -> dict:
        """Sample and simulate slices ``j .. j + w - 1`` from the saved ``states`` (whose
        last-slice offsets are ``last_offsets``)."""
        o = self.options
        n_s = len(states)
        n = o.samples
        per = np.full(n_s, n // n_s)
        per[: n - per.sum()] += 1  # the best saved states get the remainder
        parent = np.repeat(np.arange(n_s), per)
        nu = self.character.nu
        offsets = np.zeros((n, w, nu))
        controls = []
        ends = []
        prev = last_offsets[parent]
        for s in range(w):
            a, b = self.slices[j + s]
            offsets[:, s] = self._draw(rng, means[j + s], scales[j + s], n)
            r = self._ramp(j + s)
            off = r * offsets[:, s, None, :] + (1.0 - r) * prev[:, None, :]
            controls.append(self.base[None, a:b] + off)
            prev = offsets[:, s]
            ends.append(b - self.slices[j][0] - 1)
        controls = np.concatenate(controls, axis=1)
        req = RolloutRequest(self.rmodel, states[parent], controls, self.k)
        t0 = time.perf_counter()
        res = self.executor.evaluate(req)
        stats["rollout_s"] += time.perf_counter() - t0
        stats["samples"] += n * w
        stats["steps"] += n * controls.shape[1] * self.k
        cost = np.zeros((n, w))
        fallen_upto = np.zeros((n, w), dtype=bool)
        a0 = self.slices[j][0]
        for s, e in enumerate(ends):
            first = e if o.cost_at == "end" else (ends[s - 1] + 1 if s else 0)
            cost[:, s] = np.mean([self.cost(res.qpos[:, i], res.qvel[:, i], res.com[:, i],
                                            res.com_vel[:, i], res.sites[:, i], self.features,
                                            a0 + i) for i in range(first, e + 1)], axis=0)
            fallen_upto[:, s] = self.cost.fallen(res, e + 1)
        slice_cost = cost[:, 0] + FALL_COST * fallen_upto[:, 0]
        window_cost = cost.sum(axis=1) + FALL_COST * fallen_upto[:, -1]
        return {"parent": parent, "offsets": offsets, "slice_cost": slice_cost,
                "window_cost": window_cost, "fallen": fallen_upto[:, -1],
                "fallen_first": fallen_upto[:, 0], "first_states": res.states[:, ends[0]]}

    def _trajectory(self, offsets: np.ndarray, metadata: dict) -> Trajectory:
        o = self.options
        targets = self.base.copy()
        prev = np.zeros(self.character.nu)
        for j, (a, b) in enumerate(self.slices):
            r = self._ramp(j)
            targets[a:b] += r * offsets[j] + (1.0 - r) * prev
            prev = offsets[j]
        t = o.start + np.arange(self.n_controls + 1) * o.control_dt
        return Trajectory.for_model(
            self.character.model, targets, o.control_dt, self.q0, self.v0,
            warmstart_resets=[a for a, _ in self.slices], source_motion=self.source_motion,
            reference_qpos=self.reference.qpos(t), metadata=metadata)


def _options_dict(o: SamconOptions) -> dict:
    d = asdict(o)
    return d


register_replay("samcon_replay", "SAMCON trajectory replay", ("samcon",), bench=("track",))
