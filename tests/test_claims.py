"""The claims tier: every figure README.md states, asserted at the protocol the README states.

Run with ``python -m pytest -m claims`` (CI runs it with the slow tier after the default one,
on both cores: ``-n 2``). Each test names the README line it backs; ``tests/test_readme_claims.py``
checks that every number in the README is covered by one of them and that the README's numbers
are the bounds below. The protocols are the README's: pushes of 0.2 s at 4 phases of the stride
(walkers) or 4 moments (standing controllers) x 2 seeds in the four directions, at every force
in 50 N steps up to the figure; walks from the standing pose; the clips' full length.

The bounds hold on any machine of the reference kind: each is at least 10 % (or the spread
measured over seeds, whichever is larger) away from every value measured, on this machine and
on another (docs/claims.md gives the commands, seeds, values and margins).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import assert_no_root_help, shared_clip

from mjchar import bvh
from mjchar.bvh.gait import analyse, analyse_clip
from mjchar.controllers import Character, MotionRecorder, RunSpec, run
from mjchar.controllers.core.scenarios.push_search import PushProtocol, survival_rates

pytestmark = pytest.mark.claims

DIRECTIONS = ("forward", "left", "backward", "right")
README = Path(__file__).resolve().parents[1] / "README.md"

# -- the bounds (README.md states each; tests/test_readme_claims.py compares) -------------------
#: hand_of_god tracks walk60 within (cm)
HAND_OF_GOD_WALK60_CM = 2.0
#: static_balance stands this long (s) under random pushes of RANDOM_PUSH_N
STAND_S, RANDOM_PUSH_N = 30.0, 10.0
#: pushes (N) survived in every direction at every force in PUSH_STEP_N steps up to it
STATIC_BALANCE_PUSH_N, SIMBICON_PUSH_N, IPM_PUSH_N, PUSH_STEP_N = 100.0, 150.0, 150.0, 50.0
#: walks this long (s); IPM's steady speed at a commanded IPM_SPEED_MPS within IPM_SPEED_TOL
WALK_S, IPM_SPEED_MPS, IPM_SPEED_TOL = 60.0, 1.0, 0.15
#: the saved SAMCON and CMA-ES trajectories replay walk60 (the clip itself) within (cm)
SAMCON_REPLAY_CM, CMAES_REPLAY_CM = 5.0, 4.0
#: the MPC tracks walk60 within (cm), at each of MPC_SEEDS
MPC_WALK60_CM, MPC_SEEDS = 4.0, (0, 1, 2)
#: the bundled walk60 policy tracks its looped clip this long (s) within (cm); it was learned
#: in POLICY_LEARN_MINUTES on POLICY_LEARN_CORES cores (its file says how long it took)
POLICY_LOOP_S, POLICY_LOOP_CM, POLICY_LEARN_MINUTES, POLICY_LEARN_CORES = 20.0, 6.0, 60, 2
#: the gait table's columns and their tolerances (the spread over seeds, docs/claims.md)
GAIT_COLUMNS = ("cadence /min", "step m", "width m", "lean deg", "knee deg", "slip cm/step")
GAIT_TOLERANCE = (8.0, 0.02, 0.01, 0.2, 1.5, 0.3)


def _protocol(force: float) -> PushProtocol:
    """The README's push protocol up to one force: 0.2 s, 4 phases or moments x seeds 0 and 1,
    every direction, 5 s after the push (walkers: in the first stride after 4 s), at every force
    of 50, 100, ... N up to ``force`` (survival is not monotone in the force)."""
    return PushProtocol.grid(float(force), PUSH_STEP_N, phases=4, seeds=(0, 1))


def _survives_everywhere(run_spec, force: float) -> None:
    """Every run at every force up to ``force`` survives, in every direction."""
    rates = survival_rates(run_spec, _protocol(force), processes=1)
    assert not rates.falls_unpushed, rates.summary()
    assert {d: rates.largest_100_N[d] for d in DIRECTIONS} == dict.fromkeys(DIRECTIONS, force), \
        rates.summary()


# "On the bundled humanoid (1.63 m, 70 kg)"
def test_the_bundled_humanoid_is_1_63_m_and_70_kg():
    ch = Character()
    assert round(ch.info.extra["height"], 2) == 1.63
    assert round(ch.dynamics.mass) == 70


# hand_of_god: "tracks walk60 within 2 cm"
def test_hand_of_god_tracks_walk60():
    r = run("hand_of_god", "track", motion=shared_clip("walk60.bvh"))
    assert not r.fell and r.tracking_error_m < HAND_OF_GOD_WALK60_CM / 100
    assert r.root_force_mean_N > 0  # the hand of god at work


# static_balance: "stands 30 s under 10 N random pushes"
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_static_balance_stands_30_s_under_10_N_random_pushes(seed):
    r = run("static_balance", "random-push", duration=STAND_S, seed=seed)
    assert r.push_N == RANDOM_PUSH_N and r.sim_time_s == pytest.approx(STAND_S, abs=0.01)
    assert not r.fell
    assert_no_root_help(r)


# static_balance: "survives 100 N pushes in every direction"
def test_static_balance_survives_100_N_pushes_in_every_direction():
    _survives_everywhere(RunSpec("static_balance"), STATIC_BALANCE_PUSH_N)


# simbicon: "walks 60 s in either gait"
@pytest.mark.parametrize("gait", ["walk", "natural"])
def test_simbicon_walks_60_s_in_either_gait(gait):
    r = run("simbicon", "walk", gait=gait, duration=WALK_S)
    assert not r.fell and r.sim_time_s == pytest.approx(WALK_S, abs=0.01)
    assert_no_root_help(r)
    assert r.distance_m > 30.0


# simbicon: "the walk gait survives 150 N pushes in every direction while walking"
def test_simbicon_walk_gait_survives_pushes_while_walking():
    _survives_everywhere(RunSpec("simbicon", options={"gait": "walk"}), SIMBICON_PUSH_N)


# ipm: "walks 60 s at a commanded 1.0 m/s within 0.15 m/s"
def test_ipm_walks_60_s_at_1_m_s_within_0_15():
    r = run("ipm", "walk", speed=IPM_SPEED_MPS, duration=WALK_S, steady_window=10.0)
    assert not r.fell
    assert_no_root_help(r)
    assert abs(r.extra["steady_speed_mps"] - IPM_SPEED_MPS) <= IPM_SPEED_TOL


# ipm: "recovers 150 N pushes by stepping"
def test_ipm_recovers_150_N_pushes_by_stepping():
    _survives_everywhere(RunSpec("ipm"), IPM_PUSH_N)


# samcon_replay, cmaes_replay: "replay walk60 within 5 cm and 4 cm"
@pytest.mark.parametrize("name,bar_cm", [("samcon_replay", SAMCON_REPLAY_CM),
                                         ("cmaes_replay", CMAES_REPLAY_CM)])
def test_saved_trajectories_replay_walk60(name, bar_cm):
    """Measured against the clip walk60 itself (its model kinematics, as ``mjchar run mpc``
    measures), not the reference the optimiser stored in the trajectory file."""
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    built = RunSpec(name, "track").build()
    ch, replay = built.character, built.controller
    assert replay.trajectory.source_motion.endswith("walk60.bvh")
    clip = ReferenceMotion(ch.model, bvh.load(shared_clip("walk60.bvh")), info=ch.info)
    r = replay.play(ch, reference=clip)
    assert not r.fell and r.tracking_error_m < bar_cm / 100
    assert_no_root_help(r)


# mpc: "tracks walk60 within 4 cm"
@pytest.mark.parametrize("seed", MPC_SEEDS)
def test_mpc_tracks_walk60(seed):
    r = RunSpec("mpc", "track", motion=shared_clip("walk60.bvh"), options={"seed": seed}).execute()
    assert not r.fell and r.tracking_error_m < MPC_WALK60_CM / 100
    assert_no_root_help(r)


# policy: "tracks looped walk60 for 20 s within 6 cm", "learned in one hour on 2 cores"
def test_the_bundled_policy_tracks_looped_walk60():
    """docs/learning.md, "Against the bars": no fall, the mean joint error under 6 cm (3.2 cm
    measured), no root force; and the file says it was learned within the hour, on the
    cores and with the stages the README states."""
    from mjchar.controllers.learned import find_policy
    from mjchar.perf.policy import loop

    r = loop("walk60", duration=POLICY_LOOP_S)
    assert not r["fell"] and r["sim_s"] == pytest.approx(POLICY_LOOP_S, abs=0.05)
    assert r["tracking_error_m"] < POLICY_LOOP_CM / 100
    assert r["root_force_max_N"] == 0.0
    training = find_policy("walk60").meta["training"]
    assert training["options"]["minutes"] <= POLICY_LEARN_MINUTES
    assert training["wall_s"] <= 60 * POLICY_LEARN_MINUTES
    assert "PPO" in training["method"] and "DAgger" in training["method"]


# the gait table: "at 1.2 m/s | cadence | step | width | lean | knee | slip", three rows and
# the tolerances, all read from README.md
def readme_gait_table() -> dict[str, tuple[float, ...]]:
    """The README's gait table: ``{row label: (six figures)}``, the tolerance row included as
    ``"tolerance"`` (its figures without the +-)."""
    text = README.read_text()
    header = "| at 1.2 m/s | " + " | ".join(GAIT_COLUMNS) + " |"
    assert header in text, "README.md's gait table header changed"
    rows = {}
    for line in text[text.index(header):].splitlines()[2:]:
        if not line.startswith("|"):
            break
        label, *cells = [c.strip() for c in line.strip("|").split("|")]
        key = "tolerance" if label.startswith("tolerance") else label
        rows[key] = tuple(float(re.sub(r"^(\+-|±)", "", c)) for c in cells)
    return rows


#: README row label -> how the row is measured
GAIT_ROWS = {"SIMBICON natural": ("simbicon", {"gait": "natural"}), "IPM stepping": ("ipm", {}),
             "walk60 (mocap)": None}


def _row(stats) -> tuple:
    return (stats.cadence_spm, stats.step_length_m, stats.step_width_m, stats.trunk_lean_deg,
            stats.knee_flexion_deg, 100.0 * stats.stance_slip_m)


def _assert_row(label: str, measured: tuple) -> None:
    table = readme_gait_table()
    printed, tol = table[label], table["tolerance"]
    off = {c: (round(m, 4), p) for c, m, p, t in zip(GAIT_COLUMNS, measured, printed, tol,
                                                      strict=True) if abs(m - p) > t}
    assert not off, f"{label}: measured vs README beyond the tolerance: {off}"


@pytest.mark.parametrize("label", ["SIMBICON natural", "IPM stepping"])
def test_the_walkers_gait_figures_at_1_2_m_s(label):
    """As ``mjchar gait NAME --speed 1.2``: 20 s from the standing pose, analysed from 3 s."""
    from mjchar.controllers.core.builder import execute

    name, extra = GAIT_ROWS[label]
    recorder = MotionRecorder()
    built = RunSpec(name, "walk", options={"speed": 1.2, **extra},
                    scenario_options={"duration": 20.0}).build(frame_callback=recorder)
    result = execute(built)
    ch = built.character
    stats = analyse(ch.model, recorder.times, recorder.qpos, start=3.0, end=result.fall_time_s,
                    info=ch.info)
    assert not result.fell
    _assert_row(label, _row(stats))


def test_walk60s_gait_figures():
    _assert_row("walk60 (mocap)", _row(analyse_clip(shared_clip("walk60.bvh"))))
