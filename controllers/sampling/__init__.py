"""Sampling control: batched rollouts on ``mujoco.rollout`` and their executors (local threads,
Ray), saved PD-target trajectories and their open-loop replay, SAMCON and CMA-ES trajectory
optimisation, and the closed-loop sampling MPC tracker. Registered as ``replay``,
``samcon_replay``, ``cmaes_replay`` and ``mpc``.

The simulated character is read and driven through its parts like everywhere else (its state to
start rollouts from: ``character.state.get_physics``). What is computed for a *model* rather than
for the simulated character takes the Character's ``MjModel`` itself and calls MuJoCo on data of
its own: the batched rollouts (:mod:`.rollout`: ``mujoco.rollout`` on a model copy with sensors,
one ``MjData`` per thread), inverse dynamics on the reference and its features
(:mod:`.tracking`), trajectories and their stored references, tied to a model by its fingerprint
(:mod:`.trajectory`)."""

# Registration order: replay, samcon_replay, cmaes_replay, mpc:
# isort: off
from .trajectory import ReplayController, Trajectory, load_trajectory, make_replay, replay
from .samcon import Samcon, SamconOptions, SamconResult
from .trajopt import TrajectoryOptimizer, TrajoptOptions, optimise_jump, track_clip
from .mpc import MpcController, MpcOptions, make_mpc
# isort: on
from .executors import Executor, LocalExecutor, make_executor
from .rollout import RolloutModel, RolloutRequest, RolloutResult, RolloutRunner, rollout
from .tracking import CostWeights, TrackingCost, inverse_dynamics_targets, sampling_widths

__all__ = ["CostWeights", "Executor", "LocalExecutor", "MpcController", "MpcOptions",
           "ReplayController", "RolloutModel", "RolloutRequest", "RolloutResult",
           "RolloutRunner", "Samcon", "SamconOptions", "SamconResult", "TrackingCost",
           "TrajectoryOptimizer", "Trajectory", "TrajoptOptions", "inverse_dynamics_targets",
           "load_trajectory", "make_executor", "make_mpc", "make_replay", "optimise_jump",
           "replay", "rollout", "sampling_widths", "track_clip"]
