"""Batched open-loop rollouts of PD-target sequences, in C, on all cores.

Sampling-based controllers (SAMCON, Liu et al. 2010/2015; CMA-ES trajectory optimisation) spend
nearly all their time simulating many candidate PD-target sequences from saved states and scoring
the outcomes. This module does that simulation with MuJoCo's native ``<position>`` actuators and
``mujoco.rollout``, which steps every sample in C with the GIL released on a thread pool.

The pieces::

    rmodel = RolloutModel.from_source(mjchar.bvh.bundled.assets.humanoid_path())  # model + cost
    sensors request = RolloutRequest(rmodel, states0, targets, steps_per_control=50)
    result = rollout(request, threads=2)        # or an Executor
    (mjchar.controllers.sampling.executors) result.final_states, result.com, result.sites,
    result.non_foot_contact, result.ok

Semantics (what a plain Python loop does, bit for bit; :func:`reference_rollout` is that loop):

- sample ``b`` starts from the full-physics state ``initial_states[b]`` (``mj_getState`` with
  ``mjSTATE_FULLPHYSICS``) with ``qacc_warmstart = 0``, equality constraints at the model's
  ``eq_active0``, mocap bodies at their model poses, ``qfrc_applied = 0``;
- control ``i`` (one PD target per actuator, radians for hinge position actuators) is written
  to ``data.ctrl`` and held for ``k = steps_per_control`` physics steps (``mj_step``), with the
  optional external wrench ``xfrc_applied[b, i]`` (N, N m, world frame, per body) alongside;
- the result records the state at the end of every control interval, i.e. after physics steps
  ``k, 2k, ..., T k``, and the cost quantities at those states (centre of mass and its velocity,
  site positions) from sensors the prepared model adds; contacts between watched bodies and the
  floor are sensed at every physics step.

Sensors in MuJoCo are evaluated inside ``mj_step`` *before* integration, so a step's sensor values
describe the state the step started from. The engine therefore takes one extra physics step after
the last control (its state is discarded): its sensors describe the final state, and if it did
not run, MuJoCo stopped the sample on a warning during the last real step. That extra step costs
``1 / (T k)`` of the work (2 % for one 0.1 s slice at 2 ms).

It works on MuJoCo directly, not through a Character: ``mujoco.rollout`` needs a plain
``MjModel`` (here a copy of the model with the cost sensors added) and runs its own ``MjData``
per thread; states move between the two as full-physics vectors (``character.state.get_physics``,
:func:`get_state`, :func:`set_state`).

Divergence: ``mujoco.rollout`` stops a sample on its first MuJoCo warning (NaN/Inf/huge values,
full contact buffers, ...) and repeats the last state. Such a sample gets ``ok = False`` and
``failed_step`` = the physics step during which the warning was raised; its states and cost
quantities from that control interval on are NaN. No exception is raised for it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np

from mjchar.bvh.errors import MjcharError

__all__ = [
    "FULLPHYSICS", "RolloutError", "RolloutModel", "RolloutRequest", "RolloutResult",
    "RolloutRunner", "rollout", "reference_rollout", "get_state", "set_state", "state_slices",
    "to_fullphysics",
]

FULLPHYSICS = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
"""The ``mjtState`` spec of every state this module reads and writes."""

_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)
_XFRC = int(mujoco.mjtState.mjSTATE_XFRC_APPLIED)
_PREFIX = "mjchar_rollout/"  # names of the sensors the prepared model adds
_FOOT_ROLES = ("left_ankle", "right_ankle", "left_toe", "right_toe")


class RolloutError(MjcharError):
    """A rollout was asked for with inputs it cannot run (shapes, sizes, non-finite values)."""


# ------------------------------------------------------------------------------------------------
# full-physics state helpers


def state_slices(model: mujoco.MjModel) -> dict[str, slice]:
    """Where each component sits in a full-physics state vector of ``model``.

    Returns:
        ``{"time", "qpos", "qvel", "act", ...}`` -> slice into a ``(nstate,)`` state, in the order
        ``mj_getState`` writes them (ascending ``mjtState`` bits); empty components are included.
    """
    out, start = {}, 0
    for bit in sorted(int(b) for b in mujoco.mjtState.__members__.values()):
        if bit & (bit - 1) or not bit & FULLPHYSICS:  # composite spec, or not in FULLPHYSICS
            continue
        size = mujoco.mj_stateSize(model, bit)
        name = mujoco.mjtState(bit).name.removeprefix("mjSTATE_").lower()
        out[name] = slice(start, start + size)
        start += size
    return out


def get_state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Full-physics state of ``data``: ``(nstate,)`` float64 (time, qpos, qvel, act, ...)."""
    state = np.empty(mujoco.mj_stateSize(model, FULLPHYSICS))
    mujoco.mj_getState(model, data, state, FULLPHYSICS)
    return state


