"""The push-recovery protocol (controllers/core/push_protocol.py): the grid, the figures from a
rate curve (non-monotone survival included), the unpushed check, the run length, and that
worker processes do not change the result."""

from __future__ import annotations

import json

import pytest

from mjchar.controllers.core.scenarios import push_search as P
from mjchar.controllers.core.scenarios.push_search import (
    PushProtocol,
    PushProtocolError,
    largest_force,
    run_push,
    survival_rates,
)


def test_grid_ends_at_the_cap():
    assert PushProtocol.grid(100.0, 25.0).forces == (25.0, 50.0, 75.0, 100.0)
    assert PushProtocol.grid(110.0, 25.0).forces == (25.0, 50.0, 75.0, 100.0, 110.0)
    for bad in [dict(cap=0.0, resolution=25.0), dict(cap=100.0, resolution=200.0)]:
        with pytest.raises(PushProtocolError):
            PushProtocol.grid(**bad)
    with pytest.raises(PushProtocolError, match="ascending"):
        PushProtocol(forces=(50.0, 25.0)).check()
    with pytest.raises(PushProtocolError, match="directions"):
        PushProtocol(forces=(50.0,), directions=("up",)).check()


def test_largest_force_is_the_last_one_before_any_failure():
    forces = [25, 50, 75, 100, 125]
    assert largest_force(forces, [1, 1, 1, 1, 1], 1.0) == 125
    assert largest_force(forces, [1, 1, 0.5, 1, 1], 1.0) == 50  # 100 and 125 survive: ignored
    assert largest_force(forces, [1, 1, 0.9, 0.95, 0.0], 0.9) == 100
    assert largest_force(forces, [0.5, 1, 1, 1, 1], 1.0) == 0.0
    assert largest_force(forces, [1, 1], 1.0) == 50  # a curve stopped early


def test_non_monotone_survival_gives_a_rate_curve_and_the_safe_figure(monkeypatch):
    """A controller whose survival flips with force: at 75 N half the phases fail, at 100 N
    every run survives again, at 125 N every run falls. The curve shows all of it; the 100 %
    figure is 50 N (the largest force below which every grid point survived), not 100 N."""
    def fake(task):
        if task.force == 0.0:
            ok = True
        elif task.force == 75.0:
            ok = task.phase < 0.5
        else:
            ok = task.force <= 100.0
        return {"direction": task.direction, "force_N": task.force, "phase": task.phase,
                "seed": task.seed, "survived": ok, "fell": not ok, "fall_time_s": None,
                "reason": None, "push_time_s": 1.0}

    monkeypatch.setattr(P, "run_push", fake)
    protocol = PushProtocol.grid(200.0, 25.0, phases=4, seeds=(0, 1), directions=("forward",))
    r = survival_rates("static_balance", protocol)
    curve = r.curves["forward"]
    assert curve["forces_N"] == [25.0, 50.0, 75.0, 100.0, 125.0]  # stops after the first 0 %
    assert curve["rates"] == [1.0, 1.0, 0.5, 1.0, 0.0]
    assert r.largest_100_N["forward"] == 50.0 and r.largest_90_N["forward"] == 50.0
    assert not r.at_cap["forward"]
    assert len(r.runs) == 5 * 4 * 2 and len(r.unpushed) == 2
    assert "forward: 100 % up to 50 N" in r.summary()
    json.dumps(r.to_dict())  # JSON-ready


def test_a_controller_that_falls_unpushed_has_no_figures():
    """Stable PD alone holds the stiff T-pose for about 5 s: a run 5 s past the push is long
    enough to see it fall unpushed, so it gets no push figure (it used to get one from a 3 s
    window)."""
    protocol = PushProtocol(forces=(50.0,), phases=1, seeds=(0,))
    r = survival_rates("spd", protocol)
    assert r.falls_unpushed and not r.runs and not r.largest_100_N
    assert r.unpushed[0]["fell"] and r.unpushed[0]["fall_time_s"] < 6.2
    assert "falls unpushed" in r.summary()


def test_every_run_lasts_the_window_after_the_push():
    protocol = PushProtocol(forces=(40.0,), phases=2, seeds=(3,), after=1.0)
    task = P.PushTask("static_balance", "left", 40.0, 0.5, 3, protocol)
    rec = run_push(task)
    assert rec["survived"] and rec["push_time_s"] == pytest.approx(1.5)
    r, ok = P.simulate_push(task)
    assert ok and r.sim_time_s == pytest.approx(1.5 + 0.2 + 1.0, abs=0.01)
    assert r.push_N == 40.0 and r.push_direction_deg == 90.0


def test_worker_processes_give_the_same_rates():
    protocol = PushProtocol(forces=(100.0, 150.0), phases=2, seeds=(0, 1),
                            directions=("backward",), after=1.0)
    one = survival_rates("static_balance", protocol, processes=1)
    two = survival_rates("static_balance", protocol, processes=2)
    assert one.to_dict() == two.to_dict()


def test_the_docs_state_the_protocol_in_the_words_of_the_code():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "push-protocol.md").read_text()
    assert P.__doc__.strip() in doc


def test_curves_stopped_below_90_percent_give_the_same_figures():
    full = PushProtocol(forces=(100.0, 200.0, 300.0, 400.0), phases=2, seeds=(0,),
                        directions=("forward", "backward"), after=1.0)
    short = PushProtocol(**{**full.to_dict(), "forces": full.forces, "seeds": full.seeds,
                            "directions": full.directions, "full_curves": False})
    a = survival_rates("static_balance", full)
    b = survival_rates("static_balance", short)
    assert (a.largest_100_N, a.largest_90_N, a.at_cap) == \
        (b.largest_100_N, b.largest_90_N, b.at_cap)
    assert len(b.runs) <= len(a.runs)
    for d, c in b.curves.items():  # each short curve ends at its first rate below 90 %
        assert all(r >= 0.9 for r in c["rates"][:-1])
        assert c["rates"][-1] < 0.9 or len(c["rates"]) == len(full.forces)
        assert c["rates"] == a.curves[d]["rates"][:len(c["rates"])]
    assert "below 90 %" in short.describe() and "below 90 %" not in full.describe()
