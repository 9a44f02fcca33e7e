"""Gait analysis (mjchar.bvh.gait.analysis, ``mjchar gait``): the statistics of the mocap walks
agree with an independent calculation from the clip's own forward kinematics, simulated walks are
measured by the same probe, and the command refuses what does not apply."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.gait.analysis import GaitAnalysisError, _stride_yaws, analyse, analyse_clip, table
from mjchar.bvh.reference.export import MotionRecorder
from mjchar.bvh.rigs import units
from mjchar.cli import main
from mjchar.controllers import registry
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.character import Character


def _clip_fk(path):
    """``(motion, fk, names, speed, strikes)`` of a BVH from its own FK (no model, no stance
    rule): ``fk (T, J, 3)`` in metres, ``strikes`` ``[(frame, side)]`` in time order, the local
    minima of each ankle's horizontal speed, at least 0.5 s apart."""
    motion = bvh.load(path)
    fk = bvh.forward_kinematics(motion).positions * units.guess_unit_scale(motion.skeleton)
    t = motion.times
    names = motion.skeleton.names
    root = fk[:, 0][:, [0, 2]]                                  # Y-up clips: the XZ plane
    speed = np.linalg.norm(root[-1] - root[0]) / (t[-1] - t[0])
    strikes = []
    for side in ("l", "r"):
        a = fk[:, names.index(f"{side}Ankle")][:, [0, 2]]
        v = np.linalg.norm(np.gradient(a, t, axis=0), axis=1)
        k = 1
        while k < len(v) - 1:
            w = slice(max(0, k - 15), min(len(v), k + 16))     # +-0.25 s at 60 fps
            if v[k] == v[w].min() and v[k] < 0.5 * speed:
                strikes.append((k, side))
                k += 30
            else:
                k += 1
    strikes.sort()
    return motion, fk, names, speed, strikes


def _independent(path):
    """Speed, step length and cadence from the BVH's own FK (:func:`_clip_fk`'s strikes)."""
    motion, fk, names, speed, strikes = _clip_fk(path)
    t = motion.times
    root = fk[:, 0][:, [0, 2]]
    f = (root[-1] - root[0]) / np.linalg.norm(root[-1] - root[0])
    ankle = {side: fk[:, names.index(f"{side}Ankle")][:, [0, 2]] for side in ("l", "r")}
    steps = [float((ankle[b[1]][b[0]] - ankle[a[1]][a[0]]) @ f)
             for a, b in zip(strikes, strikes[1:], strict=False) if a[1] != b[1]]
    left = np.linalg.norm(np.gradient(fk[:, names.index("lAnkle")][:, [0, 2]], t, axis=0), axis=1)
    left = left - left.mean()
    ac = np.correlate(left, left, "full")[len(left) - 1:]
    lags = np.arange(len(ac)) * motion.frame_time
    ok = (lags > 0.6) & (lags < 2.0)
    period = lags[ok][np.argmax(ac[ok])]
    return speed, float(np.mean(steps)), 120.0 / period


def test_walk60_matches_an_independent_calculation():
    path = shared_clip("walk60.bvh")
    stats = analyse_clip(path)
    speed, step, cadence = _independent(path)
    assert stats.speed_mps == pytest.approx(speed, abs=0.02)
    assert stats.step_length_m == pytest.approx(step, abs=0.05)
    assert stats.cadence_spm == pytest.approx(cadence, abs=8)
    # the issue's own probe of this clip: 1.20 m/s, 0.73 m steps, ~100 steps/min, 4 deg lean
    assert stats.speed_mps == pytest.approx(1.20, abs=0.03)
    assert 0.65 < stats.step_length_m < 0.80 and 90 < stats.cadence_spm < 110
    assert 2.0 < stats.trunk_lean_deg < 6.0 and stats.step_width_m < 0.12
    assert 15 < stats.knee_flexion_deg < 35


