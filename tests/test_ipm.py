"""IPM stepping (controllers/walking/ipm.py, controllers/walking/swing.py) on the bundled humanoid,
no root force.

Fast tests (default run): the formulas and helpers, 10 s walks at 0.5 and 1.0 m/s, stopping,
turning by 90 degrees, one 150 N push per direction, and a push that static balance cannot
survive while IPM stepping can. The 60 s walks and the 8-direction push sweep are marked slow
(``pytest -m slow``); ``python -m mjchar.perf.ipm`` runs the long versions and reports the numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjchar.bvh.bundled.humanoid_skeleton import humanoid_rest_motion
from mjchar.bvh.mjcf import convert
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.registry import make_controller
from mjchar.controllers.core.scenarios import push, simulate, standing_pose, survived
from mjchar.controllers.walking.ipm import (
    IPMController,
    IPMError,
    IPMParams,
    ipm_step_offset,
    make_ipm,
)
from mjchar.controllers.walking.ipm_params import StepTiming
from mjchar.controllers.walking.swing import (
    SwingError,
    SwingTrajectory,
    rotation_about,
    two_link_ik,
)


@pytest.fixture(scope="module")
def character() -> Character:
    return Character()


def run_walk(character: Character, controller, duration: float):
    """Simulate from the standing pose; returns (result, times (T,), COM xy (T, 2), yaw (T,))."""
    times, com, yaw = [], [], []

    def record(ch: Character) -> None:
        times.append(ch.time)
        com.append(ch.state.com()[:2].copy())
        R = ch.data.xmat[ch.root_body].reshape(3, 3)
        yaw.append(math.atan2(R[1, 0], R[0, 0]))

    r = simulate(character, controller, duration=duration, scenario="walk",
                 qpos=standing_pose(character), frame_callback=record)
    return r, np.asarray(times), np.asarray(com), np.asarray(yaw)


def mean_velocity(times: np.ndarray, com: np.ndarray, t0: float, t1: float | None = None):
    """``(2,)`` mean COM velocity (m/s) between ``t0`` and ``t1`` (default: the end)."""
    i = int(np.searchsorted(times, t0))
    j = len(times) - 1 if t1 is None else int(np.searchsorted(times, t1))
    return (com[j] - com[i]) / (times[j] - times[i])


# -- formulas and helpers ------------------------------------------------------------------------
def test_ipm_step_offset_formula():
    h, g = 0.9, 9.81
    for v in (0.0, 0.3, 1.0, -0.7):
        assert ipm_step_offset(v, h) == pytest.approx(v * math.sqrt(h / g + v * v / (4 * g * g)))
    d = ipm_step_offset(np.array([0.5, -0.5]), h)
    assert d[0] == pytest.approx(-d[1]) and d[0] > 0
    assert ipm_step_offset(1.0, h) > ipm_step_offset(0.5, h) > 0
    with pytest.raises(IPMError):
        ipm_step_offset(1.0, -0.1)


def test_swing_trajectory_heights_and_blend():
    tr = SwingTrajectory((0.04, 0.15, 0.05), descent_speed=1.0, floor=-0.05, blend="quadratic")
    assert tr.height(0.0, 0.5) == pytest.approx(0.04)
    assert tr.height(0.5, 0.5) == pytest.approx(0.15)
    assert tr.height(1.0, 0.5) == pytest.approx(0.05)
    # after phase 1 the target sinks at descent_speed until the floor
    assert tr.height(1.1, 0.5) == pytest.approx(0.05 - 1.0 * 0.1 * 0.5)
    assert tr.height(3.0, 0.5) == pytest.approx(-0.05)
    # the paper's blend: lift-off weight (1 - phase)^2
    for ph in (0.0, 0.3, 0.7, 1.0, 1.4):
        assert tr.liftoff_weight(ph) == pytest.approx((1 - min(ph, 1.0)) ** 2)
    a, b = np.array([-0.2, 0.1]), np.array([0.3, 0.12])
    assert tr.horizontal(0.0, a, b) == pytest.approx(a)
    assert tr.horizontal(1.0, a, b) == pytest.approx(b)
    smooth = SwingTrajectory(blend="smooth")
    assert smooth.liftoff_weight(0.0) == 1.0 and smooth.liftoff_weight(1.0) == 0.0
    assert smooth.liftoff_weight(0.5) == pytest.approx(0.5)
    with pytest.raises(SwingError):
        SwingTrajectory(blend="cubic")
    with pytest.raises(SwingError):
        SwingTrajectory((0.1, float("nan"), 0.0))


@pytest.mark.parametrize("target", [(0.0, 0.0, -0.78), (0.3, 0.1, -0.65), (-0.2, -0.1, -0.7)])
def test_two_link_ik_reaches_target_with_knee_forward(target):
    hip = np.array([0.1, 0.2, 0.9])
    tgt = hip + np.array(target)
    l1, l2 = 0.41, 0.395
    thigh, axis, flexion = two_link_ik(hip, tgt, l1, l2, np.array([1.0, 0.0, 0.0]))
    knee = hip + l1 * thigh
    ankle = knee + l2 * (rotation_about(axis, flexion) @ thigh)
    assert ankle == pytest.approx(tgt, abs=1e-9)
    assert 0.0 <= flexion < math.pi
    # the knee is in front of the hip-ankle line (it points along the pole)
    mid = 0.5 * (hip + tgt)
    assert (knee - mid)[0] > 0


def test_two_link_ik_out_of_reach_is_clamped():
    hip = np.zeros(3)
    thigh, axis, flexion = two_link_ik(hip, np.array([0.0, 0.0, -2.0]), 0.41, 0.395,
                                       np.array([1.0, 0.0, 0.0]))
    assert flexion == pytest.approx(0.0, abs=0.1)
    assert thigh @ np.array([0.0, 0.0, -1.0]) > 0.99


def test_options_are_checked():
    """Overrides go by dotted name; an unknown one lists the valid names (the likely ones
    first); a value a parameter does not accept is one line naming it and what it accepts."""
    with pytest.raises(IPMError, match=r"unknown IPM parameter\(s\) timing.stepp_time \(did you "
                       r"mean timing.step_time\?\); valid: timing.step_time, "):
        IPMController(speed=1.0, **{"timing.stepp_time": 0.5})
    # a bare (flat) name is not a parameter: the message names the dotted ones it may mean
    with pytest.raises(IPMError, match=r"step_time \(did you mean timing.step_time, "
                       r"human.step_time\?\)"):
        IPMController(step_time=0.5)
    with pytest.raises(IPMError, match=r"human_top \(did you mean speed.human_top\?\)"):
        IPMController(human_top=1.4)
    for name, value, accepted in (
            ("timing.step_time", -0.1, "a finite number > 0 and <= 10 (s)"),
            ("timing.step_time", float("nan"), "a finite number > 0 and <= 10 (s)"),
            ("timing.step_time", "fast", "a finite number > 0 and <= 10 (s)"),
            ("timing.step_time", 1e9, "a finite number > 0 and <= 10 (s)"),
            ("tracking.hip_kp", math.inf, "a finite number >= 0 and <= 100000 (N m/rad)"),
            ("tracking.hip_kd", True, "a finite number >= 0 and <= 10000 (N m s/rad)"),
            ("feet.push_off_phase", 1.0, "a finite number >= 0 and < 1 (step phase)"),
            ("swing.blend", "linear", "one of 'quadratic', 'smooth'"),
            ("swing.heights", 0.1, "3 finite numbers, each >= -10 and <= 10 (m)"),
            ("feet.ankle_back_speeds", 0.8, "2 finite numbers, each >= 0 and <= 20 (m/s)"),
            ("turning.ankle_limit", None, "3 finite numbers, each >= 0 and <= 10 (m)"),
            ("stance.ankle_limit", (0.08, -0.01, 0.02),
             "3 finite numbers, each >= 0 and <= 10 (m), or null"),
            ("tracking.feedforward", 1, "true or false")):
        with pytest.raises(IPMError) as e:
            IPMController(**{name: value})
        assert str(e.value) == f"IPM parameter {name} must be {accepted}, got {value!r}"
    with pytest.raises(IPMError, match="speed.fast <= speed.human_top < speed.human_end"):
        IPMController(**{"speed.human_top": 1.7})
    with pytest.raises(IPMError, match="timing.min_phase < timing.max_phase"):
        IPMController(**{"timing.max_phase": 0.4})
    with pytest.raises(IPMError, match="from < full"):
        IPMController(**{"feet.ankle_back_speeds": (0.9, 0.7)})
    with pytest.raises(IPMError, match="group timing must be a StepTiming"):
        IPMParams(timing={"step_time": 0.5})
    with pytest.raises(IPMError):
        IPMController(speed=float("nan"))
    c = IPMController(speed=1.0, params=IPMParams(timing=StepTiming(step_time=0.45)),
                      **{"tracking.hip_kp": 500, "feet.ankle_back_speeds": [0.6, 0.8],
                         "stance.ankle_limit": None})
    assert c.params.timing.step_time == 0.45 and c.params.tracking.hip_kp == 500.0
    assert type(c.params.tracking.hip_kp) is float  # a JSON integer becomes a float
    assert c.params.feet.ankle_back_speeds == (0.6, 0.8) and c.params.stance.ankle_limit is None
    assert c.params.flat()["timing.step_time"] == 0.45
    q = IPMParams().updated({"timing.step_time": np.float32(0.5), "swing.heights": np.zeros(3)})
    assert type(q.timing.step_time) is float and q.swing.heights == (0.0, 0.0, 0.0)
    assert c.params.updated({}) is c.params
    assert c.name == "ipm" and c.actuation == "torque"


def test_toe_up_ankle_limit_weight_follows_the_speed():
    """The toe-up ankle limit (``feet.ankle_back``) takes over between feet.ankle_back_speeds
    and holds at every faster speed, at least as much as the human band's blend."""
    p = IPMParams()
    lo, hi = p.feet.ankle_back_speeds
    assert p.ankle_back_weight(0.0) == p.ankle_back_weight(lo) == 0.0
    assert p.ankle_back_weight((lo + hi) / 2) == pytest.approx(0.5)
    assert all(p.ankle_back_weight(v) == 1.0 for v in (hi, 1.2, 1.6, 3.0, -1.2))
    late = p.updated({"feet.ankle_back_speeds": (1.5, 2.0)})
    assert late.ankle_back_weight(1.2) == late.speed_blend(1.2) == 1.0


