"""A model's physics fingerprint: what ties a saved trajectory or a walker's calibration to the
body it was made for (:func:`model_fingerprint`)."""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

# the physics a trajectory or a calibration depends on (sensors, names and the time step
# excluded: the rollout model adds sensors, and the time step is stored and set separately)
_FINGERPRINT_FIELDS = (
    "body_parentid", "body_mass", "body_inertia", "body_pos", "body_quat", "body_ipos",
    "body_iquat", "jnt_type", "jnt_range", "jnt_limited", "jnt_pos", "jnt_axis",
    "dof_armature", "dof_damping", "dof_frictionloss", "geom_type", "geom_size", "geom_pos",
    "geom_quat", "geom_friction", "geom_contype", "geom_conaffinity", "geom_solref",
    "geom_solimp", "geom_bodyid", "actuator_trnid", "actuator_gear", "actuator_gainprm",
    "actuator_biasprm", "actuator_forcerange", "actuator_forcelimited", "actuator_ctrlrange",
    "actuator_ctrllimited",
)
#: what the first fingerprint left out (version 2): contact dimensions and mixing,
#: joint springs and limit softness, actuator types, and the solver's options below
_FINGERPRINT_FIELDS_V2 = (
    "geom_condim", "geom_priority", "geom_solmix", "geom_margin", "geom_gap", "jnt_stiffness",
    "jnt_solref", "jnt_solimp", "jnt_margin", "dof_solref", "dof_solimp", "qpos_spring",
    "actuator_dyntype", "actuator_gaintype", "actuator_biastype", "actuator_dynprm",
)
_FINGERPRINT_OPTIONS_V2 = ("impratio", "tolerance", "ls_tolerance", "noslip_tolerance",
                           "density", "viscosity", "wind", "solver", "iterations",
                           "ls_iterations", "noslip_iterations", "jacobian", "enableflags")
FINGERPRINT_VERSION = 2


def model_fingerprint(model: mujoco.MjModel, version: int = FINGERPRINT_VERSION) -> str:
    """A SHA-256 hex digest of the model's physics (bodies, joints, geoms and their contact
    settings, actuators, gravity, integrator, constraint solver options), independent of
    sensors and of the time step. Two models with the same fingerprint simulate a PD-target
    sequence identically at the same time step. ``version=1`` is the digest of mjchar before
    version 1, which left out the contact dimensions, the friction cone's ``impratio`` and
    the solver options (kept to read trajectories saved then)."""
    if version not in (1, 2):
        raise ValueError(f"model_fingerprint: unknown version {version!r}")
    h = hashlib.sha256()
    h.update(np.array([model.nq, model.nv, model.nu, model.nbody, model.ngeom,
                       int(model.opt.integrator), int(model.opt.cone),
                       int(model.opt.disableflags)], dtype=np.int64).tobytes())
    h.update(np.asarray(model.opt.gravity, dtype=np.float64).tobytes())
    fields = _FINGERPRINT_FIELDS if version == 1 else _FINGERPRINT_FIELDS + _FINGERPRINT_FIELDS_V2
    for name in fields:
        h.update(name.encode())
        h.update(np.ascontiguousarray(getattr(model, name)).tobytes())
    if version == 2:
        for name in _FINGERPRINT_OPTIONS_V2:
            h.update(name.encode())
            h.update(np.asarray(getattr(model.opt, name), dtype=np.float64).tobytes())
    return h.hexdigest()
