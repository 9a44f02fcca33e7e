"""The simulated Character: named access, actuation switch, COM and Jacobians, contacts, pushes,
state save/restore, weld and divergence detection (a small hand-written contract model and the
bundled humanoid)."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from mjchar.controllers.core.base import Action
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.errors import CharacterError, SimulationDiverged
from mjchar.controllers.core.geometry import convex_hull_2d, point_in_polygon_margin


def mini_humanoid_xml() -> str:
    """A small biped written by hand that follows docs/model-contract.md: world-aligned bodies
    named like BVH joints, a free joint ``root``, hinge triplets ``<joint>_z/_x/_y``, knee
    ``<joint>_y``, one position actuator per hinge, foot boxes with sole sites, ``floor``,
    the inactive ``root_weld`` and the ``mjchar`` metadata."""

    def trip(name: str, rng: int) -> str:
        return "".join(f'<joint name="{name}_{a}" type="hinge" axis="{ax}" range="-{rng} {rng}"/>'
                       for a, ax in (("z", "0 0 1"), ("x", "1 0 0"), ("y", "0 1 0")))

    def leg(s: str, y: float) -> str:
        side = "left" if s == "l" else "right"
        return f"""
      <body name="{s}Hip" pos="0 {y} -0.05">{trip(s + 'Hip', 90)}
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.06" mass="8"/>
        <body name="{s}Knee" pos="0 0 -0.4">
          <joint name="{s}Knee_y" type="hinge" axis="0 1 0" range="0 150"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05" mass="4"/>
          <body name="{s}Ankle" pos="0 0 -0.4">{trip(s + 'Ankle', 45)}
            <geom type="box" pos="0.05 0 -0.045" size="0.11 0.045 0.035" mass="1.2"/>
            <site name="{side}_foot" pos="0.05 0 -0.08"/>
          </body>
        </body>
      </body>"""

    joints = {
        "RootJoint": (["root"], "pelvis"),
        "lowerback_torso": ([f"lowerback_torso_{a}" for a in "zxy"], "spine"),
        "lHip": ([f"lHip_{a}" for a in "zxy"], "left_hip"),
        "lKnee": (["lKnee_y"], "left_knee"),
        "lAnkle": ([f"lAnkle_{a}" for a in "zxy"], "left_ankle"),
        "rHip": ([f"rHip_{a}" for a in "zxy"], "right_hip"),
        "rKnee": (["rKnee_y"], "right_knee"),
        "rAnkle": ([f"rAnkle_{a}" for a in "zxy"], "right_ankle"),
    }
    meta = {
        "version": 1, "joint_model": "hinge", "unit_scale": 1.0, "up_axis": "z",
        "basis": [1, 0, 0, 0],
        "joints": {k: {"body": k, "mj_joints": v[0], "order": "zxy" if len(v[0]) == 3 else "y",
                       "role": v[1]} for k, v in joints.items()},
        "roles": {"pelvis": "RootJoint", "spine": ["lowerback_torso"], "left_hip": "lHip",
                  "left_knee": "lKnee", "left_ankle": "lAnkle", "right_hip": "rHip",
                  "right_knee": "rKnee", "right_ankle": "rAnkle"},
        "dropped": [], "fused_into": {},
    }
    gains = {"lowerback_torso": (800, 80, 300), "Hip": (500, 50, 200), "Knee": (500, 50, 200),
             "Ankle": (300, 30, 100)}
    acts = []
    for name, (mjj, _) in joints.items():
        if name == "RootJoint":
            continue
        kp, kv, lim = next(v for k, v in gains.items() if k in name)
        acts += [f'<position name="{j}" joint="{j}" kp="{kp}" kv="{kv}" '
                 f'forcerange="-{lim} {lim}"/>' for j in mjj]
    data = json.dumps(meta).replace('"', "&quot;")
    return f"""<mujoco model="mini">
  <compiler angle="degree"/>
  <option integrator="implicitfast" timestep="0.002"/>
  <default><joint armature="0.05" damping="0"/><geom friction="1 0.005 0.0001"/></default>
  <custom><text name="mjchar" data="{data}"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="20 20 0.1"/>
    <body name="RootJoint" pos="0 0 0.93">
      <freejoint name="root"/>
      <geom type="capsule" fromto="0 -0.09 0 0 0.09 0" size="0.08" mass="10"/>
      <body name="lowerback_torso" pos="0 0 0.12">{trip('lowerback_torso', 45)}
        <geom type="capsule" fromto="0 0 0.05 0 0 0.45" size="0.12" mass="30"/>
        <site name="head" pos="0 0 0.6"/>
      </body>{leg('l', 0.09)}{leg('r', -0.09)}
    </body>
  </worldbody>
  <equality><weld name="root_weld" body1="RootJoint" active="false"/></equality>
  <actuator>{''.join(acts)}</actuator>