@pytest.mark.parametrize("speed", [1.0, 1.4])  # 1.4: with the stance foot's twist block
def test_the_implicit_damping_equals_the_dense_solve(character, speed):
    """Mid-walk, :class:`~.ipm_torques.Damping` (sparse factorisation, the hips' rows by
    Woodbury) gives the torques of the dense ``(M + dt D) qddot = rhs`` solve."""
    from mjchar.controllers.walking import ipm_torques

    ctrl = make_ipm(character, speed=speed, calibration="none")
    seen, calls = [], [0]
    real = ipm_torques.Damping.damped

    def check(self, ch, tau, implicit):
        out = real(self, ch, tau, implicit)
        calls[0] += 1
        if ch.time > 2.0 and calls[0] % 10 == 0:  # 20 steps from 2 s to 4 s
            D = np.diag(self.d)
            D[self.rows] = self.W
            if self.has_block:
                D[np.ix_(self.block_dofs, self.block_dofs)] += self.B
            dyn, v, dt = ch.dynamics, ch.state.qvel, ch.timestep
            rhs = (tau - D @ v - dyn.bias_forces() + dyn.passive_forces()
                   + dyn.constraint_forces())
            qacc = np.linalg.solve(dyn.mass_matrix() + dt * D, rhs)
            np.testing.assert_allclose(out, tau - D @ (v + dt * qacc), rtol=0, atol=1e-9)
            seen.append(self.has_block)
        return out

    ipm_torques.Damping.damped = check
    try:
        run_walk(character, ctrl, 4.0)
    finally:
        ipm_torques.Damping.damped = real
    assert len(seen) >= 19 and any(seen) == (speed > 1.2)