def to_fullphysics(model: mujoco.MjModel, states: np.ndarray,
                   spec: int = int(mujoco.mjtState.mjSTATE_INTEGRATION)) -> np.ndarray:
    """Convert states of another ``mjtState`` spec (default ``mjSTATE_INTEGRATION``, what
    ``Character.get_state`` returns) to full-physics states.

    Args:
        states: ``(n,)`` or ``(B, n)`` with ``n = mj_stateSize(model, spec)``; the spec must
            contain ``mjSTATE_FULLPHYSICS``.

    Returns:
        ``(nstate,)`` or ``(B, nstate)`` full-physics states (the other components, e.g. the
        solver warm start, are dropped: a rollout starts with a zero warm start).
    """
    if spec & FULLPHYSICS != FULLPHYSICS:
        raise RolloutError(f"state spec {spec} does not contain mjSTATE_FULLPHYSICS")
    states = np.asarray(states, dtype=np.float64)
    size = mujoco.mj_stateSize(model, spec)
    if states.shape[-1:] != (size,) or states.ndim not in (1, 2):
        raise RolloutError(f"states have shape {states.shape}, expected (B, {size}) for spec "
                           f"{spec}")
    data = mujoco.MjData(model)
    flat = states.reshape(-1, size)
    out = np.empty((flat.shape[0], mujoco.mj_stateSize(model, FULLPHYSICS)))
    for i, row in enumerate(flat):
        mujoco.mj_setState(model, data, row, spec)
        mujoco.mj_getState(model, data, out[i], FULLPHYSICS)
    return out.reshape(states.shape[:-1] + out.shape[-1:])


def set_state(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray) -> None:
    """Load a ``(nstate,)`` full-physics state into ``data`` exactly as a rollout starts a sample.

    Also zeroes ``qacc_warmstart``, ``qfrc_applied`` and ``xfrc_applied``, resets ``eq_active`` to
    the model's ``eq_active0`` and mocap bodies to their model poses, so that stepping ``data``
    afterwards reproduces a rollout bit for bit.
    """
    state = np.ascontiguousarray(state, dtype=np.float64)
    if state.shape != (mujoco.mj_stateSize(model, FULLPHYSICS),):
        raise RolloutError(f"state has shape {state.shape}, expected "
                           f"({mujoco.mj_stateSize(model, FULLPHYSICS)},) (mjSTATE_FULLPHYSICS)")
    data.qfrc_applied[:] = 0.0
    data.xfrc_applied[:] = 0.0
    data.eq_active[:] = model.eq_active0
    mocap = model.body_mocapid >= 0
    if mocap.any():
        data.mocap_pos[model.body_mocapid[mocap]] = model.body_pos[mocap]
        data.mocap_quat[model.body_mocapid[mocap]] = model.body_quat[mocap]
    mujoco.mj_setState(model, data, state, FULLPHYSICS)
    data.qacc_warmstart[:] = 0.0


# ------------------------------------------------------------------------------------------------
# the prepared model


def _obj_name(model: mujoco.MjModel, obj: mujoco.mjtObj, i: int) -> str:
    return mujoco.mj_id2name(model, obj, i) or ""


def _check_names(model: mujoco.MjModel, obj: mujoco.mjtObj, names: Sequence[str],
                 what: str) -> tuple[str, ...]:
    """``names`` as a tuple; a :class:`RolloutError` naming those ``model`` lacks."""
    names = tuple(names)
    missing = [n for n in names if mujoco.mj_name2id(model, obj, n) < 0]
    if missing:
        raise RolloutError(f"unknown {what} {missing} in the model")
    return names


def _root_name(model: mujoco.MjModel) -> str:
    """The character's root body: the first free body on the world, else its first child."""
    roots = [i for i in range(1, model.nbody) if model.body_parentid[i] == 0]
    if not roots:
        raise RolloutError("the model has no body besides the world")
    free = [i for i in roots if model.body_jntnum[i] and
            model.jnt_type[model.body_jntadr[i]] == mujoco.mjtJoint.mjJNT_FREE]
    root = _obj_name(model, mujoco.mjtObj.mjOBJ_BODY, (free or roots)[0])
    if not root:
        raise RolloutError("the root body has no name; name it to record the centre of mass")
    return root