</mujoco>"""


@pytest.fixture
def mini() -> Character:
    return Character(mujoco.MjModel.from_xml_string(mini_humanoid_xml()))


@pytest.fixture(scope="module")
def humanoid() -> Character:
    return Character()


def standing(ch: Character) -> np.ndarray:
    return ch.poses.standing()


# -- structure and named access ------------------------------------------------------------------
def test_named_access_follows_the_joint_map(mini):
    assert mini.nq == 24 and mini.nv == 23 and mini.nu == 17
    assert mini.dynamics.mass == pytest.approx(66.4)
    assert len(mini.joint_dofs("lKnee")) == 1
    assert len(mini.joint_dofs("lHip")) == 3
    np.testing.assert_array_equal(mini.joint_dofs("RootJoint"), np.arange(6))
    assert mini.role("left_knee") == "lKnee" and mini.roles("spine") == ["lowerback_torso"]
    np.testing.assert_array_equal(mini.dofs(["left_knee"]), mini.joint_dofs("lKnee"))
    assert mini.dof_names[mini.joint_dofs("lKnee")[0]] == "lKnee_y"
    assert not mini.actuated[mini.root_dofs].any() and mini.actuated.sum() == 17
    # actuator i drives the dof named like it
    for a in range(mini.nu):
        name = mujoco.mj_id2name(mini.model, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
        assert mini.dof_names[mini.actuator_dof[a]] == name


def test_dof_and_body_lookups(mini):
    knee = mini.joint_dofs("lKnee")[0]
    assert mini.dof_qpos[knee] == mini.joint_qpos("lKnee")[0]
    assert mini.hinge_dofs[knee] and not mini.hinge_dofs[mini.root_dofs].any()
    assert (mini.dof_qpos[mini.root_dofs] == -1).all()
    assert mini.dof_body[knee] == mini.body_id("lKnee")
    assert mini.body_parent[mini.body_id("lKnee")] == mini.body_id("lHip")
    assert mini.dof_names[knee] == mujoco.mj_id2name(mini.model, mujoco.mjtObj.mjOBJ_JOINT,
                                                      int(mini.dof_joint[knee]))
    assert {"head", "left_foot", "right_foot"} <= set(mini.site_names)


def test_unknown_names_raise_project_errors(mini):
    with pytest.raises(CharacterError, match="unknown joint 'lElbow'"):
        mini.joint_dofs("lElbow")
    with pytest.raises(CharacterError, match="role"):
        mini.role("left_elbow")
    assert mini.role("left_toe", required=False) is None
    with pytest.raises(CharacterError):
        mini.body_id("nope")
    with pytest.raises(CharacterError):
        Character("/nonexistent/model.xml")
    with pytest.raises(CharacterError):
        mini.set_timestep(-0.01)
    with pytest.raises(CharacterError):
        mini.reset(np.zeros(3))


def test_bundled_humanoid_has_roles_feet_and_sites(humanoid):
    for role in ("pelvis", "left_hip", "left_knee", "left_ankle", "left_toe", "right_hip",
                 "right_knee", "right_ankle", "right_toe"):
        assert humanoid.role(role) in humanoid.joint_names
    assert humanoid.dynamics.mass == pytest.approx(70.0, rel=1e-4)
    assert len(humanoid.contacts.foot_bodies) == 4  # ankles and toes
    assert humanoid.actuation.position_actuators.all()
    left, right = humanoid.contacts.foot_sites()
    assert left[1] > right[1]  # left is +y


# -- actuation -----------------------------------------------------------------------------------
def test_actuation_switch_rewrites_gains_and_back(mini):
    kp, kd = mini.actuation.native_gains()
    assert kp[mini.joint_dofs("lKnee")[0]] == 500 and kd[mini.joint_dofs("lKnee")[0]] == 50
    gain0 = mini.model.actuator_gainprm.copy()
    bias0 = mini.model.actuator_biasprm.copy()
    mini.actuation.set_mode("torque")
    assert np.all(mini.model.actuator_gainprm[:, 0] == 1)
    assert np.all(mini.model.actuator_biasprm == 0)
    # a torque command is a torque, clamped to the limit
    mini.reset(standing(mini))
    tau = np.zeros(mini.nv)
    knee = mini.joint_dofs("lKnee")[0]
    hip = mini.joint_dofs("lHip")[2]
    tau[knee], tau[hip] = 50.0, 1000.0
    mini.actuation.apply(Action(torque=tau))
    mujoco.mj_fwdActuation(mini.model, mini.data)
    assert mini.data.qfrc_actuator[knee] == pytest.approx(50.0)
    assert mini.data.qfrc_actuator[hip] == pytest.approx(200.0)  # torque limit
    mini.actuation.set_mode("native")
    np.testing.assert_array_equal(mini.model.actuator_gainprm, gain0)
    np.testing.assert_array_equal(mini.model.actuator_biasprm, bias0)
    with pytest.raises(CharacterError):
        mini.actuation.set_mode("magic")


def test_native_gains_can_be_rewritten_and_default_table_kept(mini):
    kp, kd = mini.actuation.native_gains()
    mini.actuation.set_native_gains(kp * 2, kd * 3)
    kp2, kd2 = mini.actuation.native_gains()
    np.testing.assert_allclose(kp2, kp * 2)
    np.testing.assert_allclose(kd2, kd * 3)
    np.testing.assert_allclose(mini.actuation.default_gains()[0], kp)


def test_root_rows_of_an_action_are_an_external_wrench(mini):
    mini.actuation.set_mode("torque")
    mini.reset(standing(mini))
    tau = np.zeros(mini.nv)
    tau[:3] = [10.0, -20.0, 30.0]
    # the rotational rows are in the root frame: a world torque R^T-rotated
    tau[3:6] = mini.state.root_rotation.T @ [0.0, 0.0, 5.0]
    mini.actuation.apply(Action(torque=tau))
    np.testing.assert_allclose(mini.actuation.root_wrench, [10, -20, 30, 0, 0, 5], atol=1e-12)
    np.testing.assert_allclose(mini.data.qfrc_applied[:3], [10, -20, 30])
    mini.actuation.apply(Action(torque=np.zeros(mini.nv)))
    np.testing.assert_array_equal(mini.actuation.root_wrench, np.zeros(6))


@pytest.mark.parametrize("mode", ["native", "torque"])
def test_an_oversized_feedforward_torque_is_applied_at_the_limit(mode):
    """5000 N m asked of a knee (limit: its actuator's forcerange): the simulation applies the
    limit, feed-forward on top of native PD included; with the limits lifted it applies it
    all."""
    ch = Character()
    knee = int(ch.joint_dofs(ch.role("left_knee"))[0])
    a = int(np.flatnonzero(ch.actuator_dof == knee)[0])
    limit = float(ch.actuation.torque_limits()[knee])
    assert 0 < limit < 5000

    def applied(lift: bool) -> tuple[float, float]:
        ch.actuation.set_torque_limits(not lift)
        ch.actuation.set_mode(mode)
        q = standing(ch)
        ch.reset(q)
        tau = np.zeros(ch.nv)
        tau[knee] = 5000.0
        target = q[ch.actuator_qpos] if mode == "native" else None
        ch.step(Action(torque=tau, target=target))
        d = ch.data
        return float(d.qfrc_actuator[knee] + d.qfrc_applied[knee]), float(d.actuator_force[a])

    total, force = applied(lift=False)
    assert total == pytest.approx(limit, rel=1e-9) and force == pytest.approx(limit, rel=1e-9)
    total, _ = applied(lift=True)
    assert total > 4000.0
    ch.actuation.set_torque_limits(True)


# -- centre of mass, Jacobians, mass matrix ------------------------------------------------------
def test_com_velocity_and_jacobian_match_finite_differences(humanoid):
    rng = np.random.default_rng(3)
    q = standing(humanoid)
    q[humanoid.root_qpos[2]] += 0.5  # in the air
    v = rng.normal(0, 0.5, humanoid.nv)
    humanoid.reset(q, v)
    m = humanoid.model
    com = (m.body_mass[:, None] * humanoid.data.xipos).sum(0) / m.body_mass.sum()
    np.testing.assert_allclose(humanoid.state.com(), com, atol=1e-12)
    J = humanoid.dynamics.com_jacobian()
    assert J.shape == (3, humanoid.nv)
    h = 1e-6
    humanoid.reset(humanoid.dynamics.integrate(q, v, h), v)
    fd = (humanoid.state.com() - com) / h
    np.testing.assert_allclose(J @ v, fd, atol=1e-4)
    humanoid.reset(q, v)
    np.testing.assert_allclose(humanoid.state.com_velocity(), J @ v, atol=1e-12)


def test_subtree_com_jacobian_matches_finite_differences(humanoid):
    """``com_jacobian(body)``: the centre of mass of a leg (its hip's subtree), into ``out``."""
    rng = np.random.default_rng(4)
    q = standing(humanoid)
    v = rng.normal(0, 0.5, humanoid.nv)
    hip = humanoid.body_id(humanoid.role("left_hip"))
    humanoid.reset(q, v)
    c0 = humanoid.state.subtree_coms[hip].copy()
    out = np.full((3, humanoid.nv), np.nan)
    J = humanoid.dynamics.com_jacobian(hip, out=out)
    assert J is out
    np.testing.assert_array_equal(humanoid.dynamics.com_jacobian(humanoid.role("left_hip")), J)
    h = 1e-6
    humanoid.reset(humanoid.dynamics.integrate(q, v, h), v)
    np.testing.assert_allclose(J @ v, (humanoid.state.subtree_coms[hip] - c0) / h, atol=1e-4)
    leg = humanoid.dynamics.subtree_mass(hip)
    assert 0.1 * humanoid.dynamics.mass < leg < 0.25 * humanoid.dynamics.mass
    np.testing.assert_array_equal(humanoid.dynamics.gravity, [0.0, 0.0, -9.81])


def test_sparse_mass_solve_equals_dense(humanoid):
    rng = np.random.default_rng(0)
    humanoid.reset(standing(humanoid), rng.normal(0, 0.3, humanoid.nv))
    M = humanoid.dynamics.mass_matrix()
    d = rng.uniform(0, 1, humanoid.nv)
    y = rng.normal(size=humanoid.nv)
    np.testing.assert_allclose(humanoid.dynamics.solve_mass(y, d),
                               np.linalg.solve(M + np.diag(d), y), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(M, M.T, atol=1e-12)


def test_sparse_mass_solve_with_a_joint_block_equals_dense(humanoid):
    """``solve_mass_plus``: ``M`` plus a diagonal and a symmetric block on one joint's hinges,
    several right-hand sides at once, as the dense solve."""
    rng = np.random.default_rng(1)
    humanoid.reset(standing(humanoid), rng.normal(0, 0.3, humanoid.nv))
    dyn = humanoid.dynamics
    M = dyn.mass_matrix()
    d = rng.uniform(0, 1, humanoid.nv)
    dofs = humanoid.joint_dofs(humanoid.role("left_ankle"))
    a = rng.normal(size=(len(dofs), len(dofs)))
    B = a @ a.T
    add = dyn.mass_addition(d)
    adr = dyn.block_addresses(dofs)
    low = np.tril_indices(len(dofs))
    add[adr[low]] += B[low]
    Y = rng.normal(size=(3, humanoid.nv))
    dense = M + np.diag(d)
    dense[np.ix_(dofs, dofs)] += B
    np.testing.assert_allclose(dyn.solve_mass_plus(Y, add), np.linalg.solve(dense, Y.T).T,
                               rtol=1e-9, atol=1e-12)
    other = humanoid.joint_dofs(humanoid.role("right_ankle"))
    with pytest.raises(ValueError, match="not on one branch"):
        dyn.block_addresses([int(dofs[0]), int(other[0])])


# -- contacts ------------------------------------------------------------------------------------
def test_feet_contacts_and_support_polygon(humanoid):
    humanoid.reset(standing(humanoid))
    humanoid.actuation.set_mode("native")
    for _ in range(50):  # settle on the floor
        humanoid.step()
    assert humanoid.contacts.feet() == (True, True)
    assert humanoid.contacts.non_foot() == []
    poly = humanoid.contacts.support_polygon()
    assert len(poly) >= 4
    left, right = humanoid.contacts.foot_sites()
    mid = 0.5 * (left + right)
    assert point_in_polygon_margin(mid[:2], poly) > 0.03
    # the polygon spans both feet
    assert poly[:, 1].max() > left[1] and poly[:, 1].min() < right[1]
    q = standing(humanoid)
    q[humanoid.root_qpos[2]] += 0.3
    humanoid.reset(q)
    assert humanoid.contacts.feet() == (False, False)
    assert humanoid.contacts.support_polygon().shape == (0, 2)


def test_foot_forces_carry_the_weight(humanoid):
    """Standing still on both feet, the floor's normal forces under them add up to the weight;
    reading them changes nothing (the next step recomputes what they solve)."""
    humanoid.reset(standing(humanoid))
    humanoid.actuation.set_mode("native")
    for _ in range(500):
        humanoid.step()
    s = humanoid.state.get()
    forces = humanoid.contacts.foot_forces()
    weight = humanoid.dynamics.mass * 9.81
    assert forces.min() > 0.3 * weight
    assert forces.sum() == pytest.approx(weight, rel=0.05)
    humanoid.step()
    after = humanoid.state.qpos.copy()
    humanoid.state.set(s)
    humanoid.step()
    np.testing.assert_array_equal(humanoid.state.qpos, after)
    q = standing(humanoid)
    q[humanoid.root_qpos[2]] += 0.3
    humanoid.reset(q)
    np.testing.assert_array_equal(humanoid.contacts.foot_forces(), [0.0, 0.0])


def test_lying_body_counts_as_non_foot_contact(mini):
    q = mini.poses.rest()
    q[3:7] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]  # on its side
    mini.reset(mini.poses.on_floor(q, clearance=-0.005))
    assert "RootJoint" in mini.contacts.non_foot()


def test_contact_tables_agree_with_the_contact_list(humanoid):
    """``feet()`` and the fall test read geom-pair tables built at start-up: on poses from
    standing to lying they say what the contact list says (the floor's other geom, its body,
    its side)."""
    c = humanoid.contacts
    rng = np.random.default_rng(3)
    falls = 0
    for _ in range(120):
        q = humanoid.dynamics.integrate(standing(humanoid), rng.normal(0, 0.6, humanoid.nv), 1.0)
        q[humanoid.root_qpos[2]] += rng.uniform(-0.8, 0.05)
        humanoid.reset(q)
        n = humanoid.data.ncon
        g = humanoid.data.contact.geom[:n]
        other = np.where(g[:, 0] == c.floor_geom, g[:, 1],
                         np.where(g[:, 1] == c.floor_geom, g[:, 0], -1))
        bodies = humanoid.model.geom_bodyid[other[other >= 0]]
        left = {humanoid.body_id(humanoid.role(f"left_{p}")) for p in ("ankle", "toe")}
        right = {humanoid.body_id(humanoid.role(f"right_{p}")) for p in ("ankle", "toe")}
        assert c.feet() == (bool(left & set(bodies)), bool(right & set(bodies)))
        assert c.any_non_foot() == bool(set(bodies) - left - right) == bool(c.non_foot())
        falls += c.any_non_foot()
    assert 10 < falls < 110  # both kinds of pose were seen


def test_convex_hull_and_margin():
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [1, 0], [0.5, 0]])
    hull = convex_hull_2d(pts)
    assert len(hull) == 4
    a, b = hull[1] - hull[0], hull[2] - hull[1]
    assert a[0] * b[1] - a[1] * b[0] > 0  # counter-clockwise
    assert point_in_polygon_margin([0.5, 0.5], hull) == pytest.approx(0.5)
    assert point_in_polygon_margin([0.5, 0.9], hull) == pytest.approx(0.1)
    assert point_in_polygon_margin([2.0, 0.5], hull) == pytest.approx(-1.0)
    assert point_in_polygon_margin([0, 0], np.zeros((0, 2))) == -np.inf
    assert len(convex_hull_2d(np.array([[0, 0], [1, 1], [2, 2]]))) == 2