def test_act_before_reset_raises():
    with pytest.raises(IPMError):
        IPMController().act(None, 0.0)


def test_a_ball_jointed_model_is_refused():
    # ball hips and ankles (and a hinge knee) have the leg's dof counts, but IPM maps torques to
    # hinges: refused at reset, not walked on
    c = convert(humanoid_rest_motion(), joint_model="ball")
    ch = Character(c.compile(), info=c.info)
    with pytest.raises(IPMError, match=r"left hip \(joint lHip is a ball joint\).*--joint-model "
                                       "hinge"):
        IPMController(speed=1.0).reset(ch)


def test_foot_placement_follows_velocity_width_and_clamp(character):
    c = make_ipm(character, speed=0.0)
    character.reset(standing_pose(character))
    c.reset(character)
    h = 0.9
    slow = c.foot_placement(np.array([0.2, 0.0]), h, swing=0, v_desired=0.0)
    fast = c.foot_placement(np.array([0.8, 0.0]), h, swing=0, v_desired=0.0)
    assert fast[0] > slow[0] > 0
    # the desired speed moves the step back (keeps walking instead of stopping)
    assert c.foot_placement(np.array([0.8, 0.0]), h, 0, v_desired=1.0)[0] < fast[0]
    # left swing steps to the left of the COM, right swing to the right
    assert c.foot_placement(np.zeros(2), h, swing=0, v_desired=0.0)[1] > 0
    assert c.foot_placement(np.zeros(2), h, swing=1, v_desired=0.0)[1] < 0
    # never closer than min_width beside the stance foot (no crossed legs)
    off = c.foot_placement(np.array([0.0, -1.0]), h, swing=0, v_desired=0.0, stance_lateral=-0.1)
    assert off[1] >= -0.1 + c.params.placement.min_width - 1e-12
    # clamped to +-0.4 leg length
    huge = c.foot_placement(np.array([10.0, 10.0]), h, swing=0, v_desired=0.0)
    assert np.all(np.abs(huge) <= 0.4 * c.leg_length + 1e-12)