def test_pelvis_rotation_of_a_known_sinusoidal_yaw():
    """The bundled model's root walks a straight line at 1 m/s (heading 30 deg) and yaws +-6 deg
    sinusoidally, one period per stride: the hip joints' positions (its FK) give 12 deg of
    pelvis rotation per stride, whatever the heading."""
    ch = Character(None)
    amp, period, heading = 6.0, 1.1, np.radians(30.0)
    t = np.arange(0.0, 5.0, 0.01)
    yaw = heading + np.radians(amp) * np.sin(2 * np.pi * t / period)
    q = np.tile(ch.model.qpos0, (len(t), 1))
    q[:, 0], q[:, 1] = t * np.cos(heading), t * np.sin(heading)
    q[:, 3], q[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)        # a turn about z
    data = mujoco.MjData(ch.model)
    body = {r: mujoco.mj_name2id(ch.model, mujoco.mjtObj.mjOBJ_BODY,
                                 ch.info.joints[ch.info.roles[r]].body)
            for r in ("pelvis", "left_hip", "right_hip")}
    pos = {r: np.empty((len(t), 3)) for r in body}
    for k, qk in enumerate(q):
        data.qpos[:] = qk
        mujoco.mj_kinematics(ch.model, data)
        for r, b in body.items():
            pos[r][k] = data.xpos[b]
    strikes = list(np.searchsorted(t, 0.37 + period * np.arange(4)))
    yaws = _stride_yaws(pos["left_hip"], pos["right_hip"], pos["pelvis"], strikes)
    strides = [float(np.ptp(y)) for y in yaws.values()]  # as analyse() reports them
    assert len(strides) == 3
    assert strides == pytest.approx([2 * amp] * 3, abs=0.5), strides


def test_walk60_pelvis_rotation_matches_the_root_orientation():
    """walk60's pelvis rotation (the gait probe measures it from the hip line of the model's
    kinematics) against an independent quantity: the yaw of the clip's own root rotation
    channels (quaternions, no positions), relative to each stride's travel, over the strides
    between the left strikes that :func:`_clip_fk` finds."""
    from scipy.spatial.transform import Rotation

    path = shared_clip("walk60.bvh")
    stats = analyse_clip(path)
    motion, fk, names, _, strikes = _clip_fk(path)
    root = fk[:, 0][:, [0, 2]]
    q = motion.rotations[:, 0]                                   # (T, 4) wxyz, root joint
    rest = motion.skeleton.offsets[names.index("lHip")] - motion.skeleton.offsets[
        names.index("rHip")]                                      # the hip line at rest
    lat = Rotation.from_quat(q, scalar_first=True).apply(rest)[:, [0, 2]]
    left = [k for k, side in strikes if side == "l"]
    ranges = []
    for a, b in zip(left, left[1:], strict=False):
        d = root[b] - root[a]
        yaw = np.unwrap(np.arctan2(lat[a:b + 1, 1], lat[a:b + 1, 0]))
        yaw -= np.arctan2(d[1], d[0])
        ranges.append(np.degrees(np.ptp(yaw)))
    assert len(ranges) >= 1 and stats.strides >= 1              # a 3 s clip: one stride
    assert stats.pelvis_rotation_deg == pytest.approx(np.mean(ranges), abs=1.5)
    assert 2.0 < stats.pelvis_rotation_deg < 20.0


def test_simulated_walk_is_measured_by_the_same_probe():
    ch = Character(None)
    ch.set_timestep(registry.get("simbicon").timestep)
    rec = MotionRecorder()
    result = S.run_scenario("walk", ch, registry.make_controller("simbicon", ch, None),
                            duration=6.0, frame_callback=rec)
    stats = analyse(ch.model, rec.times, rec.qpos, start=2.0, info=ch.info, label="simbicon")
    assert not result.fell and stats.steps >= 6
    t, q = np.asarray(rec.times), np.asarray(rec.qpos)
    i = int(np.searchsorted(t, 2.0 - 1e-9))
    assert stats.speed_mps == pytest.approx(
        np.linalg.norm(q[-1, :2] - q[i, :2]) / (t[-1] - t[i]), rel=1e-6)
    assert 0.2 < stats.step_length_m < 1.0 and 60 < stats.cadence_spm < 200
    assert set(stats.cycle_mean) >= {"left_knee_flexion", "left_hip_flexion", "trunk_lean"}
    assert len(stats.cycle_mean["trunk_lean"]) == 101
    assert "| step length m |" in table([stats])


