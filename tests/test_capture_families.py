"""The converter on the capture families users bring: up axes that point down, decimetres,
knees that twist while they bend (generated files; the real exports are tests/test_real_exports.py).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.mjcf import convert
from mjchar.bvh.rigs.units import transform_motion
from mjchar.bvh.rotations import quat_from_rotvec, quat_mul
from tests.conftest import run_command


@pytest.fixture(scope="module")
def walk() -> bvh.Motion:
    """The bundled walk: metres, Y-up, facing +Z."""
    return bvh.load(motion_path("walk"))


def _knee_axis(model: mujoco.MjModel, side: str) -> np.ndarray:
    for j in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if name.startswith(f"{side}Knee"):
            return model.jnt_axis[j].copy()
    raise AssertionError(f"no {side}Knee hinge")


def test_up_axis_pointing_down_is_detected(walk, tmp_path, capsys):
    """The walk written with +Y pointing down (an Azure Kinect export's camera frame): read as
    -y, the same body stands up, and the replay is as exact as the original's."""
    down = transform_motion(walk, 1.0, quat_from_rotvec([0.0, 0.0, np.pi]))  # y -> -y
    ref, c = convert(walk), convert(down)
    assert ref.info.up_axis == "y" and c.info.up_axis == "-y"
    assert c.summary["height_m"] == pytest.approx(ref.summary["height_m"], abs=1e-3)
    assert c.summary["n_dofs"] == ref.summary["n_dofs"]
    assert not any("stood upright" in w for w in c.warnings)
    given = convert(down, up_axis="-y")
    assert given.summary["height_m"] == pytest.approx(c.summary["height_m"], abs=1e-9)
    from mjchar.bvh.reference.reference_motion import replay_errors

    assert replay_errors(c.compile(), c.motion)["max_mm"] < 20.0
    path = tmp_path / "down.bvh"
    bvh.save(down, path)
    capsys.readouterr()
    assert run_command(["convert", str(path), "-o", str(tmp_path / "d.xml"), "--up", "-y"]) == 0
    assert "up axis -y" in capsys.readouterr().out


def test_up_axis_option_refuses_nonsense(walk):
    with pytest.raises(bvh.MjcharError, match="-x, -y or -z"):
        convert(walk, up_axis="+w")


def test_decimetres_from_the_body(walk):
    """A Blender scene in decimetres (Z-up), a 1.55 m body: read in dm, not at a fitted
    scale, and said in the unit line."""
    zup = transform_motion(walk, 10.0 * 1.55 / convert(walk).summary["height_m"],
                           quat_from_rotvec([np.pi / 2, 0.0, 0.0]))
    c = convert(zup)
    assert c.info.up_axis == "z"
    assert c.summary["unit_name"] == "dm" and c.summary["unit_scale"] == 0.1
    assert c.summary["height_m"] == pytest.approx(1.55, abs=0.01)


def test_fitted_scale_said_in_one_line(walk, tmp_path, capsys):
    """No known unit fits (a body 8.5 units tall): the fitted scale is used and said."""
    odd = transform_motion(walk, 8.5 / convert(walk).summary["height_m"])
    path = tmp_path / "odd.bvh"
    bvh.save(odd, path)
    capsys.readouterr()
    assert run_command(["convert", str(path), "-o", str(tmp_path / "o.xml")]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "unit:" in ln]
    assert len(line) == 1 and "no known unit fits" in line[0]


def _twisting_knees(walk: bvh.Motion, ratio: float) -> bvh.Motion:
    """The walk with each knee twisting about its shank by ``ratio`` times its flexion (the
    ankles stay where they were: only the feet turn)."""
    m = walk.copy()
    sk = m.skeleton
    for s in "lr":
        k, a = sk.index(f"{s}Knee"), sk.index(f"{s}Ankle")
        e = sk.offsets[a] / np.linalg.norm(sk.offsets[a])
        q = m.rotations[:, k]
        angle = 2.0 * np.arccos(np.clip(np.abs(q[:, 0]), 0.0, 1.0))
        twist = quat_from_rotvec(ratio * angle[:, None] * e)
        m.rotations[:, k] = quat_mul(q, twist)
    return m


def test_knee_hinge_fitted_on_the_flexion_not_the_twist(walk):
    """Knees that twist while they flex (0.8 x the flexion: up to ~50 deg): the hinge is still
    the lateral axis (MuJoCo y), as for the untwisted clip; the whole rotation's principal
    axis, the old fit, is far off it."""
    from mjchar.bvh.mjcf.dynamics import _flexion_from_clip
    from mjchar.bvh.rotations import quat_to_rotvec

    twisted = _twisting_knees(walk, 0.8)
    model = convert(twisted).compile()
    for s in "lr":
        axis = _knee_axis(model, s)
        assert abs(axis[1]) > np.cos(np.radians(5.0)), (s, axis)
    # the same clip fitted on the whole rotation vectors
    sk = twisted.skeleton
    k = sk.index("lKnee")
    rv = quat_to_rotvec(twisted.rotations[:, k])
    naive = _flexion_from_clip(None, rv)
    assert naive is not None
    lateral = np.array([1.0, 0.0, 0.0])  # the file's left-right axis (Y-up, facing +Z)
    assert abs(float(naive[2] @ lateral)) < np.cos(np.radians(25.0)), naive