def test_stands_without_command(character):
    """Zero command: it stands (static balance mode), takes no step, applies no root force."""
    c = make_ipm(character, speed=0.0)
    r, times, com, _ = run_walk(character, c, 3.0)
    assert not r.fell
    assert c.mode == "stand" and c.steps == 0
    assert r.root_force_max_N == 0.0
    assert r.foot_travel_m < 0.02


# -- walking -------------------------------------------------------------------------------------
def test_starts_from_a_foot_on_its_toes(character):
    """A start with one foot on its toes (perturbed starts on converted rigs): the
    standing pose lowers the pelvis until both legs reach their flat-foot targets, so its IK
    stays near the start (no wound-up hip or ankle angles) and the walk starts without a fall."""
    q = standing_pose(character)
    q[character.joint_qpos(character.role("right_ankle"))[0]] += 0.3  # toes down
    q = character.poses.on_floor(q)
    c = make_ipm(character, speed=1.0)
    character.reset(q, np.zeros(character.nv))
    c.reset(character)
    legs = np.concatenate([lg.leg for lg in c._legs])
    m = character.model
    assert np.abs(c._stand.pose[m.jnt_qposadr[m.dof_jntid[legs]]]).max() < 0.6
    r = simulate(character, make_ipm(character, speed=1.0), duration=3.0, scenario="walk",
                 qpos=q)
    assert not r.fell, r.fall_reason


@pytest.mark.parametrize("speed", [0.5, 1.0])
def test_walks_at_commanded_speed(character, speed):
    c = make_ipm(character, speed=speed)
    r, times, com, yaw = run_walk(character, c, 10.0)
    assert not r.fell, r.fall_reason
    assert r.root_force_max_N == 0.0 and r.root_torque_mean_Nm == 0.0
    assert c.mode == "step" and c.steps >= 12
    v = mean_velocity(times, com, 4.0)
    assert abs(v[0] - speed) < 0.15, v      # along the commanded heading (+X)
    assert abs(v[1]) < 0.1, v
    assert abs(yaw[-1]) < math.radians(10)


def test_walks_fast_with_quicker_steps(character):
    """1.5 m/s (beyond the old 1.0 m/s range): no fall in 10 s, the speed within 0.15 m/s once
    the ramped speed target has arrived, and quicker steps than at 0.5 m/s."""
    c = make_ipm(character, speed=1.5)
    r, times, com, yaw = run_walk(character, c, 10.0)
    assert not r.fell, r.fall_reason
    assert r.root_force_max_N == 0.0
    v = mean_velocity(times, com, 6.0)
    assert abs(v[0] - 1.5) < 0.15, v
    late = np.diff([t for t in c.step_switches if t > 6.0])
    assert late.mean() < 0.45 < c.params.at_speed(0.5)[0]