def test_filmstrip_shows_one_stride_of_a_walk_beside_the_clip(tmp_path):
    """The filmstrip's frames span the middle whole stride (left strike to left strike, the
    strikes the probe found), and the rendered poses differ from frame to frame."""
    from mjchar.gait_plot import plot_filmstrip, stride_window
    from mjchar.render import render_poses

    ch = Character(None)
    rec = MotionRecorder()
    result = S.run_scenario("walk", ch, registry.make_controller("ipm", ch, None, speed=1.0),
                            duration=6.0, frame_callback=rec)
    stats = analyse(ch.model, rec.times, rec.qpos, start=2.0, info=ch.info, label="ipm")
    assert not result.fell and len(stats.left_strikes) >= 3
    t0, t1 = stride_window(stats, rec.times)
    k = stats.left_strikes.index(t0)
    assert stats.left_strikes[k + 1] == t1 and 0.6 < t1 - t0 < 1.6
    q = np.asarray(rec.qpos)
    i = int(np.searchsorted(rec.times, t0))
    a, b = render_poses(ch.model, q[[i, i + 25]], width=64, height=96)
    assert a.shape == (96, 64, 3) and np.abs(a.astype(int) - b).sum() > 0
    again = render_poses(ch.model, q[[i]], width=64, height=96)[0]
    assert np.array_equal(a, again)
    out = tmp_path / "strip.png"
    plot_filmstrip([(stats, ch.model, rec.times, rec.qpos)], out, frames=4)
    import matplotlib.image as mpimg

    img = mpimg.imread(out)
    assert img.shape[1] > 1.5 * img.shape[0]  # one row of four portrait frames


def test_cli_filmstrip_beside_the_mocap(tmp_path, capsys):
    out = tmp_path / "strip.png"
    clip = str(shared_clip("walk60.bvh"))
    assert main(["gait", clip, "--reference", str(shared_clip("walk_forward.bvh")),
                 "--filmstrip", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["filmstrip"] == str(out) and out.stat().st_size > 10_000
    assert len(doc["source"]["left_strikes"]) >= 2


def test_cli_seed_perturbs_the_start_and_repeats(capsys):
    """``--seed N`` starts a walker from a seeded perturbation of the standing pose: another
    walk than without it, the same walk for the same seed."""
    def run(*extra):
        argv = ["gait", "ipm", "--speed", "1.0", "--duration", "4", "--from", "1", "--json"]
        assert main(argv + list(extra)) == 0
        return json.loads(capsys.readouterr().out)["source"]

    plain, seeded, again = run(), run("--seed", "1"), run("--seed", "1")
    assert seeded == again
    assert seeded["speed_mps"] != plain["speed_mps"]


def test_too_short_a_window_is_an_error():
    ch = Character(None)
    q = np.tile(ch.model.qpos0, (5, 1))
    with pytest.raises(GaitAnalysisError, match="at least 0.5 s"):
        analyse(ch.model, np.arange(5) * 0.01, q)


def test_cli_clip_json_and_plot(tmp_path, capsys):
    out = tmp_path / "cycle.png"
    assert main(["gait", str(shared_clip("walk60.bvh")), "--plot", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["source"]["label"] == "walk60" and doc["references"] == []
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("argv,needle", [
    (["gait", "ipm", "--gait", "walk"], "--gait does not apply to ipm"),
    (["gait", "simbicon", "--speed", "3"], "simbicon walks at"),
    (["gait", "ipm", "--speed", "9"], "out of range"),
    (["gait", "hand_of_god"], "SOURCE must be a walker"),
    (["gait", "/no/such.bvh"], "no such file"),
    (["gait", "ipm", "--filmstrip", "strip.gif"], "--filmstrip strip.gif: give a .png path"),
    (["gait", "x.bvh", "--duration", "3"], "--duration applies to walkers"),
    (["gait", "simbicon", "--duration", "2", "--from", "3"], "before the end"),
])
def test_cli_refuses_what_does_not_apply(argv, needle, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1
