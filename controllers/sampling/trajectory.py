"""Saved open-loop PD-target trajectories (what SAMCON and CMA-ES produce) and their replay.

SAMCON (:mod:`mjchar.controllers.sampling.samcon`) and CMA-ES trajectory optimisation
(:mod:`mjchar.controllers.sampling.trajopt`) both end with a sequence of set-points for the
humanoid's native ``<position>`` actuators, one vector per control interval, that drives the
character from a given start state without any feedback and without any force on the root. This
module is that result as a file, and the controller that plays it back through the shared scenarios
and metrics.

File format (``numpy`` ``.npz`` archive, no pickles; read with :func:`load_trajectory`):

============================  ======================================================================
key                           content
============================  ======================================================================
``format``                    the string ``"mjchar-trajectory"`` (anything else is not one)
``version``                   integer, :data:`FORMAT_VERSION`
``targets``                   ``(T, nu)`` PD targets (rad), control ``i`` held over
                              ``[i control_dt, (i + 1) control_dt)``
``control_dt``, ``timestep``  seconds per control and per physics step
``initial_qpos``              ``(nq,)`` start pose; ``initial_qvel`` ``(nv,)`` start velocity
``warmstart_resets``          ``(R,)`` control indices at which the constraint solver's warm start
                              is cleared (where the optimiser started a new batch of rollouts)
``model_name``, ``model_hash``  the model's name and :func:`model_fingerprint`
``actuator_names``            ``(nu,)`` actuator names, in target column order
``source_motion``             path of the source BVH (``""`` for a task without a clip)
``reference_qpos``            ``(T + 1, nq)`` the reference at every control boundary (``(0, nq)``
                              without one): the replay measures tracking errors against it
``metadata``                  JSON text: method, options, costs, seeds, timings
============================  ======================================================================

Why ``warmstart_resets``: the batched rollouts (:mod:`mjchar.controllers.sampling.rollout`) start
every sample with ``qacc_warmstart = 0``, while a simulation that runs straight through carries the
warm start over; the two differ at the solver-tolerance level and contact-rich motion amplifies
that. The :class:`ReplayController` clears the warm start exactly where the optimiser's rollouts
started, so a replay reproduces the optimised path bit for bit (and is deterministic).
"""

from __future__ import annotations

import io
import json
import math
import os
import warnings
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from mjchar.bvh.bundled.assets import find_trajectory
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.io.files import write_bytes

from ..core.base import Action, ControllerError
from ..core.character import Character
from ..core.fingerprint import model_fingerprint
from ..core.limits import MAX_DURATION_S, control_dt_problem, timestep_problem
from ..core.metrics import Result
from ..core.registry import ControllerSpec, make_controller, register

__all__ = [
    "FORMAT", "FORMAT_VERSION", "TrajectoryError", "Trajectory", "StoredReference",
    "ReplayController", "load_trajectory", "model_fingerprint", "replay",
]

FORMAT = "mjchar-trajectory"
#: largest trajectory file, and the most its arrays may unpack to, in bytes
MAX_TRAJECTORY_BYTES = 256 * 2**20
FORMAT_VERSION = 1
_REQUIRED = ("format", "version", "targets", "control_dt", "timestep", "initial_qpos",
             "initial_qvel", "warmstart_resets", "model_name", "model_hash", "actuator_names",
             "source_motion", "reference_qpos", "metadata")


class TrajectoryError(MjcharError):
    """A file is not a saved trajectory, or a trajectory does not fit the model it is played on."""


def _model_name(model: mujoco.MjModel) -> str:
    """The ``<mujoco model="...">`` name (the first entry of MuJoCo's names buffer)."""
    raw = bytes(model.names)
    name = raw[: raw.find(b"\0")].decode(errors="replace") if raw else ""
    return name or "model"


def _actuator_names(model: mujoco.MjModel) -> list[str]:
    return [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator{a}"
            for a in range(model.nu)]


