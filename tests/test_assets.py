"""The bundled default humanoid (bvh.humanoid_skeleton, bvh.assets, assets/mjcf/humanoid.xml)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import bvh
from bvh import assets
from bvh.humanoid_skeleton import ROOT_HEIGHT, humanoid_rest_motion, humanoid_skeleton
from bvh.mjcf import ModelInfo


def test_checked_in_model_is_the_converters_output():
    """assets/mjcf/humanoid.xml equals a fresh conversion byte for byte
    (regenerate with `python -m bvh.assets` after changing the converter)."""
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
    assert bvh.units.guess_up_axis(sk) == "y" and bvh.units.guess_unit_scale(sk) == 1.0
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