def test_gait_at_1_2_mps_is_human_like(character):
    """The gait bars at 1.2 m/s (12 s walk from standing, analysed from 3 s with
    mjchar.bvh.gait.analysis, the probe of ``mjchar gait``): trunk lean < 8 deg, step width
    0.05-0.15 m, step length 0.55-0.80 m, cadence 95-130 steps/min, mean knee flexion 15-35 deg,
    stance slip < 1 cm per step (docs/ipm.md: the human band's lift-off and stance ankle)."""
    from mjchar.bvh.gait.analysis import analyse
    from mjchar.bvh.reference.export import MotionRecorder

    rec = MotionRecorder()
    r = simulate(character, make_ipm(character, speed=1.2), duration=12.0, scenario="walk",
                 qpos=standing_pose(character), frame_callback=rec)
    assert not r.fell, r.fall_reason
    g = analyse(character.model, rec.times, rec.qpos, start=3.0, info=character.info)
    assert g.trunk_lean_deg < 8.0
    assert 0.05 <= g.step_width_m <= 0.15
    assert 0.55 <= g.step_length_m <= 0.80
    assert 95.0 <= g.cadence_spm <= 130.0
    assert 15.0 <= g.knee_flexion_deg <= 35.0
    assert g.stance_slip_m < 0.010


@pytest.mark.parametrize("speed", [1.0, 1.4])
def test_stance_slip_under_1cm_off_1_2_mps(character, speed):
    """The slip bar (< 1 cm per step, mjchar.bvh.gait.analysis's probe) away from 1.2 m/s
    too: 15 s walks from standing, analysed from 3 s (docs/ipm.md, stance slip across speeds: 1.29
    and 1.71 cm before the stance ankle's toe-up limit below the band, the swing foot's toes-up
    lift-off and the feet's measures held above it; 0.63 and 0.95 cm after)."""
    from mjchar.bvh.gait.analysis import analyse
    from mjchar.bvh.reference.export import MotionRecorder

    rec = MotionRecorder()
    r = simulate(character, make_ipm(character, speed=speed), duration=15.0, scenario="walk",
                 qpos=standing_pose(character), frame_callback=rec)
    assert not r.fell, r.fall_reason
    g = analyse(character.model, rec.times, rec.qpos, start=3.0, info=character.info)
    assert g.stance_slip_m < 0.010, g.stance_slip_m
    assert g.speed_mps > 0.85 * speed, g.speed_mps      # from 3 s: the start-up is in it


def test_stops_and_stands(character):
    c = make_ipm(character, speed=lambda t: 0.5 if t < 4.0 else 0.0)
    r, times, com, _ = run_walk(character, c, 10.0)
    assert not r.fell, r.fall_reason
    assert c.steps >= 5
    assert c.mode == "stand"
    assert c.stand_switches[-1] < 8.0
    v = mean_velocity(times, com, 9.0)
    assert np.linalg.norm(v) < 0.03, v
    assert r.root_force_max_N == 0.0


def test_turns_to_a_heading_90_degrees_away(character):
    c = make_ipm(character, speed=0.5, heading=lambda t: 0.0 if t < 2.0 else 90.0)
    r, times, com, yaw = run_walk(character, c, 10.0)
    assert not r.fell, r.fall_reason
    assert abs(math.degrees(yaw[-1]) - 90.0) < 15.0
    v = mean_velocity(times, com, 8.0)
    direction = math.degrees(math.atan2(v[1], v[0]))
    assert abs(direction - 90.0) < 25.0 and np.linalg.norm(v) > 0.3, v
    assert r.root_force_max_N == 0.0


# -- pushes --------------------------------------------------------------------------------------
@pytest.mark.parametrize("direction", [0.0, 90.0, 180.0, 270.0])
def test_survives_150N_push_by_stepping(character, direction):
    c = make_ipm(character, speed=0.0)
    r = push(character, c, force=150.0, direction=direction, allow_steps=True)
    assert survived(r, allow_steps=True), r.fall_reason
    assert r.stepped and c.steps >= 1
    assert r.root_force_max_N == 0.0


def test_recovery_step_is_not_widened_while_the_com_moves_sideways():
    """The push protocol's one 150 N failure before the fix (backward, moment 1.625 s, seed 2):
    the recovery steps drift sideways, a step of the zero command was widened to the standing
    width across the COM's motion, and the COM fell over the far side of the new stance foot."""
    from mjchar.controllers.core.scenarios.push_search import PushProtocol, PushTask, simulate_push

    protocol = PushProtocol(forces=(150.0,), phases=8, seeds=(2,)).check()
    task = PushTask("ipm", "backward", 150.0, protocol.phase_values()[5], 2, protocol)
    r, ok = simulate_push(task)
    assert ok, r.fall_reason
    assert r.stepped and r.root_force_max_N == 0.0


