"""The bundled default humanoid (mjchar.bvh.bundled.humanoid_skeleton, mjchar.bvh.bundled.assets,
assets/mjcf/humanoid.xml)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled import assets
from mjchar.bvh.bundled.humanoid_skeleton import (
    ROOT_HEIGHT,
    humanoid_rest_motion,
    humanoid_skeleton,
)
from mjchar.bvh.mjcf import ModelInfo
from mjchar.bvh.rigs import units


def test_checked_in_model_is_the_converters_output():
    """assets/mjcf/humanoid.xml equals a fresh conversion byte for byte
    (regenerate with `python -m mjchar.bvh.bundled.assets` after changing the converter)."""
    on_disk = assets.humanoid_path().read_bytes()
    assert on_disk == assets.build_humanoid().xml.encode("utf-8")


def test_bundled_model_loads_with_metadata():
    m = mujoco.MjModel.from_xml_path(str(assets.humanoid_path()))
    info = ModelInfo.from_model(m)
    assert info.joint_model == "hinge"
    assert m.nbody - 1 == 20 and m.nv == 55 and m.nu == 49
    assert abs(m.body_mass.sum() - 70.0) < 0.07
    assert m.body("RootJoint").pos[2] == pytest.approx(ROOT_HEIGHT, abs=1e-3)
    assert info.extra["height"] == pytest.approx(1.633, abs=1e-3)


def test_skeleton_matches_the_shared_clips(walk60):
    ours = humanoid_skeleton()
    theirs = bvh.load(walk60).skeleton
    assert sorted(ours.names) == sorted(theirs.names)
    assert ours.n_end_sites == theirs.n_end_sites == 5
    # same parent joint names
    for n in ours.names[1:]:
        assert ours.names[ours.parents[ours.index(n)]] == theirs.names[
            theirs.parents[theirs.index(n)]]
    # similar proportions: every bone within 25% (or 3 cm) of the clips' bone
    for n in ours.names[1:]:
        a = np.linalg.norm(ours.offsets[ours.index(n)])
        b = np.linalg.norm(theirs.offsets[theirs.index(n)])
        assert abs(a - b) < max(0.25 * b, 0.03), n


def test_skeleton_layout():
    sk = humanoid_skeleton()
    assert sk.n_joints == 20
    assert sk.channels[0] == ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation",
                              "Zrotation")
    assert all(len(c) == 3 for c in sk.channels[1:])
    assert units.guess_up_axis(sk) == "y" and units.guess_unit_scale(sk) == 1.0
    rest = sk.rest_positions()
    assert rest[sk.index("lHip")][0] > 0  # left is +X: it faces +Z
    assert rest[sk.index("lToeJoint")][2] > rest[sk.index("lAnkle")][2]
    m = humanoid_rest_motion()
    fk = bvh.forward_kinematics(m)
    assert fk.positions[0, 0, 1] == pytest.approx(ROOT_HEIGHT)
    assert 1.6 < bvh.end_site_positions(m, fk)[0, :, 1].max() < 1.7  # top of the head


def test_motion_path_errors():
    with pytest.raises(assets.AssetError, match="no bundled motion"):
        assets.motion_path("no_such_motion")


def test_regenerate_into_a_folder(tmp_path):
    written = assets.regenerate(tmp_path, motions=False)
    assert written == [tmp_path / "mjcf" / "humanoid.xml"]
    assert written[0].read_bytes() == assets.humanoid_path().read_bytes()


def test_assets_found_through_the_package():
    """The bundled files are package data of ``mjchar.assets`` (what the wheel ships), found with
    importlib.resources, not from the checkout's layout."""
    import importlib.resources

    import mjchar.bvh.bundled.assets as ba
    from mjchar import assets

    folder = importlib.resources.files(assets)
    assert ba.ASSETS == folder
    assert ba.humanoid_path() == folder / "mjcf" / "humanoid.xml"
    assert ba.motion_path("walk").is_file() and ba.motion_path("idle").is_file()
    assert sorted(p.name for p in ba.TRAJECTORIES.glob("*.npz")) == [
        "cmaes_walk60_1.5s.npz", "samcon_walk60.npz"]


def test_missing_motion_lists_the_bundled_ones():
    import mjchar.bvh.bundled.assets as ba

    with pytest.raises(ba.AssetError, match="available: idle, walk"):
        ba.motion_path("moonwalk")


def test_a_users_own_assets_package_does_not_shadow_mjchars(tmp_path, monkeypatch):
    """A project with its own top-level ``assets`` package (common) keeps using it, and mjchar
    still finds its own bundled files."""
    import sys

    import mjchar.bvh.bundled.assets as ba

    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "__init__.py").write_text("MINE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "assets", raising=False)
    import importlib

    assert importlib.import_module("assets").MINE  # the user's own
    assert ba.humanoid_path().is_file()
    assert ba.humanoid_path().parts[-3:] == ("assets", "mjcf", "humanoid.xml")
    assert tmp_path not in ba.humanoid_path().parents
    monkeypatch.delitem(sys.modules, "assets")


def test_broken_mujoco_warns():
    from mjchar.controllers.core.character.model import check_mujoco_version

    with pytest.warns(RuntimeWarning, match="mujoco-core>=4.0.1"):
        assert not check_mujoco_version("4.0.0")
    assert check_mujoco_version("4.0.1")


def test_installed_mujoco_is_fixed():
    """The environment the suite runs in has a MuJoCo without the 4.0.0 sparse-solver bug."""
    import mujoco

    major, minor, patch = (int(x) for x in mujoco.__version__.split(".")[:3])
    assert (major, minor, patch) >= (4, 0, 1), mujoco.__version__
