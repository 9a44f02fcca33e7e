"""The saved SAMCON and CMA-ES trajectories shipped in assets/trajectories (the bench's replay
rows) still replay on the bundled humanoid with the results documented in docs/sampling.md."""

from __future__ import annotations

import pytest

from mjchar.bench import find_trajectories
from mjchar.bvh.bundled.assets import TRAJECTORIES as TRAJECTORY_DIR
from mjchar.controllers.sampling.trajectory import load_trajectory, replay


def test_the_bench_finds_one_trajectory_per_replay_row():
    found = find_trajectories()
    assert found == {"samcon_replay": TRAJECTORY_DIR / "samcon_walk60.npz",
                     "cmaes_replay": TRAJECTORY_DIR / "cmaes_walk60_1.5s.npz"}


@pytest.mark.parametrize("name, method, tracking, final_root", [
    ("samcon_walk60.npz", "samcon", 0.05, 0.15),
    ("cmaes_walk60_1.5s.npz", "cmaes-track", 0.05, 0.15),
])
def test_bundled_trajectory_replays_open_loop_without_falling(name, method, tracking, final_root):
    path = TRAJECTORY_DIR / name
    assert load_trajectory(path).metadata["method"] == method
    r = replay(path)
    assert not r.fell, r.fall_reason
    assert r.root_force_mean_N == 0.0
    assert r.tracking_error_m < tracking
    assert r.extra["final_root_error_m"] < final_root
    again = replay(path)
    assert again.tracking_error_m == r.tracking_error_m  # open-loop replay is deterministic