def test_push_static_balance_cannot_survive_but_ipm_can(character):
    """The same 200 N, 0.2 s push on the pelvis from behind: static balance falls, IPM steps."""
    sb = make_controller("static_balance", character)
    r_sb = push(character, sb, force=200.0, direction=0.0, allow_steps=True)
    assert r_sb.fell
    ipm = make_ipm(character, speed=0.0)
    r_ipm = push(character, ipm, force=200.0, direction=0.0, allow_steps=True)
    assert not r_ipm.fell, r_ipm.fall_reason
    assert r_ipm.stepped and ipm.steps >= 1
    assert r_sb.root_force_max_N == 0.0 and r_ipm.root_force_max_N == 0.0


# -- long runs -----------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("speed", [0.5, 1.0])
def test_walks_60s_with_small_speed_error(character, speed):
    c = make_ipm(character, speed=speed)
    r, times, com, _ = run_walk(character, c, 60.0)
    assert not r.fell, r.fall_reason
    assert abs(np.linalg.norm(com[-1] - com[0]) / times[-1] - speed) < 0.15
    assert abs(mean_velocity(times, com, 5.0)[0] - speed) < 0.15
    assert r.root_force_max_N == 0.0


#: 60 s walks that fall with the defaults (docs/ipm.md, speed range): none since cadence_gain
_FALLS_60S: dict[float, str] = {}


@pytest.mark.slow
@pytest.mark.parametrize("speed", [round(0.3 + 0.1 * i, 1) for i in range(14)])
def test_speed_range_60s(character, speed):
    """0.3 to 1.6 m/s: 60 s with no fall, steady speed (last 10 s) within 0.15 m/s."""
    if speed in _FALLS_60S:
        pytest.xfail(_FALLS_60S[speed])
    c = make_ipm(character, speed=speed)
    r, times, com, _ = run_walk(character, c, 60.0)
    assert not r.fell, r.fall_reason
    assert abs(np.linalg.norm(mean_velocity(times, com, 50.0)) - speed) < 0.15


@pytest.mark.slow
@pytest.mark.parametrize("end", [0.3, 1.6])
@pytest.mark.parametrize("height", [1.5, 1.95])
def test_speed_range_ends_on_scaled_bodies(zoo_humanoids, height, end):
    """On the zoo's 1.5 m and 1.95 m humanoids the range is the same Froude speeds (the
    registered limits scale with the leg length, as the parameters do): 60 s at the Froude
    speeds of 0.3 m/s (the slowest walk of the 60 s range; 0 stands) and 1.6 m/s."""
    from mjchar.controllers import registry
    from mjchar.controllers.core.scenarios import walk

    ch = Character(zoo_humanoids[height])
    speed = end * (ch.poses.leg_length() / registry.get("ipm").speed_leg_length) ** 0.5
    r = walk(ch, make_ipm(ch, speed=speed), duration=60.0, seed=0)
    assert not r.fell, r.fall_reason
    assert r.root_force_max_N == 0.0
    assert abs(r.extra["steady_speed_mps"] - speed) < 0.15, r.extra


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_walks_60s_at_1_2_from_seeded_starts(seed):
    """60 s at 5 seeds, at its comparison speed: no fall, no root force, steady speed
    (last 10 s) within 0.15 m/s (measured 1.159 at every seed)."""
    from mjchar.controllers.core.scenarios import walk

    ch = Character()
    r = walk(ch, make_ipm(ch, speed=1.2), duration=60.0, seed=seed)
    assert not r.fell, r.fall_reason
    assert r.root_force_max_N == 0.0
    assert abs(r.extra["steady_speed_mps"] - 1.2) < 0.15, r.extra


@pytest.mark.slow
def test_speed_schedule_slow_fast_slow(character):
    """0.5 -> 1.5 -> 0.5 m/s in one run (commands at 15 and 35 s): no fall, each speed reached."""
    c = make_ipm(character, speed=lambda t: 0.5 if t < 15.0 else 1.5 if t < 35.0 else 0.5)
    r, times, com, _ = run_walk(character, c, 50.0)
    assert not r.fell, r.fall_reason
    for t0, t1, v in ((10.0, 15.0, 0.5), (25.0, 35.0, 1.5), (45.0, 50.0, 0.5)):
        assert abs(np.linalg.norm(mean_velocity(times, com, t0, t1)) - v) < 0.15, (t0, v)


