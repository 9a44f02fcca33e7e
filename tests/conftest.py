"""Shared fixtures: the real motion-capture clips in ../shared/data (skipped when absent), and the
bundled humanoid, its walk reference and a two-thread executor for the sampling tests."""

from __future__ import annotations

import os
from pathlib import Path

# headless rendering (the machines have no display): must be set before MuJoCo is first imported
os.environ.setdefault("MUJOCO_GL", "egl")
# the walkers run their defaults on every body unless a test asks for a calibration (a walker on
# an uncalibrated body would otherwise calibrate it first: minutes, into the user's cache)
os.environ.setdefault("MJCHAR_CALIBRATION", "none")

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_BVH = ROOT.parent / "shared" / "data" / "bvh"
SHARED_CLIPS = ["walk60.bvh", "idle.bvh", "walk_forward.bvh", "walk_and_turn_right.bvh"]
SHARED_REAL = ROOT.parent / "shared" / "data" / "real"


def shared_clip(name: str) -> Path:
    """Path of a shared clip; skips the calling test with a clear message when it is absent."""
    path = SHARED_BVH / name
    if not path.is_file():
        pytest.skip(f"shared motion data not found at {path} (a clone outside the mjchar "
                    f"workplace has no ../shared/data); this test needs it")
    return path


def real_export(name: str) -> Path:
    """Path of a real export in ../shared/data/real; skips the calling test with a clear
    message when it is absent."""
    path = SHARED_REAL / name
    if not path.is_file():
        pytest.skip(f"real export not found at {path} (../shared/data/real holds the real "
                    f"exports of more rig families; a clone outside the mjchar workplace has "
                    f"none); this test needs it")
    return path


@pytest.fixture(params=SHARED_CLIPS)
def shared_clip_path(request) -> Path:
    """Each shared clip in turn."""
    return shared_clip(request.param)


@pytest.fixture
def walk60() -> Path:
    return shared_clip("walk60.bvh")


@pytest.fixture(scope="module")
def character():
    """The bundled humanoid (a module's tests share it; modules may define their own)."""
    from mjchar.controllers.core.character import Character

    return Character()


@pytest.fixture(scope="module")
def walk_ref(character):
    """The bundled walk motion as a reference for ``character``."""
    from mjchar import bvh
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    return ReferenceMotion(character.model, bvh.load(motion_path("walk")), info=character.info)


@pytest.fixture(scope="module")
def executor():
    """A two-thread local rollout executor."""
    from mjchar.controllers.sampling.executors import LocalExecutor

    with LocalExecutor(threads=2) as ex:
        yield ex


def run_command(argv: list[str]):
    """Run an ``mjchar`` subcommand through the real parser, letting project errors propagate
    (``mjchar.cli.main`` would turn them into exit status 2)."""
    from mjchar.cli import build_parser

    args = build_parser().parse_args(argv)
    return args.func(args)


@pytest.fixture(scope="session")
def zoo_humanoids(tmp_path_factory) -> dict[float, str]:
    """The zoo's humanoids: the bundled humanoid's skeleton scaled to 1.5 m / 50 kg and 1.95 m /
    100 kg, converted with their masses as the bench's skeletons section does: {height: xml}."""
    from mjchar import bvh
    from mjchar.bvh.bundled.zoo import _humanoids
    from mjchar.bvh.mjcf import convert

    out = {}
    for rig in _humanoids():
        xml = tmp_path_factory.mktemp("rigs") / f"{rig.name}.xml"
        convert(bvh.loads(bvh.dumps(rig.motion)), total_mass=rig.mass_kg).save(xml)
        out[rig.height_m] = str(xml)
    return out