# -- pushes --------------------------------------------------------------------------------------
def test_push_delivers_its_impulse_and_only_in_its_window(mini):
    """Zero gravity, in the air: the COM velocity change equals force x duration / mass."""
    mini.model.opt.gravity[:] = 0
    q = standing(mini)
    q[mini.root_qpos[2]] += 1.0
    mini.reset(q)
    mini.actuation.set_mode("torque")
    mini.pushes.add("RootJoint", [30.0, -12.0, 0.0], duration=0.1, start=0.05)
    seen = []
    for _ in range(150):
        mini.step(Action(torque=np.zeros(mini.nv)))
        seen.append((mini.time, mini.pushes.active_force()[0]))
    on = [t for t, f in seen if f != 0]
    assert min(on) == pytest.approx(0.052, abs=1e-9) and max(on) == pytest.approx(0.15)
    assert len(on) == 50
    # (armature adds rotor inertia without a reaction: momentum is conserved to ~1e-4)
    np.testing.assert_allclose(mini.state.com_velocity(), [30 * 0.1 / 66.4, -12 * 0.1 / 66.4, 0],
                               rtol=1e-3, atol=1e-5)
    with pytest.raises(CharacterError):
        mini.pushes.add("RootJoint", [1.0, 2.0], 0.1)
    with pytest.raises(CharacterError):
        mini.pushes.add("RootJoint", [1.0, 0, 0], -1)