@dataclass
class Trajectory:
    """An open-loop PD-target trajectory for one model.

    Attributes:
        targets: ``(T, nu)`` actuator set-points (rad), control ``i`` held for ``control_dt`` s.
        control_dt: seconds per control (a whole number of physics steps).
        timestep: physics time step (s) the trajectory was optimised at.
        initial_qpos: ``(nq,)`` start pose; initial_qvel: ``(nv,)`` start velocity.
        warmstart_resets: ``(R,)`` int control indices where the solver warm start is cleared.
        model_name: the model's name; model_hash: :func:`model_fingerprint` of it.
        actuator_names: ``(nu,)`` names, in target column order.
        source_motion: path of the source BVH (``""`` when the trajectory solves a task).
        reference_qpos: ``(T + 1, nq)`` reference pose at each control boundary, or ``None``.
        metadata: JSON-serialisable dict (method, options, costs, timings).
    """

    targets: np.ndarray
    control_dt: float
    timestep: float
    initial_qpos: np.ndarray
    initial_qvel: np.ndarray
    warmstart_resets: np.ndarray
    model_name: str
    model_hash: str
    actuator_names: tuple[str, ...]
    source_motion: str = ""
    reference_qpos: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    @classmethod
    def for_model(cls, model: mujoco.MjModel, targets: np.ndarray, control_dt: float,
                  initial_qpos: np.ndarray, initial_qvel: np.ndarray, *,
                  warmstart_resets=(0,), source_motion: str = "",
                  reference_qpos: np.ndarray | None = None,
                  metadata: dict | None = None, model_name: str | None = None) -> Trajectory:
        """Build a trajectory for ``model`` (its time step, name, fingerprint, actuator names)."""
        traj = cls(np.array(targets, dtype=float), float(control_dt), float(model.opt.timestep),
                   np.array(initial_qpos, dtype=float), np.array(initial_qvel, dtype=float),
                   np.unique(np.asarray(warmstart_resets, dtype=np.int64)),
                   model_name or _model_name(model), model_fingerprint(model),
                   tuple(_actuator_names(model)), str(source_motion),
                   None if reference_qpos is None else np.array(reference_qpos, dtype=float),
                   dict(metadata or {}))
        traj.validate(model)
        return traj

    # -- properties -------------------------------------------------------------------------
    @property
    def n_controls(self) -> int:
        """Number of controls T."""
        return int(self.targets.shape[0])

    @property
    def duration(self) -> float:
        """Seconds covered by the targets, ``T * control_dt``."""
        return self.n_controls * self.control_dt

    @property
    def steps_per_control(self) -> int:
        """Physics steps per control."""
        return int(round(self.control_dt / self.timestep))

    # -- checks -------------------------------------------------------------------------------
    def _check_shapes(self, where: str) -> None:
        t = self.targets
        if t.ndim != 2 or t.shape[0] < 1:
            raise TrajectoryError(f"{where}: targets must be (T, nu) with T >= 1, got {t.shape}")
        if not np.isfinite(t).all():
            raise TrajectoryError(f"{where}: targets contain NaN or Inf")
        problem = timestep_problem(self.timestep)
        if problem:
            raise TrajectoryError(f"{where}: its timestep {problem}")
        problem = control_dt_problem(self.control_dt, self.timestep)
        if problem:
            raise TrajectoryError(f"{where}: its control_dt {problem}")
        if self.duration > MAX_DURATION_S:
            raise TrajectoryError(f"{where}: {t.shape[0]} controls of {self.control_dt:g} s "
                                  f"last {self.duration:g} s, longer than a run may "
                                  f"({MAX_DURATION_S:g} s)")
        for name in ("initial_qpos", "initial_qvel", "reference_qpos"):
            a = getattr(self, name)
            if a is not None and not np.isfinite(a).all():
                raise TrajectoryError(f"{where}: {name} contains NaN or Inf")
        k = self.control_dt / self.timestep
        if abs(k - round(k)) > 1e-6 or round(k) < 1:
            raise TrajectoryError(f"{where}: control_dt {self.control_dt} s is not a whole number "
                                  f"of {self.timestep} s physics steps")
        if len(self.actuator_names) != t.shape[1]:
            raise TrajectoryError(f"{where}: {len(self.actuator_names)} actuator names for "
                                  f"{t.shape[1]} target columns")
        if self.reference_qpos is not None and (self.reference_qpos.ndim != 2 or
                                                self.reference_qpos.shape[0] != t.shape[0] + 1):
            raise TrajectoryError(f"{where}: reference_qpos must be (T + 1, nq) = "
                                  f"({t.shape[0] + 1}, nq), got {self.reference_qpos.shape}")
        w = self.warmstart_resets
        if w.ndim != 1 or (len(w) and (w.min() < 0 or w.max() >= t.shape[0])):
            raise TrajectoryError(f"{where}: warmstart_resets must be control indices in "
                                  f"[0, {t.shape[0]})")

    def validate(self, model: mujoco.MjModel, where: str = "trajectory") -> None:
        """Raise :class:`TrajectoryError` unless the trajectory fits ``model`` (sizes, actuator
        names and physics fingerprint; the time step is set by the replay, not compared)."""
        self._check_shapes(where)
        if self.targets.shape[1] != model.nu:
            raise TrajectoryError(f"{where}: {self.targets.shape[1]} targets per control but the "
                                  f"model has {model.nu} actuators")
        if self.initial_qpos.shape != (model.nq,) or self.initial_qvel.shape != (model.nv,):
            raise TrajectoryError(f"{where}: initial state is for nq={self.initial_qpos.size}, "
                                  f"nv={self.initial_qvel.size}; the model has nq={model.nq}, "
                                  f"nv={model.nv}")
        if self.reference_qpos is not None and self.reference_qpos.shape[1] != model.nq:
            raise TrajectoryError(f"{where}: reference_qpos has {self.reference_qpos.shape[1]} "
                                  f"columns, the model nq={model.nq}")
        names = _actuator_names(model)
        if list(self.actuator_names) != names:
            raise TrajectoryError(f"{where}: actuators differ from the model's (first saved: "
                                  f"{self.actuator_names[:3]}, model: {names[:3]})")
        fingerprint = model_fingerprint(model)
        if fingerprint == self.model_hash:
            return
        if model_fingerprint(model, version=1) == self.model_hash:
            warnings.warn(f"{where}: saved by an earlier mjchar, whose model fingerprint did not "
                          f"cover contact dimensions or solver options; it matches this model's "
                          f"other physics. Save it again to refresh the fingerprint.",
                          stacklevel=3)
            return
        raise TrajectoryError(f"{where}: it was optimised for another model "
                              f"({self.model_name!r}, fingerprint {self.model_hash[:12]}; "
                              f"this model: {fingerprint[:12]})")

    # -- I/O -----------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the ``.npz`` archive to exactly ``path`` (no suffix is added); returns it."""
        self._check_shapes(str(path))
        path = Path(path)
        if path.parent and not path.parent.exists():
            raise TrajectoryError(f"{path}: the folder {path.parent} does not exist")
        ref = (np.zeros((0, self.initial_qpos.size)) if self.reference_qpos is None
               else self.reference_qpos)
        arrays = {
            "format": np.array(FORMAT), "version": np.array(FORMAT_VERSION),
            "targets": self.targets, "control_dt": np.array(self.control_dt),
            "timestep": np.array(self.timestep), "initial_qpos": self.initial_qpos,
            "initial_qvel": self.initial_qvel,
            "warmstart_resets": np.asarray(self.warmstart_resets, dtype=np.int64),
            "model_name": np.array(self.model_name), "model_hash": np.array(self.model_hash),
            "actuator_names": np.array(list(self.actuator_names)),
            "source_motion": np.array(self.source_motion), "reference_qpos": ref,
            "metadata": np.array(json.dumps(_jsonable(self.metadata))),
        }
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        try:
            write_bytes(path, buf.getvalue())  # atomically: a failed write leaves what was there
        except OSError as e:
            raise TrajectoryError(f"{path}: cannot write the trajectory: {e}") from None
        return path


