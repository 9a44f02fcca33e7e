"""The bench's progress bar: its ETA weighs each cell by its measured cost, and it is drawn
only on a terminal.

A cell's cost is its CPU seconds measured in a recorded ``--quick`` run (``cell_costs.json``,
per cell, scaled to the reference machine); the full run's cells scale those by the ratio of
their rough step counts (:func:`~mjchar.bench.matrix.cell_cost`); a cell never measured (a
newly registered controller) counts its rough step count at the push searches' measured rate.
The bar advances by a cell's cost when the cell finishes, so its ETA is the remaining cells'
cost at the rate the finished ones ran, however they are ordered. Into a file or a pipe it
draws nothing: the per-cell lines say how far the run is.
"""

from __future__ import annotations

import json
import sys
from functools import cache
from importlib import resources

#: reference CPU seconds per unit of :func:`~mjchar.bench.matrix.cell_cost` (the push
#: searches' measured rate) and the fixed cost of a cell (worker set-up, the clip, the model)
_PER_STEP_S, _OVERHEAD_S = 47e-6, 5.0


@cache
def _measured() -> dict[str, float]:
    text = resources.files("mjchar.bench").joinpath("cell_costs.json").read_text()
    return dict(json.loads(text)["quick"])


def expected_cost(name: str, scenario: str, config, cell_cost) -> float:
    """Reference CPU seconds the cell ``name / scenario`` takes under ``config``;
    ``cell_cost(name, scenario, config)`` is the rough step count
    (:func:`~mjchar.bench.matrix.cell_cost`)."""
    from .config import quick_config

    measured = _measured().get(f"{name} / {scenario}")
    rough = cell_cost(name, scenario, config)
    if measured is None:
        return _OVERHEAD_S + rough * _PER_STEP_S
    if config.quick:
        return measured
    return measured * rough / max(cell_cost(name, scenario, quick_config()), 1.0)


def progress_bar(costs: list[float], enabled: bool, desc: str):
    """A bar over cells of the given costs (advance it with :func:`advance`); disabled unless
    ``enabled`` and standard error is a terminal."""
    from tqdm import tqdm

    on_terminal = bool(getattr(sys.stderr, "isatty", lambda: False)())
    bar = tqdm(total=max(sum(costs), 1e-9), desc=desc, file=sys.stderr,
               disable=not (enabled and on_terminal), dynamic_ncols=True, leave=True,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} "
                          "[{elapsed} elapsed, about {remaining} left]")
    bar.cells = (0, len(costs))
    bar.set_postfix_str(f"0/{len(costs)} cells", refresh=False)
    return bar


def advance(bar, cost: float) -> None:
    """One cell of ``cost`` finished."""
    done, total = bar.cells
    bar.cells = (done + 1, total)
    bar.set_postfix_str(f"{done + 1}/{total} cells", refresh=False)
    bar.update(cost)
