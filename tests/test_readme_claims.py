"""Every number README.md states is backed by a test of the claims tier (``tests/test_claims.py``,
and the tests of ``tests/test_real_*.py`` marked ``claims``), with that test's bound.

:data:`CLAIMS` maps each figure-bearing phrase of the README to the claims test that asserts it;
this (fast) test fails when the README gains a number no phrase covers, when a listed phrase is
no longer in the README, or when its test is gone. :data:`BOUNDS` reads the numbers of each
claim from the README and compares them with the bounds the tests use (module-level constants),
so a figure changed on one side only fails. Numbers that are not claims about the software
(versions, years of the cited papers, counts in commands) are listed in :data:`NOT_CLAIMS` with
the reason.
"""

from __future__ import annotations

import re
from pathlib import Path

import test_claims as C
import test_real_ipm as RI
import test_real_simbicon as RS

README = Path(__file__).resolve().parents[1] / "README.md"

#: README phrase -> the claims test that asserts every number in it
CLAIMS = {
    "On the bundled humanoid (1.63 m, 70 kg)": C.test_the_bundled_humanoid_is_1_63_m_and_70_kg,
    "tracks walk60 within 2 cm": C.test_hand_of_god_tracks_walk60,
    "stands 30 s under 10 N random pushes":
        C.test_static_balance_stands_30_s_under_10_N_random_pushes,
    "survives 100 N pushes in every direction":
        C.test_static_balance_survives_100_N_pushes_in_every_direction,
    "walks 60 s in either gait": C.test_simbicon_walks_60_s_in_either_gait,
    "survives 150 N pushes in every direction while walking":
        C.test_simbicon_walk_gait_survives_pushes_while_walking,
    "walks 60 s at a commanded 1.0 m/s within 0.15 m/s": C.test_ipm_walks_60_s_at_1_m_s_within_0_15,
    "recovers 150 N pushes by stepping": C.test_ipm_recovers_150_N_pushes_by_stepping,
    "replay walk60 within 5 cm and 4 cm": C.test_saved_trajectories_replay_walk60,
    "tracks walk60 within 4 cm": C.test_mpc_tracks_walk60,
    "static balance stands 30 s,": RS.test_static_balance_stands_30s_on_a_real_export,
    "SIMBICON walks 60 s,": RS.test_simbicon_walks_60s_on_a_real_export,
    "and IPM walks 60 s": RI.test_ipm_walks_60_s_at_1_mps_on_a_real_export,
    "at 1.0 m/s within 0.15 m/s, each with no root force":
        RI.test_ipm_walks_60_s_at_1_mps_on_a_real_export,
    "| SIMBICON natural | 121 | 0.59 | 0.115 | 7.3 | 19.4 | 0.86 |":
        C.test_the_walkers_gait_figures_at_1_2_m_s,
    "| IPM stepping | 120 | 0.57 | 0.139 | 1.8 | 32.7 | 0.80 |":
        C.test_the_walkers_gait_figures_at_1_2_m_s,
    "| walk60 (mocap) | 100 | 0.72 | 0.06 | 4.0 | 25.3 | 2.8 |": C.test_walk60s_gait_figures,
    "| tolerance (seeds, CPUs) | ±8 | ±0.02 | ±0.01 | ±0.2 | ±1.5 | ±0.3 |":
        C.test_the_walkers_gait_figures_at_1_2_m_s,
    "with a margin of at least 10 % (or the spread between seeds, if":
        C.test_mpc_tracks_walk60,
    "as it does every force below it in 50 N steps": C.test_ipm_recovers_150_N_pushes_by_stepping,
    # the protocol of the push figures (tests/test_claims.py's _protocol, used by every push test)
    "Pushes are 0.2 s long, at 4 phases of the stride":
        C.test_ipm_recovers_150_N_pushes_by_stepping,
    "(walkers, on the chest) or 4 moments": C.test_ipm_recovers_150_N_pushes_by_stepping,
    "(standing controllers, on the pelvis) x 2 seeds": C.test_ipm_recovers_150_N_pushes_by_stepping,
    "| at 1.2 m/s | cadence /min |": C.test_the_walkers_gait_figures_at_1_2_m_s,
    "How the walkers walk next to motion capture, at 1.2 m/s from the standing pose":
        C.test_the_walkers_gait_figures_at_1_2_m_s,
    "own time step, SIMBICON's 1 ms,":
        C.test_the_walkers_gait_figures_at_1_2_m_s,
    "learned in\none hour on 2 cores, tracks its looped clip for 20 s within 6 cm":
        C.test_the_bundled_policy_tracks_looped_walk60,
    "the bundled policy tracks looped walk60 for 20 s within 6 cm":
        C.test_the_bundled_policy_tracks_looped_walk60,
}

