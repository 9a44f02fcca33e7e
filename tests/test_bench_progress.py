"""The bench's progress: the ETA weighs the cells by their measured costs, and no bar is
drawn into a file or a pipe."""

from __future__ import annotations

import io
import json
from importlib import resources

from mjchar.bench.config import full_config, quick_config
from mjchar.bench.matrix import cell_cost
from mjchar.bench.progress import advance, expected_cost, progress_bar


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_quick_cells_cost_what_was_measured_and_full_ones_more():
    measured = json.loads(resources.files("mjchar.bench").joinpath("cell_costs.json")
                          .read_text())["quick"]
    q, f = quick_config(), full_config()
    for cell, cost in measured.items():
        name, scenario = cell.split(" / ")
        assert expected_cost(name, scenario, q, cell_cost) == cost
        assert expected_cost(name, scenario, f, cell_cost) >= cost * 0.999
    # the longest cell dwarfs the shortest, as measured (a count of cells would not)
    longest = expected_cost("simbicon", "push-search", q, cell_cost)
    assert longest > 50 * expected_cost("pd", "track", q, cell_cost)


def test_the_bar_advances_by_cost(monkeypatch):
    monkeypatch.setattr("sys.stderr", _Terminal())
    bar = progress_bar([90.0, 5.0, 5.0], True, "bench")
    advance(bar, 90.0)  # one cell of three, nine tenths of the work
    assert bar.n / bar.total == 0.9
    assert "1/3 cells" in str(bar)
    bar.close()


def test_no_bar_into_a_file_or_a_pipe(monkeypatch):
    stream = io.StringIO()  # not a terminal
    monkeypatch.setattr("sys.stderr", stream)
    bar = progress_bar([1.0, 1.0], True, "bench")
    advance(bar, 1.0)
    advance(bar, 1.0)
    bar.close()
    assert stream.getvalue() == ""