def _contact_bodies(spec: mujoco.MjSpec, model: mujoco.MjModel, floor: str | None,
                    contact_bodies: Sequence[str] | None,
                    foot_bodies: Sequence[str] | None) -> tuple[tuple[str, ...], set[str]]:
    """``(contact bodies, feet)`` checked against ``model`` (see
    :meth:`RolloutModel.from_source`); none without a ``floor``."""
    body = mujoco.mjtObj.mjOBJ_BODY
    if floor is None:
        return (), set()
    if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, floor) < 0:
        raise RolloutError(f"no floor geom named {floor!r} in the model (pass floor=None "
                           "to record no contacts)")
    if contact_bodies is None:
        contact_bodies = [_obj_name(model, body, i) for i in range(1, model.nbody)
                          if model.body_geomnum[i] and _obj_name(model, body, i)]
    contact_bodies = _check_names(model, body, contact_bodies, "contact bodies")
    if foot_bodies is None:
        foot_bodies = _default_feet(spec, model)
    return contact_bodies, set(_check_names(model, body, foot_bodies, "foot bodies"))


def _with_sensors(spec: mujoco.MjSpec, root: str, sites: Sequence[str],
                  contact_bodies: Sequence[str], floor: str | None) -> mujoco.MjModel:
    """``spec`` compiled with the cost sensors added (it is modified): the root's subtree COM
    and its velocity, each site's position, each contact body's floor contact."""
    body = mujoco.mjtObj.mjOBJ_BODY
    specs = [("com", mujoco.mjtSensor.mjSENS_SUBTREECOM, body, root, None),
             ("com_vel", mujoco.mjtSensor.mjSENS_SUBTREELINVEL, body, root, None)]
    specs += [(f"site/{s}", mujoco.mjtSensor.mjSENS_FRAMEPOS, mujoco.mjtObj.mjOBJ_SITE, s,
               None) for s in sites]
    specs += [(f"contact/{b}", mujoco.mjtSensor.mjSENS_CONTACT, body, b, floor)
              for b in contact_bodies]
    for name, stype, objtype, objname, ref in specs:
        sensor = spec.add_sensor(name=_PREFIX + name, type=stype, objtype=objtype,
                                 objname=objname)
        if ref is not None:  # contact sensor: body1=objname, geom2=floor, data="found"
            sensor.reftype, sensor.refname = mujoco.mjtObj.mjOBJ_GEOM, ref
            sensor.intprm = [1, 0, 1]
    try:
        return spec.compile()
    except ValueError as e:
        raise RolloutError(f"cannot compile the model with rollout sensors: {e}") from e


@dataclass(frozen=True, eq=False)
class RolloutModel:
    """A model compiled for rollouts, with sensors for the quantities sampling costs need.

    Build it with :meth:`from_source`. Its physics is that of the source model (sensors do not
    change dynamics), so states from a model compiled from the same source, e.g. a ``Character``'s,
    are valid initial states. Picklable (the compiled model travels as MJB bytes), which is how
    the Ray executor ships it.

    Attributes:
        model: the compiled ``MjModel`` with the added sensors.
        site_names: sites whose world positions are recorded, ``(S,)``.
        contact_bodies: bodies whose contacts with the floor are recorded, ``(C,)``.
        foot_mask: ``(C,)`` bool, True for the feet among ``contact_bodies`` (ankles and toes).
        root_body: the body whose subtree centre of mass is ``com``.
    """

    model: mujoco.MjModel
    site_names: tuple[str, ...]
    contact_bodies: tuple[str, ...]
    foot_mask: np.ndarray
    root_body: str
    _sensor: dict[str, slice] = field(repr=False)

    @classmethod
    def from_source(cls, source: str | os.PathLike | mujoco.MjSpec, *,
                    sites: Sequence[str] | None = None,
                    contact_bodies: Sequence[str] | None = None,
                    foot_bodies: Sequence[str] | None = None,
                    floor: str | None = "floor") -> RolloutModel:
        """Compile ``source`` with cost sensors added.

        Args:
            source: an MJCF file path, an MJCF XML string (starting with ``<``) or an ``MjSpec``
                (copied, not modified).
            sites: names of the sites to record (default: every named site).
            contact_bodies: bodies whose floor contacts to record (default: every body with a
                geom, the world excepted).
            foot_bodies: which of them are feet (default: the bodies of the ``left/right_ankle``
                and ``left/right_toe`` roles in the model's ``mjchar`` metadata; without
                metadata, the bodies that own a box geom, the converter's foot shape).
            floor: name of the floor geom; ``None`` records no contacts.

        Raises:
            RolloutError: the source does not parse/compile, or a named site, body or floor geom
                does not exist.
        """
        spec = _load_spec(source)
        try:
            plain = spec.compile()
        except ValueError as e:
            raise RolloutError(f"cannot compile the model: {e}") from e
        if sites is None:
            sites = [n for n in (_obj_name(plain, mujoco.mjtObj.mjOBJ_SITE, i)
                                 for i in range(plain.nsite)) if n]
        sites = _check_names(plain, mujoco.mjtObj.mjOBJ_SITE, sites, "sites")
        root = _root_name(plain)
        contact_bodies, feet = _contact_bodies(spec, plain, floor, contact_bodies, foot_bodies)
        model = _with_sensors(spec, root, sites, contact_bodies, floor)

        def _slice(name: str) -> slice:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, _PREFIX + name)
            return slice(int(model.sensor_adr[i]), int(model.sensor_adr[i] + model.sensor_dim[i]))

        sensor = {"com": _slice("com"), "com_vel": _slice("com_vel")}
        sensor["sites"] = _block([_slice(f"site/{s}") for s in sites], sensor["com"].stop)
        sensor["contacts"] = _block([_slice(f"contact/{b}") for b in contact_bodies],
                                    sensor["sites"].stop)
        mask = np.array([b in feet for b in contact_bodies], dtype=bool)
        mask.setflags(write=False)
        return cls(model, sites, contact_bodies, mask, root, sensor)

    @property
    def nstate(self) -> int:
        """Size of a full-physics state vector."""
        return mujoco.mj_stateSize(self.model, FULLPHYSICS)

    @property
    def nu(self) -> int:
        """Number of actuators (PD targets per control)."""
        return self.model.nu

    @property
    def dt(self) -> float:
        """Physics time step, s."""
        return float(self.model.opt.timestep)

    def initial_state(self, qpos: np.ndarray | None = None,
                      qvel: np.ndarray | None = None) -> np.ndarray:
        """A ``(nstate,)`` full-physics state at time 0 from ``qpos`` (nq,) / ``qvel`` (nv,)
        (defaults: the model's ``qpos0`` and zero velocity)."""
        data = mujoco.MjData(self.model)
        if qpos is not None:
            data.qpos[:] = qpos
        if qvel is not None:
            data.qvel[:] = qvel
        return get_state(self.model, data)


