"""The bundled assets: the default humanoid model, its motions and saved trajectories.

``assets/mjcf/humanoid.xml`` is the converter's output for the project-authored skeleton
(:mod:`mjchar.bvh.bundled.humanoid_skeleton`) at the default options; ``assets/motions/<name>.bvh``
are motions authored for that skeleton. Regenerate everything with::

    python -m mjchar.bvh.bundled.assets

A test checks that the checked-in model equals a fresh conversion byte for byte.
"""

from __future__ import annotations

import importlib.resources
import os
import sys
from pathlib import Path

from mjchar.bvh.errors import MjcharError


class AssetError(MjcharError):
    """A bundled asset is missing (regenerate with ``python -m mjchar.bvh.bundled.assets``)."""


def _assets_folder() -> Path:
    """The folder of the ``mjchar.assets`` data package, found with ``importlib.resources`` (the
    checkout's ``assets/`` in an editable install, ``site-packages/mjchar/assets`` from the
    wheel)."""
    folder = importlib.resources.files("mjchar.assets")
    if not isinstance(folder, Path):
        raise AssetError(f"mjchar's assets are inside an archive ({folder}); install mjchar "
                         "unpacked (pip install does)")
    return folder


#: the paths below are found on first use (PEP 562), so ``import bvh`` never fails on assets:
#: ``ASSETS`` the data folder, ``HUMANOID_XML`` the default humanoid, ``MOTIONS`` the bundled
#: motions, ``TRAJECTORIES`` the saved SAMCON / CMA-ES trajectories (``mjchar run samcon_replay``)
_PATHS = {"ASSETS": (), "HUMANOID_XML": ("mjcf", "humanoid.xml"), "MOTIONS": ("motions",),
          "TRAJECTORIES": ("trajectories",)}


def __getattr__(name: str) -> Path:
    if name in _PATHS:
        return _assets_folder().joinpath(*_PATHS[name])
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

#: options the bundled humanoid is converted with
HUMANOID_OPTIONS = {"total_mass": 70.0, "joint_model": "hinge", "model_name": "humanoid"}


def humanoid_path() -> Path:
    """Path of the bundled humanoid model ``assets/mjcf/humanoid.xml``."""
    path = __getattr__("HUMANOID_XML")
    if not path.is_file():
        raise AssetError(f"{path} is missing; regenerate it with "
                         "`python -m mjchar.bvh.bundled.assets`")
    return path


#: the bundled clips, by name (``mjchar run --motion walk``, ``ImitationEnv(motion="idle")``)
BUNDLED_MOTION_NAMES = ("walk", "idle")


def bundled_motions() -> tuple[str, ...]:
    """The names of the bundled clips present (``assets/motions/*.bvh``)."""
    motions = __getattr__("MOTIONS")
    return tuple(sorted(p.stem for p in motions.glob("*.bvh"))) if motions.is_dir() else ()


def find_trajectory(prefixes: tuple[str, ...], directory: str | os.PathLike | None = None
                    ) -> Path | None:
    """The first saved trajectory (``*.npz``, sorted by name) in ``directory`` (default: the
    bundled ``assets/trajectories``) whose file name starts with one of ``prefixes`` (case
    insensitive), or ``None``."""
    d = Path(__getattr__("TRAJECTORIES") if directory is None else directory)
    if not prefixes or not d.is_dir():
        return None
    return next((f for f in sorted(d.glob("*.npz")) if f.name.lower().startswith(prefixes)),
                None)


def motion_path(name: str) -> Path:
    """Path of a bundled motion, ``assets/motions/<name>.bvh`` (e.g. ``"idle"``, ``"walk"``)."""
    motions = __getattr__("MOTIONS")
    path = motions / f"{name}.bvh"
    if not path.is_file():
        have = sorted(p.stem for p in motions.glob("*.bvh")) if motions.is_dir() else []
        raise AssetError(f"no bundled motion {name!r} at {path}; available: "
                         f"{', '.join(have) or 'none'} (regenerate with "
                         "`python -m mjchar.bvh.bundled.assets`)")
    return path


def build_humanoid():
    """Convert the project skeleton with :data:`HUMANOID_OPTIONS` -> ``ConvertedModel``."""
    from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton
    from mjchar.bvh.mjcf import convert

    return convert(humanoid_skeleton(), **HUMANOID_OPTIONS)


def regenerate(out_root: str | os.PathLike | None = None, motions: bool = True) -> list[Path]:
    """Write the humanoid model (and the bundled motions when their author module exists).

    Args:
        out_root: folder standing for ``assets/`` (default: the project's ``assets/``).
        motions: also write ``motions/*.bvh`` via
        ``mjchar.bvh.bundled.authored.write_bundled_motions``.

    Returns:
        The paths written.
    """
    root = Path(out_root) if out_root is not None else _assets_folder()
    written = []
    converted = build_humanoid()
    xml_path = root / "mjcf" / "humanoid.xml"
    converted.save(xml_path)
    written.append(xml_path)
    if motions:
        try:
            from mjchar.bvh.bundled.authored import write_bundled_motions
        except ImportError:
            write_bundled_motions = None
        if write_bundled_motions is not None:
            from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton

            out = write_bundled_motions(humanoid_skeleton(), root / "motions")
            paths = out.values() if isinstance(out, dict) else (out or [])
            written.extend(Path(p) for p in paths)
    return written


def main(argv: list[str] | None = None) -> int:
    """``python -m mjchar.bvh.bundled.assets [--no-motions]``: regenerate the bundled assets."""
    argv = sys.argv[1:] if argv is None else argv
    for p in regenerate(motions="--no-motions" not in argv):
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