def test_multi_step_with_push_equals_single_steps(mini):
    q = standing(mini)
    runs = []
    for n in (1, 7):
        mini.reset(q)
        mini.pushes.add("RootJoint", [40.0, 0, 0], duration=0.05, start=0.02)
        for _ in range(140 // n):
            mini.step(None, n)
        runs.append(mini.state.qpos.copy())
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-12)


# -- state -----------------------------------------------------------------------------------
def test_get_set_state_replays_exactly(humanoid):
    humanoid.reset(standing(humanoid))
    humanoid.actuation.set_mode("native")
    rng = np.random.default_rng(1)
    target = rng.normal(0, 0.2, humanoid.nu)
    for _ in range(20):
        humanoid.step(Action(target=target))
    s = humanoid.state.get()
    t0 = humanoid.time
    for _ in range(30):
        humanoid.step(Action(target=target))
    a = humanoid.state.qpos.copy()
    humanoid.state.set(s)
    assert humanoid.time == t0
    for _ in range(30):
        humanoid.step(Action(target=target))
    np.testing.assert_array_equal(humanoid.state.qpos, a)


def test_state_views_follow_the_simulation_and_cannot_be_written(mini):
    st = mini.state
    mini.reset(standing(mini))
    mini.actuation.set_mode("torque")
    for _ in range(5):
        mini.step(Action(torque=np.zeros(mini.nv)))
    d = mini.data
    np.testing.assert_array_equal(st.qpos, d.qpos)
    np.testing.assert_array_equal(st.qvel, d.qvel)
    b = mini.body_id("lKnee")
    np.testing.assert_array_equal(st.body_rotations[b], d.xmat[b].reshape(3, 3))
    np.testing.assert_array_equal(st.body_angular_velocities[b], d.cvel[b, :3])
    np.testing.assert_array_equal(st.site_positions, d.site_xpos)
    np.testing.assert_array_equal(st.root_position, d.xpos[mini.root_body])
    np.testing.assert_array_equal(st.joint_positions(), d.xpos[mini.joint_bodies])
    with pytest.raises(ValueError):
        st.qpos[0] = 1.0
    with pytest.raises(ValueError):
        st.body_positions[b] = 0.0


