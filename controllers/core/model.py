"""Loading the model a :class:`~controllers.core.character.Character` drives, and reading the
converter's metadata (joint map and roles) from it."""

from __future__ import annotations

import copy
import os

import mujoco

from .errors import CharacterError


def model_info(model: mujoco.MjModel):
    """The converter's ``ModelInfo`` for ``model`` (joint map and roles), read from the
    ``mjchar`` metadata with ``bvh.mjcf.ModelInfo.from_model``."""
    from bvh.mjcf import ModelInfo

    return ModelInfo.from_model(model)


def load_model(model) -> mujoco.MjModel:
    """An ``MjModel`` the caller owns: ``None`` -> the bundled humanoid, a path -> loaded from
    the MJCF file, an ``MjModel`` -> a deep copy. Raises :class:`CharacterError` naming the file
    when it is missing or MuJoCo cannot load it."""
    if model is None:
        from bvh.assets import humanoid_path

        model = humanoid_path()
    if isinstance(model, mujoco.MjModel):
        return copy.deepcopy(model)
    if isinstance(model, (str, os.PathLike)):
        path = os.fspath(model)
        if not os.path.isfile(path):
            raise CharacterError(f"{path}: no such MJCF file")
        try:
            return mujoco.MjModel.from_xml_path(path)
        except ValueError as e:
            raise CharacterError(f"{path}: MuJoCo cannot load it: {e}") from None
    raise CharacterError(f"model must be None, an MJCF path or an MjModel, got "
                         f"{type(model).__name__}")