def _jsonable(v):
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple | np.ndarray):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.integer | np.bool_):
        return v.item()
    if isinstance(v, float | np.floating):
        v = float(v)
        return v if math.isfinite(v) else None
    return v


def _check_array_sizes(z, p: Path) -> None:
    """Refuse an archive whose arrays would unpack to more than :data:`MAX_TRAJECTORY_BYTES`
    (a small compressed file can hold a huge array of zeros), from their headers alone."""
    total = 0
    for name in z.zip.namelist():
        with z.zip.open(name) as f:
            version = np.lib.format.read_magic(f)
            read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                    else np.lib.format.read_array_header_2_0)
            shape, _, dtype = read(f)
        total += math.prod(shape) * dtype.itemsize
        if total > MAX_TRAJECTORY_BYTES:
            raise TrajectoryError(f"{p}: its arrays unpack to more than "
                                  f"{MAX_TRAJECTORY_BYTES // 2**20} MB, far more than a "
                                  f"trajectory holds: is it the right file?")


def load_trajectory(path: str | os.PathLike) -> Trajectory:
    """Read a trajectory written by :meth:`Trajectory.save`.

    Raises:
        TrajectoryError: the file does not exist, is not an ``.npz`` archive, is an archive
            without the ``mjchar-trajectory`` marker (another kind of file), has a newer format
            version, or is missing/has malformed fields.
    """
    p = Path(path)
    if not p.is_file():
        raise TrajectoryError(f"{p}: no such trajectory file")
    if p.stat().st_size > MAX_TRAJECTORY_BYTES:
        raise TrajectoryError(f"{p}: {p.stat().st_size / 2**20:.0f} MB, more than the "
                              f"{MAX_TRAJECTORY_BYTES // 2**20} MB a trajectory file may be: is "
                              f"it the right file?")
    try:
        with np.load(p, allow_pickle=False) as z:
            _check_array_sizes(z, p)
            data = {k: z[k] for k in z.files}
    except TrajectoryError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError, RuntimeError,
            NotImplementedError, zlib.error) as e:
        raise TrajectoryError(f"{p}: not a saved mjchar trajectory (not an .npz archive, or "
                              f"a damaged one: {e.__class__.__name__})") from None
    if not isinstance(data, dict) or str(data.get("format", "")) != FORMAT:
        raise TrajectoryError(f"{p}: not a saved mjchar trajectory (no {FORMAT!r} marker; "
                              "write one with `mjchar samcon` or `mjchar trajopt`)")
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise TrajectoryError(f"{p}: damaged trajectory, missing {', '.join(missing)}")
    try:
        version = int(data["version"])
        control_dt, timestep = float(data["control_dt"]), float(data["timestep"])
        arrays = {k: np.asarray(data[k], dtype=float) for k in
                  ("targets", "initial_qpos", "initial_qvel", "reference_qpos")}
        resets = np.asarray(data["warmstart_resets"], dtype=np.int64).reshape(-1)
    except (TypeError, ValueError) as e:
        raise TrajectoryError(f"{p}: damaged trajectory, a field is not numbers of the right "
                              f"shape ({e})") from None
    if version > FORMAT_VERSION:
        raise TrajectoryError(f"{p}: trajectory format version {version} is newer than this "
                              f"mjchar reads ({FORMAT_VERSION})")
    try:
        meta = json.loads(str(data["metadata"]))
    except ValueError:
        raise TrajectoryError(f"{p}: damaged trajectory, metadata is not JSON") from None
    ref = arrays["reference_qpos"]
    traj = Trajectory(
        targets=arrays["targets"], control_dt=control_dt, timestep=timestep,
        initial_qpos=arrays["initial_qpos"], initial_qvel=arrays["initial_qvel"],
        warmstart_resets=resets,
        model_name=str(data["model_name"]), model_hash=str(data["model_hash"]),
        actuator_names=tuple(str(s) for s in np.asarray(data["actuator_names"]).reshape(-1)),
        source_motion=str(data["source_motion"]),
        reference_qpos=ref if ref.size else None, metadata=meta)
    traj._check_shapes(str(p))
    return traj