def test_full_physics_state_and_warm_start(humanoid):
    """``get_physics`` is what a batched rollout starts from; ``clear_warm_start`` makes the
    next step match such a rollout."""
    from mjchar.controllers.sampling.rollout import get_state

    humanoid.reset(standing(humanoid))
    humanoid.actuation.set_mode("native")
    for _ in range(20):
        humanoid.step()
    np.testing.assert_array_equal(humanoid.state.get_physics(),
                                  get_state(humanoid.model, humanoid.data))
    assert humanoid.data.qacc_warmstart.any()
    humanoid.state.clear_warm_start()
    assert not humanoid.data.qacc_warmstart.any()


def test_pose_kinematics_leave_the_state_alone(humanoid):
    q = standing(humanoid)
    q[humanoid.root_qpos[2]] += 0.2
    humanoid.reset(standing(humanoid))
    before = humanoid.state.body_positions.copy()
    kin = humanoid.poses.kinematics(q)
    np.testing.assert_array_equal(humanoid.state.body_positions, before)
    humanoid.reset(q)
    st = humanoid.state
    np.testing.assert_allclose(kin.body_positions, st.body_positions, atol=1e-12)
    np.testing.assert_allclose(kin.body_rotations, st.body_rotations, atol=1e-12)
    np.testing.assert_allclose(kin.joint_axes, st.joint_axes, atol=1e-12)
    np.testing.assert_allclose(kin.joint_anchors, st.joint_anchors, atol=1e-12)
    np.testing.assert_allclose(kin.site_positions, st.site_positions, atol=1e-12)
    np.testing.assert_array_equal(humanoid.poses.rest(), humanoid.model.qpos0)
    dofs = humanoid.joint_dofs(humanoid.role("left_knee"))
    lo, hi = humanoid.poses.dof_limits(dofs)[0]
    assert lo < hi