#: README pattern -> the bounds its numbers must equal, in order (the tests' constants)
BOUNDS = {
    r"On the bundled humanoid \(([\d.]+) m, ([\d.]+) kg\)": (1.63, 70),
    r"`hand_of_god` .*? tracks walk60 within ([\d.]+) cm": (C.HAND_OF_GOD_WALK60_CM,),
    r"`static_balance` .*? stands ([\d.]+) s under ([\d.]+) N random pushes; survives "
    r"([\d.]+) N pushes": (C.STAND_S, C.RANDOM_PUSH_N, C.STATIC_BALANCE_PUSH_N),
    r"`simbicon` .*? walks ([\d.]+) s in either gait; the `walk` gait survives ([\d.]+) N":
        (C.WALK_S, C.SIMBICON_PUSH_N),
    r"`ipm` .*? walks ([\d.]+) s at a commanded ([\d.]+) m/s within ([\d.]+) m/s; recovers "
    r"([\d.]+) N": (C.WALK_S, C.IPM_SPEED_MPS, C.IPM_SPEED_TOL, C.IPM_PUSH_N),
    r"replay walk60 within ([\d.]+) cm and ([\d.]+) cm": (C.SAMCON_REPLAY_CM, C.CMAES_REPLAY_CM),
    r"`mpc` .*? tracks walk60 within ([\d.]+) cm": (C.MPC_WALK60_CM,),
    r"`policy` .*? tracks looped walk60 for ([\d.]+) s within ([\d.]+) cm":
        (C.POLICY_LOOP_S, C.POLICY_LOOP_CM),
    r"learned in\s+one hour on (\d+) cores, tracks its looped clip for ([\d.]+) s within "
    r"([\d.]+) cm": (C.POLICY_LEARN_CORES, C.POLICY_LOOP_S, C.POLICY_LOOP_CM),
    r"\| tolerance \(seeds, CPUs\) \|" + r" ±([\d.]+) \|" * 6: C.GAIT_TOLERANCE,
    r"Pushes are ([\d.]+) s long, at (\d+) phases of the stride\s+\(walkers, on the chest\) or "
    r"(\d+) moments\s+\(standing controllers, on the pelvis\) x (\d+) seeds":
        (C._protocol(50).push_duration, C._protocol(50).phases, C._protocol(50).phases,
         len(C._protocol(50).seeds)),
    r"every force below it in (\d+) N steps": (C.PUSH_STEP_N,),
    r"static balance stands ([\d.]+) s,\s+SIMBICON walks ([\d.]+) s, and IPM walks ([\d.]+) s\s+"
    r"at ([\d.]+) m/s within ([\d.]+) m/s": (RS.STAND_S, RS.WALK_S, RI.WALK_S, RI.SPEED_MPS,
                                             RI.SPEED_TOL),
}


def test_the_readmes_numbers_are_the_tests_bounds():
    text = README.read_text()
    for pattern, bounds in BOUNDS.items():
        m = re.search(pattern, text, re.S)
        assert m, f"README.md no longer matches {pattern!r}: update BOUNDS"
        stated = tuple(float(x) for x in m.groups())
        assert stated == tuple(float(b) for b in bounds), (pattern, stated, bounds)


def test_every_claim_has_its_bound_read_from_the_readme():
    """Each table row's claim is matched by one of BOUNDS (a new figure needs its bound)."""
    text = README.read_text()
    # the controllers whose last cell (what it does) has a figure
    rows = [m.group(0) for m in re.finditer(r"^\| `[a-z_]+`.*\| ([^|\n]*\d[^|\n]*) \|$", text,
                                            re.M)]
    assert len(rows) >= 6
    for row in rows:
        assert any(re.search(p, row) for p in BOUNDS), f"no bound read from: {row}"