class StoredReference:
    """The reference a trajectory was optimised against, from its ``reference_qpos`` rows.

    Quacks like the parts of ``mjchar.bvh.reference.reference_motion.ReferenceMotion`` the metrics
    use: ``qpos(t)``, ``body_positions(t)``, ``joint_body_ids`` and ``duration``. Poses between
    control boundaries are interpolated with ``mj_differentiatePos``/``mj_integratePos``; times
    outside ``[0, duration]`` hold the end poses.

    Args:
        model: the model (for kinematics).
        qpos: ``(N, nq)`` poses at times ``0, dt, ..., (N - 1) dt``.
        dt: seconds between rows.
        joint_body_ids: ``(K,)`` body ids the metrics compare (the Character's joint bodies).
    """

    def __init__(self, model: mujoco.MjModel, qpos: np.ndarray, dt: float,
                 joint_body_ids: np.ndarray):
        self.model = model
        self.frame_qpos = np.asarray(qpos, dtype=float)
        self.frame_time = float(dt)
        self.joint_body_ids = np.asarray(joint_body_ids, dtype=int)
        self._data = mujoco.MjData(model)
        n = len(self.frame_qpos)
        self._vel = np.zeros((max(n - 1, 1), model.nv))
        for i in range(n - 1):
            mujoco.mj_differentiatePos(model, self._vel[i], 1.0, self.frame_qpos[i],
                                       self.frame_qpos[i + 1])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last row."""
        return (len(self.frame_qpos) - 1) * self.frame_time

    def qpos(self, t) -> np.ndarray:
        """``(*t.shape, nq)`` reference pose at time(s) ``t`` (s)."""
        t = np.asarray(t, dtype=float)
        flat = t.reshape(-1)
        n = len(self.frame_qpos)
        out = np.empty((flat.size, self.model.nq))
        for j, tt in enumerate(flat):
            s = min(max(tt / self.frame_time, 0.0), n - 1.0)
            i = min(int(math.floor(s)), max(n - 2, 0))
            a = s - i
            out[j] = self.frame_qpos[i]
            if n > 1 and a > 0:
                mujoco.mj_integratePos(self.model, out[j], self._vel[i], a)
        return out.reshape(t.shape + (self.model.nq,))

    def body_positions(self, t) -> np.ndarray:
        """``(*t.shape, nbody, 3)`` world body positions (m) of :meth:`qpos`."""
        q = self.qpos(t)
        flat = q.reshape(-1, self.model.nq)
        out = np.empty((len(flat), self.model.nbody, 3))
        for j, row in enumerate(flat):
            self._data.qpos[:] = row
            mujoco.mj_kinematics(self.model, self._data)
            out[j] = self._data.xpos
        return out.reshape(q.shape[:-1] + (self.model.nbody, 3))


class ReplayController:
    """Plays a :class:`Trajectory` open-loop on native PD actuators (no feedback, no root force).

    At simulated time ``t`` it sends ``targets[i]`` with ``i = round(t / control_dt)`` (the last
    row after the end), and clears the solver warm start at the trajectory's
    ``warmstart_resets``, as the optimiser's rollouts did. It brings what a run of it needs: its
    physics step (:attr:`timestep`, applied by ``make_controller``), and :meth:`replay_setup`,
    which the ``track`` scenario plays from: the trajectory's start state, control step and
    stored reference.

    Args:
        trajectory: a :class:`Trajectory` or a path to one.
    """

    name = "replay"
    actuation = "native"

    def __init__(self, trajectory: Trajectory | str | os.PathLike):
        self.trajectory = (trajectory if isinstance(trajectory, Trajectory)
                           else load_trajectory(trajectory))
        self._resets = set(int(i) for i in self.trajectory.warmstart_resets)
        self._bound = False

    @property
    def timestep(self) -> float:
        """The physics step (s) the trajectory was optimised at (a replay needs it exactly)."""
        return self.trajectory.timestep

    def reset(self, character: Character) -> None:
        """Check that the trajectory fits ``character`` (model, time step) and switch it to
        native PD with the model's own gains."""
        tr = self.trajectory
        if not np.all(character.actuation.position_actuators):
            raise ControllerError("replay needs <position> actuators on every actuated dof")
        if abs(character.timestep - tr.timestep) > 1e-12:
            raise TrajectoryError(f"the trajectory was optimised at a {tr.timestep} s time step, "
                                  f"the character runs at {character.timestep} s")
        character.actuation.set_mode("native")
        kp, kd = character.actuation.default_gains()
        character.actuation.set_native_gains(kp, kd)
        tr.validate(character.model)
        self._bound = True

    def act(self, character: Character, t: float) -> Action:
        if not self._bound:
            raise ControllerError("replay: act() called before reset()")
        tr = self.trajectory
        i = int(round(t / tr.control_dt))
        if i in self._resets:
            character.state.clear_warm_start()  # as every rollout batch started
        return Action(target=tr.targets[min(max(i, 0), tr.n_controls - 1)])


    def replay_setup(self, character: Character, *, duration: float | None = None,
                     reference=None, hold_last: bool = False):
        """What the ``track`` scenario plays from (a
        :class:`~mjchar.controllers.core.scenarios.replay.ReplaySetup`): the trajectory's start
        state and control step, ``duration`` (default: the trajectory's, its most unless
        ``hold_last`` holds the last target past the end) and the reference (default: the
        stored rows)."""
        from ..core.scenarios.locomotion import clip_duration
        from ..core.scenarios.replay import ReplaySetup

        tr = self.trajectory
        tr.validate(character.model)
        if reference is None and tr.reference_qpos is not None:
            reference = StoredReference(character.model, tr.reference_qpos, tr.control_dt,
                                        character.joint_bodies)
        if hold_last and duration is not None:
            duration = float(duration)  # past the end: the last target held (simulate checks)
        else:
            duration = clip_duration(tr, duration, "trajectory")
        info = {"trajectory_duration_s": tr.duration, "method": tr.metadata.get("method")}
        if tr.source_motion:
            info["source_motion"] = tr.source_motion
        return ReplaySetup(tr.initial_qpos, tr.initial_qvel, tr.control_dt, duration,
                           reference, info)

    def play(self, character: Character, **options) -> Result:
        """Play the trajectory open-loop on ``character`` from its initial state and report the
        usual metrics (the ``track`` scenario of a replay:
        :func:`~mjchar.controllers.core.scenarios.replay.play`, whose keywords ``options``
        are)."""
        from ..core.scenarios.replay import play

        return play(character, self, **options)