def test_body_and_site_offsets_are_the_rest_poses_bones(humanoid):
    # model constants in the parent's frame: at rest (world-aligned bodies, contract) a body's
    # offset is its origin's position relative to its parent's, a site's relative to its body's
    ch = humanoid
    rest = ch.poses.kinematics(ch.poses.rest())
    for name in ("lKnee", ch.role("right_ankle")):
        b = ch.body_id(name)
        off = ch.poses.body_offset(name)
        assert off.shape == (3,)
        np.testing.assert_array_equal(off, ch.poses.body_offset(b))
        np.testing.assert_allclose(off, rest.body_positions[b]
                                   - rest.body_positions[ch.body_parent[b]], atol=1e-12)
    s = ch.site_id("left_foot")
    body, pos = ch.poses.site_offset(s)
    assert body == ch.body_id(ch.role("left_ankle"))
    np.testing.assert_allclose(pos, rest.site_positions[s] - rest.body_positions[body],
                               atol=1e-12)
    pos[:] = 0.0  # copies: the model is untouched
    off[:] = 0.0
    assert np.linalg.norm(ch.poses.site_offset(s)[1]) > 0
    assert np.linalg.norm(ch.poses.body_offset(ch.role("right_ankle"))) > 0


def test_weld_holds_the_root_where_it_is(mini):
    q = standing(mini)
    q[mini.root_qpos[2]] += 0.2
    q[0] += 0.3
    mini.reset(q)
    mini.actuation.weld_root(True)
    assert mini.data.eq_active[mujoco.mj_name2id(mini.model, mujoco.mjtObj.mjOBJ_EQUALITY,
                                                 "root_weld")]
    mini.actuation.set_mode("torque")
    for _ in range(500):
        mini.step(Action(torque=np.zeros(mini.nv)))
    assert np.linalg.norm(mini.state.root_position - q[:3]) < 0.01
    mini.actuation.weld_root(False)
    for _ in range(200):
        mini.step(Action(torque=np.zeros(mini.nv)))
    assert mini.state.root_height < q[2] - 0.1  # falls once released


