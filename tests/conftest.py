"""Shared fixtures: the real motion-capture clips in ../shared/data (skipped when absent, a failure
under CI), and the bundled humanoid, its walk reference and a two-thread executor for the
sampling tests; the long tiers' tests run longest first (``durations.json``)."""

from __future__ import annotations

import json
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
SHARED_MALFORMED = ROOT.parent / "shared" / "data" / "malformed"


#: how a user gets the shared data (said by every skip and failure for its absence)
GET_THE_DATA = ("put the mjchar workplace's shared/data folder (bvh/ and real/) next to the "
                "repository, as ../shared/data")


def in_ci() -> bool:
    """Whether the tests run under CI (the ``CI`` environment variable set, as CI services do;
    ``.ci/run`` sets it): missing shared data is then a failure, never a skip."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def missing_data(what: str, path: Path) -> None:
    """Stop the calling test for want of ``path``: a failure under CI (CI always has the data,
    a missing folder there is a broken checkout), else a skip saying how to get it."""
    if in_ci():
        pytest.fail(f"CI is set but {what} {path} is missing: {GET_THE_DATA}", pytrace=False)
    pytest.skip(f"{what} not found at {path}: {GET_THE_DATA} to run this test")


def shared_clip(name: str) -> Path:
    """Path of a shared clip; skips the calling test with a clear message when it is absent
    (fails under CI)."""
    path = SHARED_BVH / name
    if not path.is_file():
        missing_data("the shared motion clip", path)
    return path


def malformed_export(name: str) -> Path:
    """Path of a broken real export in ../shared/data/malformed; skips the calling test with a
    clear message when it is absent (fails under CI)."""
    path = SHARED_MALFORMED / name
    if not path.is_file():
        missing_data("the malformed real export", path)
    return path


def real_export(name: str) -> Path:
    """Path of a real export in ../shared/data/real; skips the calling test with a clear
    message when it is absent (fails under CI)."""
    path = SHARED_REAL / name
    if not path.is_file():
        missing_data("the real export", path)
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


def run_json(argv: list[str], capsys) -> dict:
    """Run an ``mjchar`` subcommand that prints one JSON object (``--json``) as
    :func:`run_command` does, check it exits 0 and return the object it printed."""
    assert run_command(argv) == 0
    return json.loads(capsys.readouterr().out)


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


def assert_no_root_help(result) -> None:
    """The check behind every "no root force" claim: the run got no force and no torque from
    outside its joint actuators beyond its declared pushes (``Result.unaided``: the root-help
    check of ``controllers/core/root_help.py``)."""
    assert result.unaided, (f"{result.controller} / {result.scenario} got help from outside: "
                            f"force up to {result.root_force_max_N:.3g} N, torque up to "
                            f"{result.root_torque_max_Nm:.3g} N m")


# -- the long tiers, longest first --------------------------------------------------------------
#: seconds each test of the slow and claims tiers took on the 2-core machine (two workers), from
#: a ``--junitxml`` run: ``python tests/update_durations.py RESULT.xml`` (tests not listed: 0)
DURATIONS = Path(__file__).with_name("durations.json")


def pytest_collection_modifyitems(config, items):
    """Run the tests with a recorded duration longest first (longest processing time first:
    with ``--dist worksteal``, two workers then finish together instead of one waiting out a
    long test alone); the others keep their order after them. The default tier has no recorded
    durations: its order stays."""
    if not DURATIONS.is_file():
        return
    seconds = json.loads(DURATIONS.read_text())["seconds"]
    items.sort(key=lambda item: -seconds.get(item.nodeid, 0.0))