@pytest.mark.slow
@pytest.mark.parametrize("speed, heading", [(1.0, 90.0), (1.1, 90.0), (1.2, 90.0), (1.3, 90.0),
                                            (1.5, 90.0), (1.2, -90.0)])
def test_turns_90_degrees(character, speed, heading):
    """The turn across the human band, left and right (it fell at 1.1-1.3, 1.5, 1.6
    m/s before the stance foot's pressure was kept off its heel edge in turning steps;
    docs/ipm.md)."""
    c = make_ipm(character, speed=speed, heading=lambda t: 0.0 if t < 3.0 else heading)
    r, times, com, yaw = run_walk(character, c, 14.0)
    assert not r.fell, r.fall_reason
    assert abs(math.degrees(yaw[-1]) - heading) < 15.0


@pytest.mark.slow
def test_turns_90_degrees_right_at_1_6_from_a_seeded_start(character):
    """It fell at 7.6 s (a strict xfail) until the feet's measures were held above the human
    band (docs/ipm.md)."""
    from mjchar.controllers.core.scenarios import walk

    c = make_ipm(character, speed=1.6, heading=lambda t: 0.0 if t < 3.0 else -90.0)
    r = walk(character, c, duration=18.0, seed=0)
    assert not r.fell, r.fall_reason


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="at 1.6 m/s the turn is still fragile: this left turn from "
                   "the seeded start falls at 5.9 s (1 of 24 turns of the 1.0-1.6 m/s grid at seed "
                   "0, 0 of 24 at seed 1; docs/ipm.md, stance slip across speeds)")
def test_turns_90_degrees_left_at_1_6_from_a_seeded_start(character):
    from mjchar.controllers.core.scenarios import walk

    c = make_ipm(character, speed=1.6, heading=lambda t: 0.0 if t < 3.0 else 90.0)
    r = walk(character, c, duration=18.0, seed=0)
    assert not r.fell, r.fall_reason


@pytest.mark.slow
@pytest.mark.parametrize("direction", [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0])
def test_survives_200N_push_from_every_direction(character, direction):
    r = push(character, make_ipm(character, speed=0.0), force=200.0, direction=direction,
             allow_steps=True)
    assert survived(r, allow_steps=True), r.fall_reason


def test_step_time_and_stance_knee_follow_the_commanded_speed():
    """Up to speed.slow the slow values (today's walk, unchanged); from speed.fast to
    speed.human_top the human-like ones (longer steps, a stiff stance knee from landing); from
    speed.human_end on the fast ones (quick steps, a soft stance knee easing from its landing
    flexion); linear between; the speeds scale with the body like every speed."""
    p = IPMParams()
    tm, sp, st, hu = p.timing, p.speed, p.stance, p.human
    assert tm.fast_step_time < tm.step_time
    for v in (0.0, 0.5, sp.slow, -0.8):
        assert p.at_speed(v) == (tm.step_time, p.tracking.knee_kp, st.knee_ramp)
        assert p.human_weight(v) == 0.0
    for v in (sp.fast, 1.2, sp.human_top):
        assert p.human_weight(v) == 1.0
        assert p.at_speed(v)[1:] == (hu.stance_knee_kp, hu.stance_knee_ramp)
    assert p.at_speed(sp.fast)[0] == pytest.approx(hu.step_time)
    for v in (sp.human_end, 3.0):
        assert p.human_weight(v) == 0.0
        assert p.at_speed(v)[1:] == (st.fast_knee_kp, st.fast_knee_ramp)
        assert 1 / p.at_speed(v)[0] == pytest.approx(
            1 / tm.fast_step_time + tm.cadence_gain * (v - sp.fast))
    # the cadence grows with speed all the way; the step length up to human_top
    times = [p.at_speed(v)[0] for v in (1.1, 1.2, 1.3, 1.4, 1.5, 1.6)]
    assert all(a > b for a, b in zip(times, times[1:], strict=False))
    lengths = [v * p.at_speed(v)[0] for v in (1.1, 1.2, 1.3)]
    assert all(a < b for a, b in zip(lengths, lengths[1:], strict=False))
    assert 1 / p.at_speed(1.2)[0] == pytest.approx(
        1 / hu.step_time + tm.cadence_gain * (1.2 - sp.fast))
    mid = 0.5 * (sp.slow + sp.fast)
    assert p.human_weight(mid) == pytest.approx(0.5)
    fast_mid = 0.5 * (tm.step_time + tm.fast_step_time)       # the fast band's own blend
    assert p.at_speed(mid)[0] == pytest.approx(fast_mid + 0.5 * (hu.step_time - fast_mid))
    assert p.updated({"stance.knee_kp": 250.0}).at_speed(0.5)[1] == 250.0
    big = p.for_body(2 * 0.878, 140.0)
    assert big.at_speed(sp.fast * math.sqrt(2))[0] == pytest.approx(hu.step_time * math.sqrt(2))
    assert big.human_weight(sp.human_end * math.sqrt(2)) == 0.0
    with pytest.raises(IPMError, match="timing.fast_step_time must be a finite number > 0"):
        p.updated({"timing.fast_step_time": 0.0})
    with pytest.raises(IPMError, match="speed.human_top < speed.human_end"):
        p.updated({"speed.human_top": 1.7, "speed.human_end": 1.6})