def _block(slices: list[slice], start: int) -> slice:
    """One slice covering consecutive sensor slices (the sensors were added in order)."""
    if not slices:
        return slice(start, start)
    for a, b in zip(slices, slices[1:], strict=False):
        if a.stop != b.start:
            raise RolloutError("internal: rollout sensors are not contiguous")
    return slice(slices[0].start, slices[-1].stop)


def _load_spec(source) -> mujoco.MjSpec:
    try:
        if isinstance(source, mujoco.MjSpec):
            return source.copy()
        if isinstance(source, str) and source.lstrip().startswith("<"):
            return mujoco.MjSpec.from_string(source)
        path = Path(source)
        if not path.is_file():
            raise RolloutError(f"{path}: no such model file")
        return mujoco.MjSpec.from_file(str(path))
    except ValueError as e:
        raise RolloutError(f"cannot parse the model: {e}") from e
    except TypeError as e:
        raise RolloutError(f"model source must be a path, an XML string or an MjSpec, "
                           f"not {type(source).__name__}") from e


def _default_feet(spec: mujoco.MjSpec, plain: mujoco.MjModel) -> list[str]:
    """Foot bodies: from the mjchar metadata roles, else bodies that own a box geom."""
    for text in spec.texts:
        if text.name != "mjchar":
            continue
        try:
            meta = json.loads(text.data)
            roles, joints = dict(meta.get("roles", {})), dict(meta.get("joints", {}))
        except (ValueError, TypeError, AttributeError):
            break  # unreadable metadata: fall back to the geometry
        names = []
        for role in _FOOT_ROLES:
            joint = roles.get(role)
            if isinstance(joint, str):
                body = joints.get(joint, {}).get("body", joint)
                if mujoco.mj_name2id(plain, mujoco.mjtObj.mjOBJ_BODY, body) >= 0:
                    names.append(body)
        if names:
            return names
    boxes = {int(plain.geom_bodyid[g]) for g in range(plain.ngeom)
             if plain.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and plain.geom_bodyid[g] > 0}
    return [mujoco.mj_id2name(plain, mujoco.mjtObj.mjOBJ_BODY, b) for b in sorted(boxes)
            if mujoco.mj_id2name(plain, mujoco.mjtObj.mjOBJ_BODY, b)]


# ------------------------------------------------------------------------------------------------
# request and result


