"""Loading the model a :class:`~mjchar.controllers.core.character.Character` drives, reading the
converter's metadata (joint map and roles) from it, mapping its actuators to dofs, and checking
the vectors given to the Character and its parts."""

from __future__ import annotations

import copy
import os
import warnings

import mujoco
import numpy as np

from ..errors import CharacterError

#: MuJoCo releases with the sparse Cholesky bug of the Newton solver (upstream #3767: a wrong
#: Hessian factor when the constraint Jacobian is sparse, which every model with 60 or more dofs
#: uses), fixed in 4.0.1; mjchar requires ``mujoco-core>=4.0.1``
BROKEN_MUJOCO = ("4.0.0",)


def check_mujoco_version(version: str = mujoco.__version__) -> bool:
    """Warn (once per call site) when the installed MuJoCo is one of :data:`BROKEN_MUJOCO`;
    ``True`` when it is fine."""
    if version in BROKEN_MUJOCO:
        warnings.warn(f"MuJoCo {version} has a sparse-solver bug that makes large models (60+ "
                      "dofs) simulate wrongly; install mjchar's requirement: "
                      'pip install "mujoco-core>=4.0.1"', RuntimeWarning, stacklevel=3)
        return False
    return True


def model_info(model: mujoco.MjModel):
    """The converter's ``ModelInfo`` for ``model`` (joint map and roles), read from the
    ``mjchar`` metadata with ``mjchar.bvh.mjcf.ModelInfo.from_model``."""
    from mjchar.bvh.mjcf import ModelInfo

    return ModelInfo.from_model(model)


def load_model(model) -> mujoco.MjModel:
    """An ``MjModel`` the caller owns: ``None`` -> the bundled humanoid, a path -> loaded from
    the MJCF file, an ``MjModel`` -> a deep copy. Raises :class:`CharacterError` naming the file
    when it is missing, MuJoCo cannot load it or its physical fields are not physical
    (:func:`mjchar.bvh.mjcf.model_file.load_mjcf`)."""
    check_mujoco_version()
    if model is None:
        from mjchar.bvh.bundled.assets import humanoid_path

        model = humanoid_path()
    if isinstance(model, mujoco.MjModel):
        return copy.deepcopy(model)
    if isinstance(model, (str, os.PathLike)):
        from mjchar.bvh.mjcf.model_file import load_mjcf

        path = os.fspath(model)
        if not os.path.isfile(path):
            raise CharacterError(f"{path}: no such MJCF file")
        return load_mjcf(path, CharacterError)
    raise CharacterError(f"model must be None, an MJCF path or an MjModel, got "
                         f"{type(model).__name__}")


def model_source(model) -> str | None:
    """The MJCF path :func:`load_model` loads ``model`` from (``None`` -> the bundled humanoid's),
    or ``None`` for an ``MjModel`` (no file behind it)."""
    if model is None:
        from mjchar.bvh.bundled.assets import humanoid_path

        return os.fspath(humanoid_path())
    if isinstance(model, (str, os.PathLike)):
        return os.fspath(model)
    return None


_JNT_BALL = int(mujoco.mjtJoint.mjJNT_BALL)
_JNT_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)
_JNT_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)


def actuator_map(m: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """``(dof (nu,), qpos (nu,))``: the dof each actuator drives and, for hinge and slide
    joints, its qpos address (-1 for ball-joint motors). Every actuator must drive one dof of a
    hinge, slide or ball joint with a unit gear, and no two the same dof (the model contract);
    else :class:`CharacterError`."""
    nu = int(m.nu)
    dof = np.full(nu, -1)
    qpos = np.full(nu, -1)
    for a in range(nu):
        if m.actuator_trntype[a] != int(mujoco.mjtTrn.mjTRN_JOINT):
            raise CharacterError(f"actuator {a} does not drive a joint")
        j = int(m.actuator_trnid[a, 0])
        t = m.jnt_type[j]
        gear = m.actuator_gear[a, :3]
        if t in (_JNT_HINGE, _JNT_SLIDE):
            dof[a] = m.jnt_dofadr[j]
            qpos[a] = m.jnt_qposadr[j]
            ok = gear[0] == 1.0
        elif t == _JNT_BALL:  # a motor along one body axis of a ball joint
            k = int(np.argmax(np.abs(gear)))
            dof[a] = m.jnt_dofadr[j] + k
            ok = gear[k] == 1.0 and np.count_nonzero(gear) == 1
        else:
            raise CharacterError(f"actuator {a} drives the free joint")
        if not ok:
            raise CharacterError(f"actuator {a}: gear {gear.tolist()} is not a unit gear on "
                                 f"one dof (see docs/model-contract.md)")
    if len(set(dof.tolist())) != nu:
        raise CharacterError("two actuators drive the same dof")
    return dof, qpos


def as_vector(x, n: int, what: str) -> np.ndarray:
    """``x`` as a float array of shape ``(n,)`` (no copy when it already is one); else
    :class:`CharacterError` naming ``what``."""
    x = np.asarray(x, dtype=float)
    if x.shape != (n,):
        raise CharacterError(f"{what} must have shape ({n},), got {x.shape}")
    return x