def replay(trajectory: Trajectory | str | os.PathLike, *, model=None,
           duration: float | None = None, stop_on_fall: bool = True,
           frame_callback=None, reference=None, push=None, hold_last: bool = False) -> Result:
    """Play a saved trajectory open-loop from its initial state and report the usual metrics.

    Args:
        trajectory: a :class:`Trajectory` or the path of a saved one.
        model: the model to play it on (default: the bundled humanoid); must match the
            trajectory's fingerprint.
        duration: seconds to simulate (default: the trajectory's, which is also the most:
            a trajectory ends with its last control, a longer run is refused unless
            ``hold_last``).
        hold_last: hold the last target past the end (e.g. a jump that must land and stand).
        progress: a :class:`~mjchar.progress.Progress` shown the simulated time
            (``play`` only; ``None``: quiet).
        stop_on_fall: end the run at a fall (as the scenarios do).
        frame_callback: called after every control step (video capture).
        reference: a ReferenceMotion to measure tracking against (default: the stored
            reference rows; none for a task trajectory).
        push: one push during the replay (a
            :class:`~mjchar.controllers.core.scenarios.shared.PushEvent`).

    Returns:
        a :class:`~mjchar.controllers.core.metrics.Result` (scenario ``"replay"``) whose ``extra``
        holds ``final_root_error_m`` (3-D distance between the simulated and reference root at
        the end, m), ``min_root_height_m``, ``max_clearance_m`` (largest height of the
        character's lowest point above the floor, m: flight) and ``final_root_height_m``.
    """
    character = Character(model)
    controller = make_controller("replay", character, trajectory=trajectory)
    return controller.play(character, duration=duration, stop_on_fall=stop_on_fall,
                           frame_callback=frame_callback, reference=reference, push=push,
                           hold_last=hold_last)


