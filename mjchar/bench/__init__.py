"""``mjchar bench``: every registered controller in every scenario that makes sense for it, one
report.

- :mod:`~mjchar.bench.config`: :class:`BenchConfig` (:func:`quick_config`, :func:`full_config`),
  :class:`PerfConfig`, paths and JSON helpers.
- :mod:`~mjchar.bench.matrix`: the controller x scenario matrix read from the controller
  registry, and the runner of its cells (:func:`run_matrix`).
- :mod:`~mjchar.bench.performance`: the performance section (:func:`run_performance`).
- :mod:`~mjchar.bench.report`: table rows, expectations, terminal and Markdown tables, stills.
- :mod:`~mjchar.bench.schema`: the results document's JSON Schema and :func:`validate`.
- :mod:`~mjchar.bench.plots`: the PNG plots (matplotlib, the ``bench`` extra).
- :mod:`~mjchar.bench.runner`: :func:`run_bench`, which runs it all and writes the outputs.

The CLI is :mod:`mjchar.commands.bench`. The JSON document is described in ``docs/bench.md``
and ``mjchar/bench/schema.json``.
"""

from .config import (
    DIRECTION_NAMES,
    BenchConfig,
    BenchError,
    PerfConfig,
    full_config,
    json_ready,
    quick_config,
)
from .matrix import (
    availability,
    bench_specs,
    expected_cells,
    find_trajectories,
    matrix,
    run_matrix,
    select_cells,
)
from .performance import run_performance
from .report import check_expectations, format_performance, format_table, markdown_table, table_rows
from .runner import exit_status, physics_view, run_bench, write_json
from .schema import load_schema, validate

__all__ = ["DIRECTION_NAMES", "BenchConfig", "BenchError", "PerfConfig",
           "availability", "bench_specs", "check_expectations", "exit_status",
           "expected_cells", "find_trajectories", "format_performance", "format_table",
           "full_config", "json_ready", "load_schema", "markdown_table", "matrix",
           "physics_view", "quick_config", "run_bench", "run_matrix", "run_performance",
           "select_cells", "table_rows", "validate", "write_json"]