def test_parameters_follow_the_body_by_similarity():
    """Every IPM parameter declares its dimension on its field; the body scaling is derived from
    those declarations (each value times its dimension's factor); the tuned body keeps them
    exactly (the same object); and a few declarations are pinned here."""
    from mjchar.controllers.core import param_fields as F
    from mjchar.controllers.core.similarity import similarity_factors
    from mjchar.controllers.walking import ipm_params as P

    dims = {f"{g}.{n}": spec.dimension for g, n, spec in F.leaves(P.IPMParams)}
    assert list(dims) == P.IPMParams.names() and len(dims) == 79
    assert set(dims.values()) <= set(F.SCALED + F.UNSCALED)
    base = P.IPMParams()
    assert base.for_body(P.TUNED_LEG_LENGTH, P.TUNED_MASS) is base
    big = base.for_body(2 * P.TUNED_LEG_LENGTH, 2 * P.TUNED_MASS)
    factor = similarity_factors(2.0, 2.0)
    for name, value in base.flat().items():
        k = factor.get(dims[name], 1.0)
        scaled = big.flat()[name]
        if isinstance(value, tuple):
            assert scaled == tuple(x * k for x in value), name
        elif isinstance(value, float):
            assert scaled == value * k, name
        else:
            assert scaled == value, name
    pinned = {"timing.step_time": "time", "placement.step_width": "length",
              "tracking.hip_kp": "torque_gain", "tracking.hip_kd": "damping_gain",
              "force.max_sagittal": "force", "swing.heights": "length",
              "timing.cadence_gain": "per_length", "force.coronal_pos": "per_length",
              "upper.lean": "rate", "stance.yaw_limit": "torque", "speed.human_end": "speed",
              "speed.acceleration": "acceleration", "placement.clamp": "none",
              "timing.min_phase": "none", "feet.toe_up": "none"}
    assert {n: dims[n] for n in pinned} == pinned
    assert big.timing.step_time == pytest.approx(base.timing.step_time * math.sqrt(2))
    assert big.tracking.hip_kd == pytest.approx(4 * math.sqrt(2) * base.tracking.hip_kd)
    assert big.stance.knee_kp is None  # None (use the swing knee's) stays None


def test_every_parameter_is_declared_with_a_dimension():
    """A parameter group field without a dimension helper is refused when the set is used."""
    import dataclasses

    from mjchar.controllers.core import param_fields as F

    @dataclasses.dataclass(frozen=True)
    class Plain:
        step_time: float = 0.5

    @dataclasses.dataclass(frozen=True)
    class Params:
        timing: Plain = dataclasses.field(default_factory=Plain)

    with pytest.raises(TypeError, match="step_time was not declared with a dimension"):
        F.names(Params)


def test_docs_list_every_parameter_with_its_default():
    """docs/ipm.md's parameter table has a row per parameter, with its default."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "ipm.md").read_text()
    for name, value in IPMParams().flat().items():
        if isinstance(value, tuple):
            shown = "(" + ", ".join(f"{x:g}" for x in value) + ")"
        elif isinstance(value, bool) or value is None:
            shown = {True: "true", False: "false", None: "null"}[value]
        else:
            shown = f"{value:g}" if isinstance(value, float) else repr(value)
        assert f"| `{name}` | {shown} |" in text, name