def make_replay(character: Character | None = None, target=None, *,
                trajectory: Trajectory | str | os.PathLike | None = None,
                prefixes: tuple[str, ...] = (), name: str = "replay") -> ReplayController:
    """A :class:`ReplayController` of ``trajectory`` (a :class:`Trajectory` or a saved file);
    without one, the first bundled trajectory whose file name starts with one of ``prefixes``
    (a one-line error names the registered replay ``name`` when there is none)."""
    if trajectory is None:
        if not prefixes:
            raise TrajectoryError(f"{name} needs the trajectory file: mjchar run {name} FILE")
        trajectory = find_trajectory(prefixes)
        if trajectory is None:
            raise TrajectoryError(f"{name}: no bundled trajectory {prefixes[0]}*.npz; give one: "
                                  f"mjchar run {name} FILE")
    return ReplayController(trajectory)


def register_replay(name: str, label: str, prefixes: tuple[str, ...] = (),
                    bench: tuple[str, ...] = ()) -> ControllerSpec:
    """Register a replay controller ``name``: it plays the trajectory it is given
    (``mjchar run NAME FILE``), or without one the first bundled trajectory whose file name
    starts with one of ``prefixes``."""
    def factory(character=None, target=None, trajectory=None):
        return make_replay(character, target, trajectory=trajectory, prefixes=prefixes,
                           name=name)

    return register(ControllerSpec(
        name=name, label=label, kind="replay", factory=factory, abilities=("replay",),
        default_scenario="track", options=("trajectory",), bench=bench,
        trajectory_prefixes=prefixes))


register_replay("replay", "saved trajectory replay")