# -- divergence ----------------------------------------------------------------------------------
def test_exploding_velocity_raises_simulation_diverged(mini):
    v = np.zeros(mini.nv)
    v[mini.joint_dofs("lKnee")[0]] = 500.0
    with pytest.raises(SimulationDiverged, match="velocity"):
        mini.reset(standing(mini), v)
    mini.reset(standing(mini))
    mini.actuation.set_mode("torque")
    tau = np.zeros(mini.nv)
    tau[0] = np.nan  # a NaN root force
    with pytest.raises(SimulationDiverged) as e:
        for _ in range(5):
            mini.step(Action(torque=tau))
    assert e.value.time >= 0


def test_bad_actions_are_refused_whatever_their_form(mini):
    """The per-step finiteness test (one sum of absolute values, numpy's test when that is not
    finite) refuses NaN and infinite torques and targets, huge finite ones included, and takes
    targets of any float type or layout."""
    mini.reset(standing(mini))
    mini.actuation.set_mode("native")
    u = np.zeros(mini.nu)
    for bad in (np.nan, np.inf, -np.inf):
        t = u.copy()
        t[-1] = bad
        with pytest.raises(SimulationDiverged, match="target"):
            mini.step(Action(target=t))
    huge = np.full(mini.nu, 1e308)  # finite, though their sum is not
    mini.actuation.apply(Action(target=huge))
    np.testing.assert_array_equal(mini.data.ctrl, huge)
    mini.actuation.apply(Action(target=np.ones(mini.nu, dtype=np.float32)))
    np.testing.assert_array_equal(mini.data.ctrl, np.ones(mini.nu))
    strided = np.zeros(2 * mini.nu)[::2]
    mini.actuation.apply(Action(target=strided))
    mini.actuation.set_mode("torque")
    tau = np.zeros(mini.nv)
    tau[mini.actuator_dof[0]] = -np.inf
    with pytest.raises(SimulationDiverged, match="torque"):
        mini.step(Action(torque=tau))


def test_ik_lowers_pelvis_with_feet_in_place(humanoid):
    q = standing(humanoid)
    humanoid.reset(q)
    feet = [humanoid.role(f"{s}_ankle") for s in ("left", "right")]
    state = humanoid.state
    targets = [(f, *humanoid.poses.body_pose(q, f)) for f in feet]
    dofs = humanoid.dofs(["left_hip", "left_knee", "left_ankle", "right_hip", "right_knee",
                          "right_ankle"])
    q2 = q.copy()
    q2[humanoid.root_qpos[2]] -= 0.1
    for s in ("left", "right"):
        q2[humanoid.joint_qpos(humanoid.role(f"{s}_knee"))] = 0.2
    sol = humanoid.poses.solve_ik(q2, targets, dofs)
    humanoid.reset(sol)
    for f, p, _ in targets:
        np.testing.assert_allclose(state.body_positions[humanoid.body_id(f)], p, atol=1e-4)
    assert humanoid.state.root_height == pytest.approx(q[2] - 0.1)
