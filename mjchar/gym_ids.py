"""The ``mjchar/...`` Gymnasium ids, registered without ``import mjchar`` importing Gymnasium.

``import mjchar`` (and so ``import mjchar.bvh``, the kinematic layer) must stay light, and
``gymnasium.make("mjchar/Imitation-v0")`` must work after it whichever of the two was imported
first. Gymnasium 1.x discovers no plugins, so :func:`register_with_gymnasium` registers the ids
(by importing :mod:`mjchar.envs`) at once when Gymnasium is already imported, and otherwise
right after Gymnasium's own import finishes, by a one-shot import hook (:class:`_AfterGymnasium`
on ``sys.meta_path``, which removes itself on first use).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys

GYMNASIUM = "gymnasium"
ENVS = "mjchar.envs"


def register_with_gymnasium() -> None:
    """Register the ``mjchar/...`` ids now if Gymnasium is imported, else when it is."""
    if GYMNASIUM in sys.modules:
        importlib.import_module(ENVS)
    elif not any(isinstance(f, _AfterGymnasium) for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterGymnasium())


class _AfterGymnasium(importlib.abc.MetaPathFinder):
    """Finds Gymnasium as the other finders would, with a loader that imports
    :mod:`mjchar.envs` once Gymnasium's module has run."""

    def find_spec(self, name, path=None, target=None):
        if name != GYMNASIUM:
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _RegisterAfter(spec.loader)
        return spec


class _RegisterAfter(importlib.abc.Loader):
    """A module loader that runs ``loader``'s module, then registers the ids."""

    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module) -> None:
        self.loader.exec_module(module)
        importlib.import_module(ENVS)

    def __getattr__(self, name):  # resource readers and the rest: the wrapped loader's
        return getattr(self.loader, name)