#: numbers in the README that are not claims about the software, and why
NOT_CLAIMS = {
    r"## A tour in \d+ seconds": "a time, measured by the benchmark `python -m mjchar.perf.tour` "
                                 "(speed lives in benchmarks, not tests)",
    r"takes about \d+ minutes on a 2-core machine, \d+ of them": "the test command's duration, "
        "measured on a fresh clone (speed lives in benchmarks, not tests)",
    r"-n 2 -p xdist": "options in a command (both cores)",
    r"Python >= 3\.11": "a requirement",
    r"et al\. \d{4}": "the year of a cited paper",
    r"torch==2\.13\.0": "a package version",
    r"Apache License 2\.0": "the licence's name",
    r"DeepMimic-style imitation of a clip, 30 Hz": "the env's documented control rate, a default",
    r"frames 0\.1 s apart": "a picture's caption",
    r"--duration \d+|--speed 1\.2|--speed 1\.0|--push 100|--heading 90|speed=1\.2|duration=20\.0":
        "options in a command",
    r"GAMES-105": "a course's name",
    r"status 2": "the exit status of an error (asserted by the CLI tests)",
    r"mjchar/Imitation-v0|mjchar/Stand-v0|walk60|mjchar-\*\.whl": "names",
}


def _prose(text: str) -> str:
    """The README without its code blocks, image lines and link targets."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    text = re.sub(r"^!\[.*$", "", text, flags=re.M)
    return re.sub(r"\]\([^)]*\)", "]", text)


def test_every_number_in_the_readme_is_a_claim_with_a_test():
    text = _prose(README.read_text())
    for phrase in CLAIMS:
        assert phrase in text, f"README.md no longer says {phrase!r}: update CLAIMS"
        text = text.replace(phrase, " ")
    for pattern in NOT_CLAIMS:
        text = re.sub(pattern, " ", text)
    loose = [(n + 1, line.strip()) for n, line in enumerate(text.splitlines())
             if re.search(r"(?<![\w.-])\d+(\.\d+)?(?![\w-])", line)]
    assert not loose, ("numbers in README.md with no claims test (add the phrase to CLAIMS with "
                       "its test in tests/test_claims.py): "
                       + "; ".join(f"{line}" for _, line in loose))


def _marks(test) -> set[str]:
    """The names of the marks on a test function and on its module."""
    import sys

    module = getattr(sys.modules[test.__module__], "pytestmark", [])
    module = module if isinstance(module, list) else [module]
    return {m.name for m in [*getattr(test, "pytestmark", []), *module]}


def test_every_claim_test_is_in_the_claims_tier():
    for test in set(CLAIMS.values()):
        assert callable(test) and "claims" in _marks(test), test.__name__
    assert C.pytestmark.name == "claims"


def _ci_commands() -> list[str]:
    lines = (README.parent / ".ci" / "run").read_text().splitlines()
    return [line for line in lines
            if line and not line.startswith(("#", "set ", "cd ", "export ", "test ",
                                             "command -v "))]


def test_ci_runs_the_readmes_test_command_then_the_slow_and_claims_tiers():
    """`.ci/run` runs exactly the README's second set-up command, then the slow and claims
    tiers together, each on both cores, with CI set; the README gives the second command."""
    readme = README.read_text()
    setup = re.search(r"## Quick start.*?```bash\n(.*?)```", readme, re.S).group(1)
    commands = [line for line in setup.splitlines() if line and not line.startswith("#")]
    assert len(commands) == 2, "the quick start has exactly two set-up commands"
    assert commands[1].endswith("python -m pytest -q -n 2 -p xdist")
    ci = _ci_commands()
    long_tiers = 'python -m pytest -q -m "slow or claims" -n 2 -p xdist --dist worksteal'
    assert ci == [commands[1], long_tiers]
    assert f"`{long_tiers}`" in readme
    assert 'export CI="${CI:-true}"' in (README.parent / ".ci" / "run").read_text()


def test_ci_stops_at_once_without_the_shared_data(tmp_path):
    """A clone with no ../shared/data: `.ci/run` fails before installing anything, saying why."""
    import shutil
    import subprocess

    repo = tmp_path / "clone"
    (repo / ".ci").mkdir(parents=True)
    shutil.copy(README.parent / ".ci" / "run", repo / ".ci" / "run")
    p = subprocess.run(["bash", str(repo / ".ci" / "run")], capture_output=True, text=True,
                       timeout=60, env={"PATH": "/usr/bin:/bin"})
    assert p.returncode == 1 and not (repo / ".venv").exists()
    assert "../shared/data" in p.stderr and len(p.stderr.splitlines()) == 1