@dataclass(frozen=True, eq=False)
class RolloutRequest:
    """A batch of B open-loop PD-target sequences to simulate.

    Attributes:
        model: the prepared model.
        initial_states: ``(B, nstate)`` full-physics states (or ``(nstate,)`` / ``(1, nstate)``,
            shared by every sample).
        controls: ``(B, T, nu)`` PD targets (actuator ``ctrl``; rad for hinge position
            actuators), control ``i`` held for ``steps_per_control`` physics steps. A leading
            dimension of 1 is shared by every sample.
        steps_per_control: physics steps per control, ``k >= 1`` (0.1 s at 2 ms is 50).
        xfrc_applied: optional ``(B, T, nbody, 6)`` external wrench per body (force N then
            torque N m, world frame, applied at the body's centre of mass), held like the
            controls; B and T may be 1 to broadcast.

    Arrays are converted to C-contiguous float64 and validated on construction.
    """

    model: RolloutModel
    initial_states: np.ndarray
    controls: np.ndarray
    steps_per_control: int
    xfrc_applied: np.ndarray | None = None

    def __post_init__(self):
        rm = self.model
        if not isinstance(rm, RolloutModel):
            raise RolloutError(f"model must be a RolloutModel (RolloutModel.from_source), "
                               f"not {type(rm).__name__}")
        k = self.steps_per_control
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise RolloutError(f"steps_per_control must be a positive integer, got {k!r}")
        states = np.asarray(self.initial_states, dtype=np.float64)
        if states.ndim == 1:
            states = states[None]
        controls = np.asarray(self.controls, dtype=np.float64)
        if controls.ndim == 2:
            controls = controls[None]
        if states.ndim != 2 or states.shape[1] != rm.nstate:
            raise RolloutError(f"initial_states has shape {np.shape(self.initial_states)}, "
                               f"expected (B, {rm.nstate}) full-physics states")
        if controls.ndim != 3 or controls.shape[2] != rm.nu or controls.shape[1] < 1:
            raise RolloutError(f"controls has shape {np.shape(self.controls)}, expected "
                               f"(B, T, {rm.nu}) PD targets with T >= 1")
        batch = max(states.shape[0], controls.shape[0])
        for name, arr in (("initial_states", states), ("controls", controls)):
            if arr.shape[0] not in (1, batch):
                raise RolloutError(f"{name} has {arr.shape[0]} samples, others have {batch}")
        xfrc = self.xfrc_applied
        if xfrc is not None:
            xfrc = np.asarray(xfrc, dtype=np.float64)
            nbody = rm.model.nbody
            if (xfrc.ndim != 4 or xfrc.shape[2:] != (nbody, 6)
                    or xfrc.shape[0] not in (1, batch)
                    or xfrc.shape[1] not in (1, controls.shape[1])):
                raise RolloutError(f"xfrc_applied has shape {xfrc.shape}, expected "
                                   f"(B or 1, T or 1, {nbody}, 6)")
            if not np.isfinite(xfrc).all():
                raise RolloutError("xfrc_applied contains NaN or Inf")
            xfrc = np.broadcast_to(xfrc, (batch, controls.shape[1], nbody, 6))
        if not np.isfinite(states).all():
            raise RolloutError("initial_states contains NaN or Inf")
        if not np.isfinite(controls).all():
            raise RolloutError("controls contains NaN or Inf")
        object.__setattr__(self, "initial_states", np.broadcast_to(states, (batch, rm.nstate)))
        object.__setattr__(self, "controls",
                           np.broadcast_to(controls, (batch,) + controls.shape[1:]))
        object.__setattr__(self, "xfrc_applied", xfrc)
        object.__setattr__(self, "steps_per_control", int(k))

    @property
    def batch_size(self) -> int:
        """Number of samples B."""
        return self.initial_states.shape[0]

    @property
    def horizon(self) -> int:
        """Number of controls T per sample."""
        return self.controls.shape[1]

    @property
    def physics_steps(self) -> int:
        """Physics steps per sample, ``T * steps_per_control``."""
        return self.horizon * self.steps_per_control

    def take(self, index: slice) -> RolloutRequest:
        """The sub-request of samples ``index`` (a slice), sharing the model."""
        xfrc = None if self.xfrc_applied is None else self.xfrc_applied[index]
        return RolloutRequest(self.model, self.initial_states[index], self.controls[index],
                              self.steps_per_control, xfrc)

    def split(self, parts: int) -> list[RolloutRequest]:
        """At most ``parts`` contiguous sub-requests of near-equal size, in order."""
        bounds = np.linspace(0, self.batch_size, max(1, min(parts, self.batch_size)) + 1)
        bounds = bounds.round().astype(int)
        return [self.take(slice(a, b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


@dataclass(frozen=True, eq=False)
class RolloutResult:
    """What B rollouts of T controls produced, sampled at the end of every control interval.

    Attributes:
        states: ``(B, T, nstate)`` full-physics state after control ``i`` (``mj_getState``).
        com: ``(B, T, 3)`` centre of mass of the root body's subtree, m, world frame.
        com_vel: ``(B, T, 3)`` its linear velocity, m/s.
        sites: ``(B, T, S, 3)`` world positions of ``model.site_names``, m.
        contacts: ``(B, T, C)`` bool, ``model.contact_bodies[c]`` touched the floor at some
            physics step of interval ``i`` (states after steps ``i k + 1 .. (i + 1) k``).
        ok: ``(B,)`` bool, False when MuJoCo stopped the sample on a warning (divergence).
        failed_step: ``(B,)`` int, the physics step (0-based, from the sample's start) during
            which that warning was raised, -1 for samples that ran through. From the control
            interval that contains it on, the sample's states, com, com_vel and sites are NaN.
        qpos_slice, qvel_slice: where qpos and qvel sit in a state.
        foot_mask: ``(C,)`` bool, which contact bodies are feet.
        steps_per_control: physics steps per control.
    """

    states: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    sites: np.ndarray
    contacts: np.ndarray
    ok: np.ndarray
    failed_step: np.ndarray
    qpos_slice: slice
    qvel_slice: slice
    foot_mask: np.ndarray
    steps_per_control: int

    @property
    def final_states(self) -> np.ndarray:
        """``(B, nstate)`` state at the end of the last control."""
        return self.states[:, -1]

    @property
    def qpos(self) -> np.ndarray:
        """``(B, T, nq)`` generalised positions (root position m, root quaternion wxyz, hinge
        angles rad)."""
        return self.states[..., self.qpos_slice]

    @property
    def qvel(self) -> np.ndarray:
        """``(B, T, nv)`` generalised velocities (m/s, rad/s)."""
        return self.states[..., self.qvel_slice]

    @property
    def non_foot_contact(self) -> np.ndarray:
        """``(B, T)`` bool: a body other than a foot touched the floor during interval ``i``."""
        return self.contacts[..., ~self.foot_mask].any(axis=-1)

    @property
    def fallen(self) -> np.ndarray:
        """``(B,)`` bool: a non-foot body touched the floor at some point of the rollout."""
        return self.non_foot_contact.any(axis=-1)

    @staticmethod
    def concatenate(results: Sequence[RolloutResult]) -> RolloutResult:
        """Join results of consecutive sample ranges (as :meth:`RolloutRequest.split` made)."""
        if not results:
            raise RolloutError("no results to concatenate")
        first = results[0]
        arrays = {name: np.concatenate([getattr(r, name) for r in results])
                  for name in ("states", "com", "com_vel", "sites", "contacts", "ok",
                               "failed_step")}
        return RolloutResult(**arrays, qpos_slice=first.qpos_slice, qvel_slice=first.qvel_slice,
                             foot_mask=first.foot_mask,
                             steps_per_control=first.steps_per_control)

    def take(self, index) -> RolloutResult:
        """The samples ``index`` (an index array or a slice) of this result."""
        arrays = {name: getattr(self, name)[index]
                  for name in ("states", "com", "com_vel", "sites", "contacts", "ok",
                               "failed_step")}
        return RolloutResult(**arrays, qpos_slice=self.qpos_slice, qvel_slice=self.qvel_slice,
                             foot_mask=self.foot_mask, steps_per_control=self.steps_per_control)

    def then(self, later: RolloutResult) -> RolloutResult:
        """The same B samples over ``T + T'`` controls: ``later`` continued each sample from
        its final state (``RolloutRequest(model, self.final_states, more_controls, k')``, on
        this model or on one with the same physics at another time step). With the same model,
        bit-identical to one rollout of the joined controls when the model's solver warm start
        is disabled (``mjDSBL_WARMSTART``): a full-physics state then holds everything the next
        step reads; otherwise the continuation restarts the solver from a zero warm start (a
        difference at the solver's tolerance). A sample that failed in ``self`` must not be
        continued (its final state is NaN). The joined result keeps this result's
        ``steps_per_control``; a failure in ``later`` is placed at the start of the control it
        happened in when ``k'`` differs."""
        if later.states.shape[0] != self.states.shape[0]:
            raise RolloutError(f"cannot continue {self.states.shape[0]} samples with "
                               f"{later.states.shape[0]}")
        k, k2 = self.steps_per_control, later.steps_per_control
        arrays = {name: np.concatenate([getattr(self, name), getattr(later, name)], axis=1)
                  for name in ("states", "com", "com_vel", "sites", "contacts")}
        offset = self.states.shape[1] * k
        moved = later.failed_step if k2 == k else (later.failed_step // k2) * k
        failed = np.where(self.failed_step >= 0, self.failed_step,
                          np.where(later.failed_step >= 0, moved + offset, -1))
        return RolloutResult(**arrays, ok=self.ok & later.ok, failed_step=failed,
                             qpos_slice=self.qpos_slice, qvel_slice=self.qvel_slice,
                             foot_mask=self.foot_mask, steps_per_control=k)


# ------------------------------------------------------------------------------------------------
# the engine


def pool_size(threads: int | None, chunk: int,
              error: type[MjcharError] = RolloutError) -> tuple[int, int]:
    """``(threads, chunk)`` of a rollout pool, checked (:class:`RolloutRunner` and the local
    executor's): ``threads`` ``None`` is ``os.cpu_count()``; either one not a positive integer
    raises ``error``."""
    if threads is None:
        threads = os.cpu_count() or 1
    for label, value in (("threads", threads), ("chunk", chunk)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise error(f"{label} must be a positive integer, got {value!r}")
    return threads, chunk


class RolloutRunner:
    """Runs requests for one :class:`RolloutModel` on a persistent ``mujoco.rollout`` pool.

    Holds one ``MjData`` per thread and reusable output buffers, and processes a request in chunks
    of at most ``chunk`` samples to bound memory (the per-step state buffer of a chunk is
    ``chunk * (T k + 1) * nstate * 8`` bytes). Results do not depend on ``threads`` or ``chunk``:
    every sample is simulated independently from its own initial state.

    Not safe to use from several Python threads at once; use one runner per thread.

    Args:
        model: the prepared model.
        threads: worker threads (``None``: ``os.cpu_count()``); 1 runs on the calling thread
            (still in C with the GIL released).
        chunk: samples per ``mujoco.rollout`` call.
    """

    def __init__(self, model: RolloutModel, threads: int | None = None, chunk: int = 256):
        threads, chunk = pool_size(threads, chunk, RolloutError)
        self.model, self.threads, self.chunk = model, threads, chunk
        self._datas = [mujoco.MjData(model.model) for _ in range(threads)]
        self._pool = mujoco.rollout.Rollout(nthread=threads if threads > 1 else 0)
        self._slices = state_slices(model.model)
        self._buffers: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def close(self) -> None:
        """Stop the thread pool (idempotent)."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None
        self._buffers.clear()

    def __enter__(self) -> RolloutRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def run(self, request: RolloutRequest) -> RolloutResult:
        """Simulate every sample of ``request`` (see the module docstring for the semantics)."""
        if self._pool is None:
            raise RolloutError("this RolloutRunner is closed")
        if request.model is not self.model:
            raise RolloutError("the request is for another RolloutModel than this runner's")
        if request.batch_size <= self.chunk:
            return self._run_chunk(request)
        parts = [request.take(slice(a, a + self.chunk))
                 for a in range(0, request.batch_size, self.chunk)]
        return RolloutResult.concatenate([self._run_chunk(p) for p in parts])

    def _buffers_for(self, batch: int, nstep: int, ncontrol: int):
        """``(control, state, sensordata)`` arrays for a chunk of this shape, kept for the next
        chunk of the same shape: a planner asks for the same batch every planning step, and
        fresh arrays of this size cost the page faults of a new allocation every time (the
        results are copied out of them, :meth:`_collect`)."""
        key = (batch, nstep, ncontrol)
        buf = self._buffers.get(key)
        if buf is None:
            m = self.model.model
            if len(self._buffers) >= 4:  # a few shapes at most (a planner's near and tail)
                self._buffers.clear()
            buf = (np.empty((batch, nstep, ncontrol)), np.empty((batch, nstep, self.model.nstate)),
                   np.empty((batch, nstep, m.nsensordata)))
            self._buffers[key] = buf
        return buf

    def _run_chunk(self, req: RolloutRequest) -> RolloutResult:
        m = req.model.model
        batch, horizon, k = req.batch_size, req.horizon, req.steps_per_control
        nstep = horizon * k + 1  # one extra step: its sensors describe the final state
        nu = m.nu
        spec = _CTRL | (_XFRC if req.xfrc_applied is not None else 0)
        ncontrol = mujoco.mj_stateSize(m, spec)
        control, state, sensordata = self._buffers_for(batch, nstep, ncontrol)
        # control i held for k steps: a view of the first T k steps as (B, T, k, ncontrol)
        held = control[:, :-1].reshape(batch, horizon, k, ncontrol)
        if not np.may_share_memory(held, control):
            raise RolloutError("internal: the held controls are not a view of the buffer")
        held[..., :nu] = req.controls[:, :, None, :]
        control[:, -1, :nu] = req.controls[:, -1]
        if req.xfrc_applied is not None:
            xfrc = req.xfrc_applied.reshape(batch, horizon, -1)
            held[..., nu:] = xfrc[:, :, None, :]
            control[:, -1, nu:] = xfrc[:, -1]
        state0 = np.ascontiguousarray(req.initial_states)
        self._pool.rollout([m] * batch, self._datas, state0, control, control_spec=spec,
                           skip_checks=True, nstep=nstep, state=state, sensordata=sensordata)
        return self._collect(req, state0, state, sensordata)

    def _collect(self, req, state0, state, sensordata) -> RolloutResult:
        rm, k, horizon = req.model, req.steps_per_control, req.horizon
        batch, nphys = req.batch_size, horizon * k
        at_end = k * np.arange(1, horizon + 1)  # sensordata index of the state after step i k
        # a sample stopped by a warning repeats its last state: time stops advancing
        time = np.concatenate([state0[:, None, 0], state[:, :, 0]], axis=1)  # (B, nstep + 1)
        stalled = ~(np.diff(time, axis=1) > 0)  # [b, j]: step j did not advance time
        states = state[:, at_end - 1]  # (B, T, nstate), a copy
        bad_end = ~np.isfinite(states).all(axis=2)  # (B, T), belt and braces
        failed = np.full(batch, -1)
        rows = np.nonzero(stalled.any(axis=1))[0]
        j = stalled[rows].argmax(axis=1)
        # halted: step j repeated the state of step j - 1, so the warning came during step j - 1;
        # otherwise MuJoCo reset the data (its auto-reset on bad values) during step j itself
        halted = time[rows, j + 1] == time[rows, j]
        failed[rows] = np.maximum(np.where(halted, j - 1, j), 0)
        rows = bad_end.any(axis=1) & (failed < 0)
        failed[rows] = bad_end[rows].argmax(axis=1) * k
        failed = np.minimum(failed, nphys - 1)
        s = rm._sensor
        sens = sensordata[:, at_end]
        com = sens[..., s["com"]].copy()
        com_vel = sens[..., s["com_vel"]].copy()
        sites = sens[..., s["sites"]].reshape(batch, horizon, len(rm.site_names), 3)
        contacts = sensordata[:, 1:nphys + 1, s["contacts"]]
        contacts = contacts.reshape(batch, horizon, k, len(rm.contact_bodies))
        contacts = (contacts > 0).any(axis=2)
        for b in np.nonzero(failed >= 0)[0]:
            i = failed[b] // k
            for arr in (states, com, com_vel, sites):
                arr[b, i:] = np.nan
        return RolloutResult(states=states, com=com, com_vel=com_vel, sites=sites,
                             contacts=contacts, ok=failed < 0, failed_step=failed,
                             qpos_slice=self._slices["qpos"], qvel_slice=self._slices["qvel"],
                             foot_mask=rm.foot_mask, steps_per_control=k)


def rollout(request: RolloutRequest, *, threads: int | None = None,
            chunk: int = 256) -> RolloutResult:
    """Simulate ``request`` on a temporary :class:`RolloutRunner` (``threads=None``: all cores).

    For repeated calls keep a runner (or an executor from
    :mod:`mjchar.controllers.sampling.executors`): it reuses its thread pool and buffers.
    """
    with RolloutRunner(request.model, threads=threads, chunk=chunk) as runner:
        return runner.run(request)


def reference_rollout(model: mujoco.MjModel, initial_states: np.ndarray, controls: np.ndarray,
                      steps_per_control: int,
                      xfrc_applied: np.ndarray | None = None) -> np.ndarray:
    """The plain Python ``mj_step`` loop that a rollout reproduces bit for bit (slow; for tests
    and for replaying a chosen sample).

    Args:
        model: any model with the same physics as the rollout model (sensors may differ).
        initial_states: ``(B, nstate)`` full-physics states.
        controls: ``(B, T, nu)`` PD targets, each held ``steps_per_control`` steps.
        xfrc_applied: optional ``(B, T, nbody, 6)`` wrenches, held like the controls.

    Returns:
        ``(B, T, nstate)`` state after each control interval.
    """
    initial_states = np.atleast_2d(np.asarray(initial_states, dtype=np.float64))
    controls = np.asarray(controls, dtype=np.float64)
    batch, horizon = controls.shape[:2]
    data = mujoco.MjData(model)
    out = np.empty((batch, horizon, initial_states.shape[1]))
    for b in range(batch):
        set_state(model, data, initial_states[b])
        for i in range(horizon):
            data.ctrl[:] = controls[b, i]
            if xfrc_applied is not None:
                data.xfrc_applied[:] = xfrc_applied[b, i]
            for _ in range(steps_per_control):
                mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, out[b, i], FULLPHYSICS)
    return out
